"""The exact decomposition of a solid with several convex holes (assetgen.collision.carve):
without overlap a tiling (no overlap, no gap), with it a union that is exactly the material
minus the holes; nothing inside a hole, and a non-convex part at exactly its clearance."""

from __future__ import annotations

import fcl
import manifold3d as m3
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog
from scipy.spatial import ConvexHull

from assetgen.collision.carve import carve, carve_cells, farthest_cells
from assetgen.core.mesh import Mesh, cross3
from assetgen.geometry.polytope import transform_planes
from assetgen.geometry.triple_vertices import polytope_vertices_batch

C = 1e-3
MATERIAL_LO, MATERIAL_HI = np.array([-0.05, -0.05, -0.04]), np.array([0.05, 0.05, 0.0])


def box(lo, hi) -> np.ndarray:
    e = np.eye(3)
    return np.vstack([np.column_stack([e, hi]), np.column_stack([-e, -np.asarray(lo)])])


def volume(mesh: Mesh) -> float:
    t = mesh.vertices[mesh.faces]
    return float(np.einsum("ij,ij->i", t[:, 0], cross3(t[:, 1], t[:, 2])).sum() / 6.0)


def solid_mesh(planes: np.ndarray) -> Mesh:
    """The polytope's hull from its exact vertices (no snapping), outward."""
    (v,) = polytope_vertices_batch([planes])
    hull = ConvexHull(v)
    faces = hull.simplices.copy()
    t = v[faces]
    flip = np.einsum(
        "ij,ij->i", cross3(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), hull.equations[:, :3]
    )
    faces[flip < 0] = faces[flip < 0][:, ::-1]
    return Mesh(v, faces)


def depth(planes: np.ndarray) -> float:
    """The radius of the largest ball inside {n . x <= d} (0 if empty or flat): an LP,
    independent of the vertex enumeration the decomposition uses."""
    n = planes[:, :3] / np.linalg.norm(planes[:, :3], axis=1)[:, None]
    d = planes[:, 3] / np.linalg.norm(planes[:, :3], axis=1)
    a = np.column_stack([n, np.ones(len(n))])
    # in millimetres, at HiGHS's tightest tolerances: its default feasibility tolerance
    # (1e-7) in metres would read a flat face as a ball of tens of nanometres
    res = linprog(
        [0, 0, 0, -1],
        A_ub=a,
        b_ub=d * 1e3,
        bounds=[(None, None)] * 3 + [(0, 1e3)],
        options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10},
    )
    return float(res.x[3]) * 1e-3 if res.success else 0.0


def to_manifold(mesh: Mesh) -> m3.Manifold:
    return m3.Manifold(
        m3.Mesh(
            vert_properties=np.asarray(mesh.vertices, np.float64),
            tri_verts=np.asarray(mesh.faces, np.uint32),
        )
    )


def insertion_hole(solid: np.ndarray, clearance: float, top: float = 0.1) -> np.ndarray:
    """A solid's planes moved out by the clearance, open upwards (its +z row capped high
    above the material), as a part inserted along -z needs."""
    h = solid.copy()
    h[:, 3] += clearance
    up = h[:, 2] > 1 - 1e-12
    h[up, 3] = top
    return h


def cell_volume(planes: np.ndarray) -> float:
    (v,) = polytope_vertices_batch([planes])
    return float(ConvexHull(v).volume)


def material_minus_holes_solid(lo, hi, holes) -> m3.Manifold:
    """A box minus the union of the holes, by manifold3d."""
    hole_solid = m3.Manifold.batch_boolean(
        [to_manifold(solid_mesh(h)) for h in holes], m3.OpType.Add
    )
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return m3.Manifold.cube(hi - lo).translate(lo) - hole_solid


def material_minus_holes(lo, hi, holes) -> float:
    """Volume (m^3) of a box minus the union of the holes, by manifold3d."""
    return material_minus_holes_solid(lo, hi, holes).volume()


def assert_union(cells, pieces, holes, solid: m3.Manifold) -> None:
    """The overlapping cells and their pieces make up `solid` (the material minus the
    holes): no cell enters a hole (as in assert_tiles), the pieces' union has the solid's
    volume, and so does their union with it (nothing outside); and they do overlap."""
    assert max(depth(np.vstack([c, h])) for c in cells for h in holes) < 1e-8
    union = m3.Manifold.batch_boolean([to_manifold(p) for p in pieces], m3.OpType.Add)
    assert union.volume() == pytest.approx(solid.volume(), rel=1e-6)
    assert (union + solid).volume() == pytest.approx(solid.volume(), rel=1e-6)
    assert sum(volume(p) for p in pieces) > solid.volume() * (1 + 1e-3)


