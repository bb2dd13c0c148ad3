"""Cells as meshes from plane incidences: closed, outward, exactly convex, qhull's vertices."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull, HalfspaceIntersection

import assetgen.collision.cell_meshes as cm
from assetgen.checks.closed_mesh import check_closed_meshes, convexity_excess

EYE = np.eye(3)
CUBE = np.column_stack([np.vstack([EYE, -EYE]), np.ones(6)])


def _random_polytope(rng, m):
    n = rng.normal(size=(m, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return np.vstack([np.column_stack([n, rng.uniform(0.5, 2.0, m)]), 3 * CUBE])


def _assert_hull_of_its_vertices(mesh, planes):
    """Closed, outward, every fold convex (trimesh at its 1e-8 m tolerance), and the vertices
    those of the polytope (qhull's half-space intersection), with qhull's volume."""
    check_closed_meshes([mesh], ["cell"], convex=True)
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert tm.is_watertight and tm.is_winding_consistent and tm.is_convex and tm.volume > 0
    hs = np.column_stack([planes[:, :3], -planes[:, 3]])
    inner = mesh.vertices.mean(axis=0)
    want = HalfspaceIntersection(hs, inner).intersections
    # qhull gives a corner where k planes meet once per facet through it: merge those
    want = want[np.unique(np.round(want, 7), axis=0, return_index=True)[1]]
    near = np.linalg.norm(want[:, None] - mesh.vertices[None], axis=2)
    assert len(want) == len(mesh.vertices) and near.min(axis=1).max() < 1e-7
    assert tm.volume == pytest.approx(ConvexHull(mesh.vertices).volume, rel=1e-12)


def test_random_polytopes_are_the_hulls_of_their_vertices():
    rng = np.random.default_rng(1)
    systems = [_random_polytope(rng, m) for m in rng.integers(5, 40, size=40)]
    meshes = cm.cell_meshes(systems)
    assert len(meshes) == len(systems)
    for mesh, planes in zip(meshes, systems, strict=True):
        _assert_hull_of_its_vertices(mesh, planes)
        order = np.lexsort(mesh.vertices.T[::-1])
        assert np.array_equal(order, np.arange(len(order)))  # sorted x, then y, then z


def test_degenerate_vertices_where_four_planes_meet():
    """An octahedron (four planes at every vertex) and a square pyramid (four at its apex),
    each with every plane given twice: one vertex per corner, one face per plane."""
    octa = np.array([[x, y, z, 1.0] for x in (1, -1) for y in (1, -1) for z in (1, -1)])
    octa[:, :3] /= np.sqrt(3)
    side = np.array([[1, 0, 1], [-1, 0, 1], [0, 1, 1], [0, -1, 1]]) / np.sqrt(2)
    pyramid = np.vstack([np.column_stack([side, np.full(4, np.sqrt(0.5))]), [0, 0, -1, 0]])
    meshes = cm.cell_meshes([octa, np.vstack([octa, octa]), pyramid, pyramid[::-1]])
    assert [(len(m.vertices), len(m.faces)) for m in meshes] == [(6, 8)] * 2 + [(5, 6)] * 2
    for m, planes in zip(meshes, [octa, octa, pyramid, pyramid], strict=True):
        _assert_hull_of_its_vertices(m, planes)


def test_empty_flat_and_sliver_cells_are_dropped():
    beyond = np.vstack([CUBE, [[-1.0, 0.0, 0.0, -2.0]]])  # x >= 2 and x <= 1: empty
    flat = np.vstack([CUBE, [[0.0, 0.0, -1.0, -1.0]]])  # z >= 1 and z <= 1: a square
    sliver = np.vstack([CUBE, [[0.0, 0.0, -1.0, -(1 - 1e-13)]]])  # 4e-13 m^3
    meshes = cm.cell_meshes([beyond, flat, CUBE, sliver])
    assert len(meshes) == 1 and len(meshes[0].vertices) == 8


def test_near_coincident_planes_go_to_qhull(monkeypatch):
    """A plane tilted 1e-9 from a cube face cuts a few nanometres off one edge: its
    vertices sit on the two planes inconsistently, the faces do not close, and qhull makes
    the cell instead; the mesh is still the cube's hull."""
    calls = []
    qhull = cm._qhull_mesh
    monkeypatch.setattr(cm, "_qhull_mesh", lambda v: calls.append(len(v)) or qhull(v))
    n = np.array([1e-9, 0.0, 1.0]) / np.linalg.norm([1e-9, 0.0, 1.0])
    (mesh,) = cm.cell_meshes([np.vstack([CUBE, [[*n, 1.0]]])])
    assert calls == [8]
    check_closed_meshes([mesh], ["cube"], convex=True)
    assert np.allclose(np.abs(mesh.vertices), 1.0, atol=1e-8) and len(mesh.vertices) == 8


def test_no_qhull_for_the_cells_of_real_modules(monkeypatch):
    from assetgen.collision.exact import exact_pieces
    from assetgen.geometry.solids import build_module
    from assetgen.params.sampler import SamplerConfig, sample_params

    def refuse(v):
        raise AssertionError("a module's cell needed qhull")

    monkeypatch.setattr(cm, "_qhull_mesh", refuse)
    for seed in range(40):
        pieces = exact_pieces(build_module(sample_params(SamplerConfig(), seed)))
        for m in pieces:
            tm = trimesh.Trimesh(m.vertices, m.faces, process=False)
            # where an overlapping piece's planes meet in two vertices tens of nanometres
            # apart, the sliver between them has an ill-determined plane (its corners are
            # snapped up to 17 nm off their face) and trimesh's fold test fails; the mesh
            # is still the hull of its vertices to within the snap
            assert tm.is_convex or convexity_excess(m)[0] < 2.5e-8, seed


def test_cell_fit_finds_meshes_outside_or_short_of_their_cells():
    """A cell's own mesh fits it; moved, it reaches past a plane; missing a corner (the hull
    of the rest), it has triangles on none of the cell's planes."""
    octa = np.column_stack([np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T, np.ones(8)])
    octa[:, :3] /= np.sqrt(3)
    cube, solid = cm.cell_meshes([CUBE, octa])
    worst, loose = cm.cell_fit([cube, solid], [CUBE, octa], 1e-7)  # 20 nm snaps
    assert np.all(np.abs(worst) < 2e-8) and not loose.any()
    moved = type(cube)(cube.vertices + np.array([0.0, 0.0, 1e-3]), cube.faces)
    worst, loose = cm.cell_fit([moved], [CUBE], 1e-7)
    assert worst[0] == pytest.approx(1e-3) and loose[0] == 4  # top and bottom: off their planes
    rest = cube.vertices[1:]
    hull = ConvexHull(rest)
    short = type(cube)(rest, hull.simplices)
    _, loose = cm.cell_fit([short], [CUBE], 1e-7)
    assert loose[0] >= 1


def test_largest_residuals_are_the_portable_products():
    from assetgen.core.portable import matmul

    rng = np.random.default_rng(3)
    meshes = cm.cell_meshes([_random_polytope(rng, 12) for _ in range(5)])
    planes = _random_polytope(rng, 9)
    got = cm.largest_residuals(meshes, planes)
    for m, row in zip(meshes, got, strict=True):
        want = (matmul(m.vertices, planes[:, :3].T) - planes[:, 3]).max(axis=0)
        assert np.array_equal(row, want)


def test_aligned_cell_meshes_keep_the_dropped_cells_places():
    flat = np.vstack([CUBE, [[0.0, 0.0, -1.0, -1.0]]])
    meshes = cm.aligned_cell_meshes([flat, CUBE, flat])
    assert meshes[0] is None and meshes[2] is None and len(meshes[1].vertices) == 8
