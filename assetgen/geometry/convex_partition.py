"""An exact partition of a simple polygon into convex pieces (Hertel and Mehlhorn, 1983).

manifold3d triangulates the polygon (ear clipping on its own vertices: no new points), then
the diagonals are removed one by one wherever the two pieces they separate stay convex
without it. The pieces are the polygon exactly: their vertices are the polygon's, their
union is it, and they meet only along the remaining diagonals. At most four times the fewest
convex pieces possible (the theorem's bound); a convex polygon stays one piece.

Hand-written: no maintained Python library partitions a polygon into convex pieces without
approximation (CoACD and V-HACD approximate in 3D; CGAL's 2D partition has no kept wheel).
"""

from __future__ import annotations

import manifold3d as mf
import numpy as np

from assetgen.core.portable import norm

CONVEX = 1e-12
"""A corner is convex when the cross product of its unit edges exceeds this (strictly
convex: a straight corner would leave a redundant plane)."""


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def _convex_at(poly: np.ndarray, ring: list[int], k: int) -> bool:
    """Whether ring[k]'s corner turns left (counter-clockwise ring of vertex indices)."""
    o = poly[ring[k]]
    a, b = poly[ring[k - 1]], poly[ring[(k + 1) % len(ring)]]
    u, v = o - a, b - o
    cross = u[0] * v[1] - u[1] * v[0]
    return cross / (float(norm(u)) * float(norm(v))) > CONVEX


def _merged(p: list[int], q: list[int], a: int, b: int) -> list[int]:
    """Rings p (holding the diagonal as a -> b) and q (as b -> a) joined across it."""
    i = p.index(a)
    p = p[i:] + p[:i]  # p = [a, b, ...]
    j = q.index(b)
    q = q[j:] + q[:j]  # q = [b, a, ...]
    return [a, *q[2:], b, *p[2:]]


def convex_partition(poly: np.ndarray, overlap: bool = False) -> list[np.ndarray]:
    """Convex pieces (each (k, 2), counter-clockwise) of a simple counter-clockwise polygon
    (n, 2) without collinear consecutive vertices (polygon_offset.check_simple).

    overlap: each piece also reaches across each of its diagonals into its neighbour, by a
    thin triangle on the diagonal (a new vertex a little way towards the neighbour's
    centroid, as far as the piece stays strictly convex): the union is still the polygon
    exactly, but no two pieces meet face to face. A boolean union of pieces that only touch
    leaves slivers along their shared faces; a simulator's pieces that only touch have a
    seam a corner can catch on."""
    poly = np.asarray(poly, dtype=float)
    tris = np.asarray(mf.triangulate([poly]), dtype=np.int64).reshape(-1, 3)
    rings = []
    for t in tris.tolist():
        if _cross(poly[t[0]], poly[t[1]], poly[t[2]]) < 0:
            t = [t[0], t[2], t[1]]
        rings.append(list(t))
    n = len(poly)
    # the diagonals, in a fixed order (the triangulator's), each with its two rings
    owner: dict[tuple[int, int], int] = {}
    for r, ring in enumerate(rings):  # each directed edge -> its ring
        for k in range(3):
            owner[(ring[k], ring[(k + 1) % 3])] = r
    diagonals = []
    for a, b in owner:
        if (b - a) % n in (1, n - 1) or (b, a) not in owner or a > b:
            continue  # a polygon edge, or the other direction of one already listed
        diagonals.append((a, b))
    alive: dict[int, list[int]] = dict(enumerate(rings))
    where = {i: i for i in alive}  # ring -> the ring it was merged into
    for a, b in diagonals:

        def find(r: int) -> int:
            while where[r] != r:
                r = where[r]
            return r

        p, q = find(owner[(a, b)]), find(owner[(b, a)])
        if p == q:
            continue
        ring = _merged(alive[p], alive[q], a, b)
        k_a, k_b = 0, ring.index(b)
        if _convex_at(poly, ring, k_a) and _convex_at(poly, ring, k_b):
            alive[p] = ring
            del alive[q]
            where[q] = p
    rings = [ring for _, ring in sorted(alive.items())]
    if not overlap:
        return [poly[ring] for ring in rings]
    centres = {}
    for ring in rings:
        for k in range(len(ring)):
            centres[(ring[k], ring[(k + 1) % len(ring)])] = poly[ring].mean(axis=0)
    return [_grown(poly, ring, centres, n) for ring in rings]


GROW = 0.25
"""How far the vertex over a diagonal starts towards the neighbour's centroid (halved
until the grown piece is convex by a margin)."""
MARGIN = 1e-6
"""The grown piece's corners turn by at least this (normalized cross product)."""


def _grown(poly: np.ndarray, ring: list[int], centres: dict, n: int) -> np.ndarray:
    """The piece `ring` with a vertex inserted over each of its diagonals (an edge whose
    reverse belongs to another piece), reaching towards that piece's centroid."""
    diagonals = [
        k
        for k in range(len(ring))
        if (ring[(k + 1) % len(ring)], ring[k]) in centres
        and (ring[(k + 1) % len(ring)] - ring[k]) % n not in (1, n - 1)
    ]
    if not diagonals:
        return poly[ring]
    s = GROW
    for _ in range(40):
        pts = []
        for k, i in enumerate(ring):
            pts.append(poly[i])
            if k in diagonals:
                j = ring[(k + 1) % len(ring)]
                mid = 0.5 * (poly[i] + poly[j])
                pts.append(mid + s * (centres[(j, i)] - mid))
        out = np.array(pts)
        u = np.roll(out, -1, axis=0) - out
        v = np.roll(u, -1, axis=0)
        turn = (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]) / (
            np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1)
        )
        if (turn > MARGIN).all():
            return out
        s /= 2
    return poly[ring]
