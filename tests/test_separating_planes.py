"""Separating-direction bounds: never above the exact distance, tight on exact pieces, and
the collision re-check falls back to python-fcl where they prove nothing."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

import assetgen.collision.pieces as collision
from assetgen.checks.module_checks import fcl_distance, fcl_object, lifted, swept_hull
from assetgen.collision.exact import exact_pieces
from assetgen.collision.separating_planes import (
    edge_cross_directions,
    separation_bounds,
    unit_directions,
)
from assetgen.core.mesh import Mesh
from assetgen.core.stl import parse_stl_triangles_mm, stl_bytes
from assetgen.geometry.solids import build_module, insertion_travel
from assetgen.params.sampler import SamplerConfig, sample_params

from .test_geometry import CORNERS


def _hull(points: np.ndarray) -> Mesh:
    return Mesh(points, ConvexHull(points).simplices.astype(np.int64))


def test_bound_never_exceeds_the_distance_and_is_exact_along_the_separating_axis():
    rng = np.random.default_rng(0)
    for _ in range(200):
        a = rng.normal(size=(8, 3))
        b = rng.normal(size=(8, 3)) + rng.normal(scale=3.0, size=3)
        dirs = rng.normal(size=(20, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        bound = separation_bounds([a], [b], dirs)[0, 0]
        exact = fcl_distance(fcl_object(_hull(a)), fcl_object(_hull(b)))
        assert bound <= exact + 1e-12
    # Two boxes apart along x by 0.25: the x axis gives the distance exactly.
    box = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    apart = box + np.array([1.25, 0.3, 0.1])
    bound = separation_bounds([apart], [box], unit_directions(np.zeros((0, 3))))
    assert bound[0, 0] == pytest.approx(0.25, abs=1e-15)


def test_edge_crosses_separate_what_no_face_normal_separates():
    # Two tetrahedra whose ridges cross 0.2 apart (A's along x at z = 0, B's along y at
    # z = 0.2): every face normal of both leaves them overlapping; the ridges' cross
    # product (z) gives the distance (the separating axis theorem's edge-edge case).
    h = 0.2
    a = np.array([[-1, 0, 0], [1, 0, 0], [0, -1, -1], [0, 1, -1]], float)
    b = np.array([[0, -1, h], [0, 1, h], [-1, 0, h + 1], [1, 0, h + 1]], float)
    exact = fcl_distance(fcl_object(_hull(a)), fcl_object(_hull(b)))
    faces = np.vstack([ConvexHull(a).equations[:, :3], ConvexHull(b).equations[:, :3]])
    by_faces = separation_bounds([b], [a], np.vstack([faces, -faces]))[0, 0]
    by_crosses = separation_bounds([b], [a], edge_cross_directions(a[1:2] - a[:1], b[1:2] - b[:1]))
    assert by_faces < 0
    assert by_crosses[0, 0] == pytest.approx(h, abs=1e-15)
    assert exact == pytest.approx(h, abs=1e-12)


@pytest.mark.parametrize("name", ["3-gon tilts -15deg", "32-gon", "tallest peg deepest hole"])
def test_bound_is_tight_on_the_stored_exact_pieces(name):
    g = build_module(CORNERS[name])
    design = g.design_pose.matrix()
    start = lifted(design, insertion_travel(g))
    seated = g.peg.transformed(design).vertices
    swept = np.vstack([g.peg.transformed(start).vertices, seated])
    stored = [parse_stl_triangles_mm(stl_bytes(m)).reshape(-1, 3) for m in exact_pieces(g)]
    bound = separation_bounds(stored, [seated, swept], unit_directions(g.hole_planes[:, :3]))
    fcl_peg = fcl_object(g.peg, design)
    fcl_swept = fcl_object(swept_hull(g.peg, start, design))
    near = 0
    for v, b in zip(stored, bound, strict=True):
        piece = fcl_object(Mesh(v, np.arange(len(v)).reshape(-1, 3)))
        exact = np.array([fcl_distance(fcl_peg, piece), fcl_distance(fcl_swept, piece)])
        assert np.all(b <= exact + 1e-12)
        if exact[0] < 2e-3:  # the pieces around the hole: bound = distance to nanometres
            near += 1
            assert np.all(b >= exact - 1e-8)
    assert near >= len(g.hole_planes)


@pytest.mark.parametrize("seed", [0, 7, 19])
def test_recheck_proves_sampled_modules_without_fcl(seed):
    g = build_module(sample_params(SamplerConfig(), seed))
    gaps = collision.check_pieces(exact_pieces(g), g.peg, g, insertion_travel(g))
    assert gaps["pieces_measured_with_fcl"] == 0
    c = g.params.clearance
    assert c - 1e-6 <= gaps["clearance_lower_bound_m"] <= c + 1e-6
    assert c - 1e-6 <= gaps["insertion_lower_bound_m"] <= c + 1e-6


def test_recheck_measures_with_fcl_what_no_direction_proves(monkeypatch):
    g = build_module(CORNERS["32-gon"])
    pieces = exact_pieces(g)
    proven = collision.check_pieces(pieces, g.peg, g, insertion_travel(g))
    monkeypatch.setattr(
        collision, "separation_bounds", lambda sets, bodies, dirs: np.zeros((len(sets), 2))
    )
    measured = collision.check_pieces(pieces, g.peg, g, insertion_travel(g))
    assert measured["pieces_measured_with_fcl"] == len(pieces)
    # FCL's exact distances, which the proven bounds stay under by at most nanometres
    for key in ("clearance_lower_bound_m", "insertion_lower_bound_m"):
        assert proven[key] <= measured[key] + 1e-12
        assert measured[key] - proven[key] < 1e-8
