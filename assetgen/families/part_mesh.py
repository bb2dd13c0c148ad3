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


def _hulls(systems: list[np.ndarray]) -> list[mf.Manifold]:
    return [mf.Manifold.hull_points(v) for v in polytope_vertices_batch(systems)]


def part_mesh(part: Part) -> Mesh:
    """The part's closed surface in its own frame (see the module docstring)."""
    solids = _hulls(list(part.solids))
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
        holes = _hulls([np.vstack([h, clip]) for h in part.holes])
        body = body - mf.Manifold.batch_boolean(holes, mf.OpType.Add)
    m = body.to_mesh64()
    return Mesh(np.asarray(m.vert_properties)[:, :3].copy(), np.asarray(m.tri_verts, np.int64))
