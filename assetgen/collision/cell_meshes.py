"""Convex cells as meshes: the hull of each cell's enumerated vertices, outward-oriented.

The decompositions (assetgen.collision.exact for one convex hole, assetgen.collision.carve
for a union of convex holes) describe each piece as a small system of half-spaces whose
vertices come from enumerating plane triples (assetgen.collision.triple_vertices). Those
vertices are snapped to a grid and merged here, and qhull (scipy) gives each cell's faces.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from assetgen.core.mesh import Mesh, cross3

SNAP = 2e-8
"""Grid (m) piece vertices are snapped to: far below the 1 um clearance tolerance, above
float32 millimetre resolution (~5 nm on a 15 cm plate)."""
MIN_PIECE_VOLUME = 1e-12
"""Pieces below this volume (m^3, a 0.1 mm cube) are slivers of numerical noise: dropped."""


def _snapped_unique(vertex_sets: list[np.ndarray]) -> list[np.ndarray]:
    """Each set snapped to the SNAP grid, without repeated rows, sorted lexicographically
    (x, then y, then z): all sets in one sort instead of one np.unique per piece, whose
    fixed cost is most of the work for a piece's few dozen rows."""
    # Vertices where several planes meet come out of different triples a few picometres
    # apart; snapped to a 20 nm grid they merge, so no sliver edge collapses when the piece
    # is stored as float32 millimetres (the clearance is re-checked on the stored piece).
    # + 0.0 turns -0.0 into 0.0: equal coordinates are stored with one sign.
    counts = np.array([len(v) for v in vertex_sets])
    v = np.round(np.vstack([*vertex_sets, np.zeros((0, 3))]) / SNAP) * SNAP + 0.0
    owner = np.repeat(np.arange(len(vertex_sets)), counts)
    order = np.lexsort((v[:, 2], v[:, 1], v[:, 0], owner))
    v, owner = v[order], owner[order]
    keep = np.ones(len(v), bool)
    keep[1:] = (owner[1:] != owner[:-1]) | np.any(v[1:] != v[:-1], axis=1)
    v, owner = v[keep], owner[keep]
    bounds = np.searchsorted(owner, np.arange(len(vertex_sets) + 1))
    return [v[bounds[i] : bounds[i + 1]] for i in range(len(vertex_sets))]


def cell_meshes(vertex_sets: list[np.ndarray]) -> list[Mesh]:
    """The convex hull of each vertex set as an outward-oriented mesh; sets with no volume
    (fewer than 4 distinct points, flat, or a sliver below MIN_PIECE_VOLUME) are dropped."""
    hulls = []
    for vertices in _snapped_unique(vertex_sets):
        if len(vertices) < 4:
            continue
        try:
            hull = ConvexHull(vertices)
        except Exception:  # coplanar or degenerate: no volume
            continue
        if hull.volume >= MIN_PIECE_VOLUME:
            hulls.append((vertices, hull))
    if not hulls:
        return []
    # qhull's simplices are unoriented; its facet equations give the outward normals. One
    # pass over every piece's triangles instead of a few numpy calls per piece.
    nv = np.array([len(v) for v, _ in hulls])
    voff = np.concatenate([[0], np.cumsum(nv)[:-1]])
    faces = np.vstack([h.simplices + o for (_, h), o in zip(hulls, voff, strict=True)])
    tri = np.vstack([v for v, _ in hulls])[faces]
    normal = cross3(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    outward = np.vstack([h.equations[:, :3] for _, h in hulls])
    flip = np.einsum("ij,ij->i", normal, outward) < 0
    faces = np.where(flip[:, None], faces[:, ::-1], faces)
    meshes, start = [], 0
    for (vertices, hull), o in zip(hulls, voff, strict=True):
        end = start + len(hull.simplices)
        # keep only the hull's vertices (points inside a face are dropped), renumbered
        remap = np.empty(len(vertices), np.int64)
        remap[hull.vertices] = np.arange(len(hull.vertices))
        meshes.append(Mesh(vertices[hull.vertices], remap[faces[start:end] - o]))
        start = end
    return meshes
