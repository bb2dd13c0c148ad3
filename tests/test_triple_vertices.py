"""The compiled triple enumeration finds exactly the vertices qhull finds."""

from __future__ import annotations

import numpy as np
from scipy.spatial import HalfspaceIntersection

from assetgen.geometry.triple_vertices import polytope_vertices_batch


def test_cube():
    eye = np.eye(3)
    cube = np.column_stack([np.vstack([eye, -eye]), np.ones(6)])
    (v,) = polytope_vertices_batch([cube])
    assert len(v) == 8 and np.allclose(np.abs(v), 1.0)


def _random_polytope(rng, m):
    n = rng.normal(size=(m, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return np.column_stack([n, rng.uniform(0.5, 2.0, m)])  # contains the origin


def test_matches_qhull_on_random_polytopes_of_every_size():
    rng = np.random.default_rng(0)
    systems = [_random_polytope(rng, m) for m in rng.integers(8, 40, size=60)]
    eye = np.eye(3)
    box = np.column_stack([np.vstack([eye, -eye]), np.full(6, 3.0)])  # keeps them bounded
    systems = [np.vstack([s, box]) for s in systems]
    for s, v in zip(systems, polytope_vertices_batch(systems), strict=True):
        hs = np.column_stack([s[:, :3], -s[:, 3]])
        want = np.unique(np.round(HalfspaceIntersection(hs, np.zeros(3)).intersections, 9), axis=0)
        got = np.unique(np.round(v, 9), axis=0)
        assert got.shape == want.shape and np.allclose(got, want, atol=1e-9)


def test_empty_polytope_has_no_vertices():
    eye = np.eye(3)
    box = np.column_stack([np.vstack([eye, -eye]), np.ones(6)])
    beyond = np.vstack([box, [[-1.0, 0.0, 0.0, -2.0]]])  # x >= 2 and x <= 1
    empty, full = polytope_vertices_batch([beyond, box])
    assert len(empty) == 0 and len(full) == 8
