"""Convex polytopes given as half-spaces n . x <= d: vertices, transforms and offsets.

The peg, its hole and the sleeve are all intersections of half-spaces; keeping them in this
form makes the clearance exact (a plane moved by `c` along its unit normal) and gives the
convex decomposition of the module for free (see assetgen/collision/exact.py).
"""

from __future__ import annotations

import numpy as np

from assetgen.core.portable import dot, matmul
from assetgen.geometry.triple_vertices import polytope_vertices_batch


def transform_planes(planes: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """Planes (k, 4) rows [n, d] meaning n . x <= d, moved by the (4, 4) transform `matrix`."""
    r, p = matrix[:3, :3], matrix[:3, 3]
    n = matmul(planes[:, :3], r.T)
    return np.column_stack([n, planes[:, 3] + dot(n, p)])


def offset_planes(planes: np.ndarray, distance: float | np.ndarray) -> np.ndarray:
    """Every plane moved outward along its unit normal by `distance` (m)."""
    out = planes.copy()
    out[:, 3] += distance
    return out


def interior_point(planes: np.ndarray, guess: np.ndarray | None = None) -> np.ndarray | None:
    """A point strictly inside {n . x <= d}, or None if the set has no interior.

    Tries `guess` first (cheap); otherwise solves for the Chebyshev centre with an LP.
    """
    if guess is not None and np.all(planes[:, :3] @ guess - planes[:, 3] < -1e-7):
        return guess
    from scipy.optimize import linprog  # rarely needed: its import costs ~0.1 s

    # maximise r subject to n . x + r |n| <= d  (|n| = 1)
    k = len(planes)
    a = np.column_stack([planes[:, :3], np.ones(k)])
    res = linprog(
        c=[0, 0, 0, -1], A_ub=a, b_ub=planes[:, 3], bounds=[(None, None)] * 3 + [(0, 1.0)]
    )
    if not res.success or res.x[3] < 1e-7:
        return None
    return res.x[:3]


def polytope_vertices(planes: np.ndarray) -> np.ndarray:
    """Vertices (m, 3) of the bounded polytope {n . x <= d} (unit normals), by enumerating
    plane triples (assetgen.geometry.triple_vertices); a vertex where more than three planes
    meet comes once per triple through it."""
    (vertices,) = polytope_vertices_batch([planes])
    return vertices
