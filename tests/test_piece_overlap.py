"""The exact pieces overlap at their internal seams: their union is still exactly the
module (nothing missing, nothing outside, no clearance lost), and every point near a seam
lies in two pieces."""

from __future__ import annotations

import math

import manifold3d as m3
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from assetgen.checks.module_checks import CheckError
from assetgen.collision.exact import OVERLAP, exact_decomposition, exact_pieces, local_footprint
from assetgen.collision.pieces import UNION_TOLERANCE, check_union, collision_pieces
from assetgen.core.inline_mesh import stored
from assetgen.core.mesh import Mesh
from assetgen.geometry.solids import build_module, insertion_travel
from assetgen.params.sampler import SamplerConfig, sample_params

from .test_geometry import CORNERS, corner

DEG = math.pi / 180
MODULES = {
    "circle (32-gon)": CORNERS["32-gon"],
    "triangle": CORNERS["3-gon tilts -15deg"],
    "strongly tilted hexagon": corner(
        n_vertices=6,
        circumradius=0.015,
        aspect_ratio=0.8,
        taper=0.1,
        peg_height=0.05,
        hole_depth_fraction=0.6,
        hole_x=0.0,
        hole_y=0.0,
        hole_tilt_x=28 * DEG,
        hole_tilt_y=-25 * DEG,
    ),
    # thinner than twice the overlap: the sleeve rises half the plate into it
    "thin plate": corner(n_vertices=5, aspect_ratio=0.7, plate_thickness=0.003),
    "seed 0": sample_params(SamplerConfig(), 0),
    "seed 4 (circle)": sample_params(SamplerConfig(), 4),
}


def to_manifold(mesh: Mesh) -> m3.Manifold:
    return m3.Manifold(
        m3.Mesh(
            vert_properties=np.asarray(mesh.vertices, np.float32),
            tri_verts=np.asarray(mesh.faces, np.uint32),
        )
    )


def volume(meshes: list[Mesh]) -> float:
    t = np.vstack([m.vertices[m.faces] for m in meshes])
    return float(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6.0)


def in_module(g, p: np.ndarray, margin: float = 1e-7) -> np.ndarray:
    """Points (n, 3) inside the module by at least `margin` (m), from its half-spaces:
    in the plate or the sleeve, and outside the hole."""
    t, half = g.params.plate_thickness, g.params.plate_size / 2
    plate = np.all(np.abs(p[:, :2]) <= half - margin, axis=1)
    plate &= (p[:, 2] <= -margin) & (p[:, 2] >= -t + margin)
    sp = g.sleeve_planes
    sleeve = np.all(p @ sp[:, :3].T - sp[:, 3] <= -margin, axis=1)
    hp = g.hole_planes
    return (plate | sleeve) & ((p @ hp[:, :3].T - hp[:, 3]).max(axis=1) >= margin)