def assert_tiles(cells, holes, expected_volume, pieces) -> None:
    """No cell enters a hole and no two cells overlap (no ball of 10 nm fits in both: an
    LP; pairs whose boxes are apart are skipped), and the cells' volumes add up to the
    material minus the holes: so they tile it. Within 1e-6: a hole may leave a film of
    material thinner than carve.SOLID inside it, and the pieces' vertices are snapped to a
    20 nm grid; the module's own volume check uses the same bound."""
    assert max(depth(np.vstack([c, h])) for c in cells for h in holes) < 1e-8
    verts = polytope_vertices_batch(cells)
    lo = np.array([v.min(axis=0) for v in verts])
    hi = np.array([v.max(axis=0) for v in verts])
    pairs = [
        (i, j)
        for i in range(len(cells))
        for j in range(i + 1, len(cells))
        if np.all(lo[i] < hi[j]) and np.all(lo[j] < hi[i])
    ]
    assert max((depth(np.vstack([cells[i], cells[j]])) for i, j in pairs), default=0) < 1e-8
    assert sum(cell_volume(c) for c in cells) == pytest.approx(expected_volume, rel=1e-6)
    assert sum(volume(p) for p in pieces) == pytest.approx(expected_volume, rel=1e-6)


def check_carving(solids: list[np.ndarray], clearance: float = C) -> list[Mesh]:
    """Carve the part's clearance hole out of the material block and check everything the
    decomposition promises; returns the pieces."""
    material = box(MATERIAL_LO, MATERIAL_HI)
    holes = [insertion_hole(s, clearance) for s in solids]
    cells = carve_cells(material, holes, overlap=0.0)
    tiles = carve(material, holes, overlap=0.0)
    assert len(tiles) <= len(cells)  # slivers below MIN_PIECE_VOLUME become no piece
    pieces = carve(material, holes)
    # every piece inside the material (convex pieces: their vertices suffice)
    for p in tiles + pieces:
        assert np.all(p.vertices @ material[:, :3].T - material[:, 3] <= 1e-9)
    solid = material_minus_holes_solid(MATERIAL_LO, MATERIAL_HI, holes)
    assert_tiles(cells, holes, solid.volume(), tiles)
    assert_union(carve_cells(material, holes), pieces, holes, solid)
    # the part, in its design pose, is at exactly the clearance from the pieces (python-fcl)
    gaps = []
    for s in solids:
        sm = solid_mesh(s)
        faces = np.column_stack([np.full(len(sm.faces), 3), sm.faces]).ravel()
        part = fcl.CollisionObject(fcl.Convex(sm.vertices, len(sm.faces), faces))
        for p in pieces:
            pf = np.column_stack([np.full(len(p.faces), 3), p.faces]).ravel()
            piece = fcl.CollisionObject(fcl.Convex(p.vertices, len(p.faces), pf))
            gaps.append(fcl.distance(part, piece, fcl.DistanceRequest(), fcl.DistanceResult()))
    assert min(gaps) == pytest.approx(clearance, abs=1e-7)
    return pieces


def test_a_t_shaped_part_gets_an_exact_hole() -> None:
    """A T (a bar on a stem, one solid each): its hole is the union of the two moved-out
    solids; the pieces tile the block around it and the gap is the clearance."""
    stem = box([-0.003, -0.015, -0.03], [0.003, 0.015, 0.0])
    bar = box([-0.01, -0.004, -0.03], [0.01, 0.004, 0.0])
    pieces = check_carving([stem, bar])
    assert 8 <= len(pieces) <= 40


def test_a_cross_hole_through_a_profile() -> None:
    """A 32-gon bolt hole across a square profile, and a slot in one face: two holes in one
    solid, as the profile of an assembly has."""
    profile = box([-0.01, -0.01, -0.03], [0.01, 0.01, 0.03])
    a = np.arange(32) * 2 * np.pi / 32
    shank = np.array(
        [[0, np.cos(t), np.sin(t), 0.0045] for t in a] + [[1, 0, 0, 0.05]] + [[-1, 0, 0, 0.05]]
    )
    slot = box([-0.003, 0.006, -0.05], [0.003, 0.05, 0.05])
    cells = carve_cells(profile, [shank, slot], overlap=0.0)
    tiles = carve(profile, [shank, slot], overlap=0.0)
    solid = material_minus_holes_solid([-0.01, -0.01, -0.03], [0.01, 0.01, 0.03], [shank, slot])
    assert_tiles(cells, [shank, slot], solid.volume(), tiles)
    holes = [shank, slot]
    assert_union(carve_cells(profile, holes), carve(profile, holes), holes, solid)


