"""A part's surface for the printable files: the union of its convex solids minus the union
of its holes, by manifold3d (booleans whose result is guaranteed manifold).

Each solid (and each hole, clipped to a box around the part) becomes a hull of its
enumerated vertices; the booleans are exact up to float rounding. The surface is in the part
frame, metres, outward-oriented, one closed body.
"""

from __future__ import annotations

import manifold3d as mf
import numpy as np

from assetgen.core.mesh import Mesh
from assetgen.families.parts import Part
from assetgen.geometry.triple_vertices import polytope_vertices_batch

MARGIN = 0.01
"""m a hole is kept beyond the part's solids when clipped (enough to cut cleanly through)."""
SNAP = 1e-10
"""m: vertices of different holes (and of a part's solids that share corners) nearer than
this are made one. Holes that share a corner
(the convex pieces of one non-convex hole) enumerate it from different planes, a few 1e-17 m
apart; left apart, the boolean pinches the surface there, which the float32 STL folds into
an open one. Far below the files' 10 nm resolution; no earlier file changes (tested)."""


def snap(vertex_sets: list[np.ndarray], tol: float = SNAP) -> list[np.ndarray]:
    """The vertex sets with every vertex moved onto the first one (in order) within `tol`."""
    sizes = [len(v) for v in vertex_sets]
    allv = np.vstack(vertex_sets)
    near = np.linalg.norm(allv[:, None, :] - allv[None, :, :], axis=2) < tol
    return np.split(allv[near.argmax(axis=1)], np.cumsum(sizes)[:-1])


def _hulls(systems: list[np.ndarray], snapped: bool = False) -> list[mf.Manifold]:
    vertex_sets = polytope_vertices_batch(systems)
    return [mf.Manifold.hull_points(v) for v in (snap(vertex_sets) if snapped else vertex_sets)]


def printed_part(part: Part, offset: float) -> Part:
    """The part with its holes' faces moved out by `offset` (m) more: for a printer whose
    holes come out that much undersize (a hole's cap far up its axis moves too, harmlessly)."""
    from dataclasses import replace

    holes = tuple(np.column_stack([h[:, :3], h[:, 3] + offset]) for h in part.holes)
    return replace(part, holes=holes)


def part_mesh(part: Part) -> Mesh:
    """The part's closed surface in its own frame (see the module docstring)."""
    solids = _hulls(list(part.solids), snapped=part.shared_corners)
    body = mf.Manifold.batch_boolean(solids, mf.OpType.Add)
    if part.holes:
        lo, hi = body.bounding_box()[:3], body.bounding_box()[3:]
        e = np.eye(3)
        clip = np.vstack(
            [
                np.column_stack([e, np.asarray(hi) + MARGIN]),
                np.column_stack([-e, -(np.asarray(lo) - MARGIN)]),
            ]
        )
        holes = _hulls([np.vstack([h, clip]) for h in part.holes], snapped=True)
        body = body - mf.Manifold.batch_boolean(holes, mf.OpType.Add)
    m = body.to_mesh64()
    return weld(
        Mesh(np.asarray(m.vert_properties)[:, :3].copy(), np.asarray(m.tri_verts, np.int64))
    )


def weld(mesh: Mesh) -> Mesh:
    """The mesh with vertices at exactly one position made one, and the folds that leaves
    removed: a triangle and its reverse (a fin of no area), and triangles with two equal
    corners. Where the convex pieces of a non-convex hole cross on its floor, manifold3d may
    compute one crossing twice, as two vertices at the same point joined by such a fin: the
    surface is closed as indices, but an STL stores positions, and there the fin's edge
    bounds four triangles. A mesh without repeated positions comes back unchanged.
    Hand-written: trimesh's merge keeps one of two opposite faces, which leaves the fin."""
    v, f = mesh.vertices, mesh.faces
    _, first, inverse = np.unique(v, axis=0, return_index=True, return_inverse=True)
    if len(first) == len(v):
        return mesh
    faces = first[inverse.reshape(-1)][f]  # each vertex -> the first at its position
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
                  & (faces[:, 0] != faces[:, 2])]  # fmt: skip
    # a triangle and its reverse: the same corners, opposite cyclic order
    turn = np.argmin(faces, axis=1)
    rolled = np.stack([np.roll(t, -k) for t, k in zip(faces, turn, strict=True)])
    canon = np.where((rolled[:, 1] < rolled[:, 2])[:, None], rolled, rolled[:, [0, 2, 1]])
    forward = rolled[:, 1] < rolled[:, 2]
    keep = np.ones(len(faces), bool)
    seen: dict[tuple[int, int, int], list[int]] = {}
    for i, key in enumerate(map(tuple, canon)):
        seen.setdefault(key, []).append(i)
    for group in seen.values():
        ups = [i for i in group if forward[i]]
        downs = [i for i in group if not forward[i]]
        for a, b in zip(ups, downs, strict=False):  # each pair of opposites cancels
            keep[a] = keep[b] = False
    faces = faces[keep]
    used = np.unique(faces)
    index = np.full(len(v), -1)
    index[used] = np.arange(len(used))
    return Mesh(v[used], index[faces])