def containing(pieces: list[Mesh], p: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """(points, pieces) bool: point in the piece's hull (qhull's facets, within tol)."""
    out = np.empty((len(p), len(pieces)), bool)
    for j, m in enumerate(pieces):
        eq = ConvexHull(m.vertices).equations
        out[:, j] = np.all(p @ eq[:, :3].T + eq[:, 3] <= tol, axis=1)
    return out


def keys(g, systems: list[np.ndarray]) -> list[tuple[int, bool]]:
    """Each piece's hole plane (the one it lies beyond; -1 for a far-plate box) and whether
    it is a wall piece (it rises from the sleeve through the plate: no plate underside among
    its half-spaces), read off its half-spaces."""
    k = len(g.hole_planes)
    underside = np.array([0.0, 0.0, -1.0, g.params.plate_thickness])
    out = []
    for rows in systems:
        beyond = [i for i in range(k) if np.any(np.all(rows == -g.hole_planes[i], axis=1))]
        wall = not np.any(np.all(np.isclose(rows, underside, rtol=0, atol=1e-12), axis=1))
        out.append((beyond[0] if beyond else -1, bool(beyond) and wall))
    return out


def grown_from(pieces: list[Mesh], cell: Mesh) -> list[Mesh]:
    """The pieces that contain `cell` (20 nm snaps): the one it grew into among them."""
    return [m for m, inside in zip(pieces, containing(pieces, cell.vertices, 5e-8).all(axis=0),
                                   strict=True) if inside]  # fmt: skip


@pytest.fixture(scope="module", params=list(MODULES))
def module(request):
    g = build_module(MODULES[request.param])
    pieces, systems = exact_decomposition(g)
    cells, cell_systems = exact_decomposition(g, overlap=0.0)
    return g, pieces, cells, keys(g, systems), keys(g, cell_systems)


def test_union_of_the_pieces_is_the_module(module):
    g, pieces, *_ = module
    union = m3.Manifold.batch_boolean([to_manifold(m) for m in pieces], m3.OpType.Add)
    assert union.volume() == pytest.approx(g.module_volume, rel=1e-6)
    # and nothing outside it: adding the module adds no volume
    both = m3.Manifold.batch_boolean([union, to_manifold(g.module)], m3.OpType.Add)
    assert both.volume() == pytest.approx(g.module_volume, rel=1e-6)
    # the pieces do overlap: their volumes add up to more than the module's
    assert volume(pieces) > g.module_volume * (1 + 1e-3)


def test_each_face_of_the_hole_is_a_face_of_one_piece_only(module):
    """No two pieces share a face of the hole: a peg face lying flat on two coplanar faces
    of two pieces is where MuJoCo 4.0's multiccd returned contacts tens of mm deep
    (docs/physics.md). Each hole plane holds faces (triangles of positive area) of one
    piece, its wall piece; neighbours meet it along edges only."""
    g, pieces, *_ = module
    hp = g.hole_planes
    for i, (n, d) in enumerate(zip(hp[:, :3], hp[:, 3], strict=True)):
        holders = []
        for s, m in enumerate(pieces):
            tri = m.vertices[m.faces]
            on = np.all(np.abs(tri @ n - d) < 1e-7, axis=1)
            # on the hole's face itself, not on its plane past the hole's edges (inside the
            # material, where a neighbouring wall piece covers it)
            centre = tri.mean(axis=1)
            on &= (centre @ hp[:, :3].T - hp[:, 3]).max(axis=1) < 1e-7
            t = tri[on]
            area = np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
            if area.sum() > 1e-12:
                holders.append(s)
        assert len(holders) == 1, (i, holders)


def test_every_point_of_the_module_is_in_a_piece(module):
    g, pieces, *_ = module
    rng = np.random.default_rng(0)
    lo = np.min([m.vertices.min(axis=0) for m in pieces], axis=0)
    hi = np.max([m.vertices.max(axis=0) for m in pieces], axis=0)
    p = rng.uniform(lo, hi, size=(40_000, 3))
    p = p[in_module(g, p)]
    assert len(p) > 2000
    assert containing(pieces, p).any(axis=1).all()


def test_points_near_every_seam_lie_in_two_pieces(module):
    """From each face of each cell of the exact tiling (the pieces without overlap), step
    0.3 - 0.9 x OVERLAP outward: where the step stays in the module, beyond the cell's own
    hole plane and in its material (the plate, or the sleeve), the cell's piece reaches it, and so
    does the piece of the cell it is in: two pieces. The plate's and sleeve's outer faces
    and the hole's step out of the module; the plate's underside steps out of the plate
    (there the sleeve reaches up into the plate instead)."""
    g, pieces, cells, _, cell_owners = module
    t = g.params.plate_thickness
    rng = np.random.default_rng(1)
    tested = {"rival": 0, "local box side": 0, "into a wall piece": 0}
    for cell, key in zip(cells, cell_owners, strict=True):
        if key[0] < 0:
            continue  # a far-plate box: see test_far_plate_seams_overlap
        grown = grown_from(pieces, cell)
        assert grown, "a cell inside no piece"
        tri = cell.vertices[cell.faces]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area = np.linalg.norm(normal, axis=1)
        keep = area > 1e-10
        tri, normal = tri[keep], normal[keep] / area[keep, None]
        w = rng.dirichlet(np.ones(3), size=(20, len(tri)))
        x = np.einsum("stk,tkj->stj", w, tri).reshape(-1, 3)
        n = np.tile(normal, (20, 1))
        step = rng.uniform(0.3, 0.9, size=len(x)) * OVERLAP
        p = x + step[:, None] * n
        s = p @ g.hole_planes[key[0], :3] - g.hole_planes[key[0], 3]
        ok = in_module(g, p, 1e-6) & (s >= 1e-6)
        if key[1]:  # a wall piece: in the sleeve's outline, from its floor to the top
            sp = g.sleeve_planes[: len(g.hole_planes) + 4]
            ok &= np.all(p @ sp[:, :3].T - sp[:, 3] <= -1e-6, axis=1)
            ok &= p[:, 2] <= -1e-6
        else:
            ok &= p[:, 2] >= -t + 1e-6
        p, n = p[ok], n[ok]
        inside = containing(pieces, p)
        assert containing(grown, p).any(axis=1).all()
        assert (inside.sum(axis=1) >= 2).all()
        axis = np.abs(n).max(axis=1) > 1 - 1e-9
        sp = g.sleeve_planes[: len(g.hole_planes) + 4]
        wall = (not key[1]) & np.any(np.abs(n @ sp[:, :3].T + 1.0) < 1e-9, axis=1)
        tested["into a wall piece"] += int(np.sum(wall))
        tested["local box side"] += int(np.sum(axis & (np.abs(n[:, 2]) < 0.5)))
        tested["rival"] += int(np.sum(~axis & ~wall))
    assert min(tested.values()) >= 20, tested


def test_far_plate_seams_overlap(module):
    """The far plate's two boxes along y reach into the two along x: points on either side
    of those seams, away from the local box, lie in two pieces."""
    g, pieces, *_ = module
    lo, hi = local_footprint(g)
    half, t = g.params.plate_size / 2, g.params.plate_thickness
    rng = np.random.default_rng(2)
    points = []
    for x0, outward in ((lo[0], -1.0), (hi[0], 1.0)):
        if abs(x0) >= half - 1e-6:
            continue
        for y in (
            rng.uniform(-half + 1e-3, lo[1] - 1e-3, 20).tolist()
            + rng.uniform(hi[1] + 1e-3, half - 1e-3, 20).tolist()
        ):
            z = rng.uniform(-t, 0.0)
            points.append([x0 + outward * rng.uniform(0.1, 0.9) * OVERLAP, y, z])
    if not points:
        pytest.skip("the local box spans the plate")
    inside = containing(pieces, np.array(points))
    assert (inside.sum(axis=1) >= 2).all()


def test_pieces_keep_the_clearance(module, tmp_path):
    g, *_ = module
    _, rec = collision_pieces(g, insertion_travel(g))
    c = g.params.clearance
    assert c - 1e-6 <= rec["clearance_lower_bound_m"] <= c + 1e-6
    assert c - 1e-6 <= rec["insertion_lower_bound_m"] <= c + 1e-6
    assert rec["overlap_m"] == OVERLAP
    assert rec["volume_ratio"] > 1.001
    assert rec["outside_module_m"] <= UNION_TOLERANCE


def test_without_overlap_the_pieces_tile_the_module(module):
    g, pieces, cells, owners, cell_owners = module
    assert volume(cells) == pytest.approx(g.module_volume, rel=1e-6)
    assert volume(pieces) > volume(cells)
    # each cell grew into one piece, which contains it
    assert len(cells) == len(pieces)
    assert sorted(owners) == sorted(cell_owners)
    for cell in cells:
        assert grown_from(pieces, cell)


def test_a_wide_overlap_stays_inside_the_sleeve():
    """A circle's sleeve pieces reaching 10 mm past their seams cross faces' mitred outer
    planes that their neighbours' do not bound: they get those planes too."""
    g = build_module(CORNERS["32-gon"])
    pieces = exact_pieces(g, overlap=0.01)
    union = m3.Manifold.batch_boolean([to_manifold(m) for m in pieces], m3.OpType.Add)
    assert union.volume() == pytest.approx(g.module_volume, rel=1e-6)
    k = len(g.hole_planes)
    _, systems = exact_decomposition(g, overlap=0.01)
    mitred = [len({tuple(r) for r in s} & {tuple(r) for r in g.sleeve_planes[:k]}) for s in systems]
    assert max(mitred) == k and sorted(mitred)[-2] > 6  # beyond the floor's and a side's own


def test_union_check_refuses_pieces_outside_the_module_or_short_of_their_cells():
    g = build_module(CORNERS["32-gon"])
    pieces, systems = exact_decomposition(g)
    assert check_union(stored(pieces), systems, g)["outside_module_m"] <= UNION_TOLERANCE
    # a wall piece pushed 0.01 mm down: out through the sleeve's floor or walls
    s = next(i for i, (_, wall) in enumerate(keys(g, systems)) if wall)
    moved = list(pieces)
    moved[s] = Mesh(pieces[s].vertices - [0.0, 0.0, 1e-5], pieces[s].faces)
    with pytest.raises(CheckError, match="outside the module"):
        check_union(stored(moved), systems, g)
    # a piece missing a corner: the hull of the rest has a face on none of its planes
    big = int(np.argmax([len(m.vertices) for m in pieces]))
    rest = np.delete(pieces[big].vertices, 0, axis=0)
    hull = ConvexHull(rest)
    faces = hull.simplices.copy()
    flip = np.einsum(
        "ij,ij->i",
        np.cross(rest[faces[:, 1]] - rest[faces[:, 0]], rest[faces[:, 2]] - rest[faces[:, 0]]),
        hull.equations[:, :3],
    )
    faces[flip < 0] = faces[flip < 0][:, ::-1]
    short = list(pieces)
    short[big] = Mesh(rest, faces)
    with pytest.raises(CheckError, match="on none of its cell's planes"):
        check_union(stored(short), systems, g)