def faces_on(cells: list[np.ndarray], row: np.ndarray) -> int:
    """How many cells have a facet on the plane of `row` (as a face of theirs: -row)."""
    return sum(bool((np.abs(c + row).max(axis=1) < 1e-12).any()) for c in cells)


def test_a_floor_shared_by_every_hole_is_one_face() -> None:
    """A T's hole (two pieces that share their floor): the floor and each outer wall that
    bounds both pieces from one side are a face of one cell, not of one cell per piece; the
    decomposition stays exact (check_carving)."""
    stem = box([-0.003, -0.015, -0.03], [0.003, 0.015, 0.0])
    bar = box([-0.01, -0.004, -0.03], [0.01, 0.004, 0.0])
    holes = [insertion_hole(s, C) for s in (stem, bar)]
    floor = np.array([0.0, 0.0, -1.0, 0.03 + C])
    assert all((np.abs(h - floor).max(axis=1) < 1e-12).any() for h in holes)
    cells = carve_cells(box(MATERIAL_LO, MATERIAL_HI), holes, overlap=0.0)
    assert faces_on(cells, floor) == 1
    for wall in (np.array([1.0, 0, 0, 0.01 + C]), np.array([0, 1.0, 0, 0.015 + C])):
        assert faces_on(cells, wall) == 1
    check_carving([stem, bar])


def test_a_hole_that_misses_the_material_leaves_it_whole() -> None:
    material = box([0, 0, 0], [0.01, 0.01, 0.01])
    far = box([0.02, 0.02, 0.02], [0.03, 0.03, 0.03])
    (cell,) = carve_cells(material, [far])
    assert cell_volume(cell) == pytest.approx(1e-6, rel=1e-12)


def test_farthest_cells_drop_a_redundant_parallel_plane() -> None:
    """A hole with a redundant plane parallel to a tighter one: the redundant plane's cell
    is empty (it would overlap the tighter plane's), and the other cells do not overlap."""
    hole = np.vstack([box([-1, -1, -1], [1, 1, 1]), [[1.0, 0.0, 0.0, 2.0]]])
    cells = farthest_cells(hole)
    assert len(cells) == 6
    bounded = [np.vstack([c, box([-5, -5, -5], [5, 5, 5])]) for c in cells]
    total = sum(cell_volume(c) for c in bounded)
    assert total == pytest.approx(1000 - 8, rel=1e-12)


@pytest.mark.parametrize(
    ("material", "message"),
    [
        (np.zeros((3, 4)), r"material: expected \(k >= 4, 4\)"),
        (np.column_stack([np.zeros((6, 3)), np.ones(6)]), "zero normal"),
        (box([0, 0, 0], [-1, 1, 1]), "enclose no volume"),
    ],
)
def test_bad_systems_are_named(material, message) -> None:
    with pytest.raises(ValueError, match=message):
        carve_cells(material, [])


extent = st.floats(0.002, 0.02)


@settings(max_examples=12, deadline=None)
@given(
    a=st.tuples(extent, extent, st.floats(0.005, 0.03)),
    b=st.tuples(extent, extent, st.floats(0.005, 0.03)),
    shift=st.tuples(st.floats(-0.008, 0.008), st.floats(-0.008, 0.008)),
    turn=st.floats(0, np.pi),
    clearance=st.sampled_from([0.25e-3, 0.5e-3, 1e-3]),
)
def test_random_two_solid_parts(a, b, shift, turn, clearance) -> None:
    """Any part made of two boxes that overlap, turned about the insertion axis, at the
    paper's clearances: every promise of the decomposition holds."""
    first = box([-a[0] / 2, -a[1] / 2, -a[2]], [a[0] / 2, a[1] / 2, 0.0])
    # the second box overlaps the first (its centre is inside it), so the part is one body
    cx = np.clip(shift[0], -a[0] / 2 + 1e-4, a[0] / 2 - 1e-4)
    cy = np.clip(shift[1], -a[1] / 2 + 1e-4, a[1] / 2 - 1e-4)
    second = box([cx - b[0] / 2, cy - b[1] / 2, -b[2]], [cx + b[0] / 2, cy + b[1] / 2, 0.0])
    rot = np.eye(4)
    rot[:2, :2] = [[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]]
    check_carving([transform_planes(first, rot), transform_planes(second, rot)], clearance)
