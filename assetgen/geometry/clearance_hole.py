"""The exact clearance hole of a part made of convex solids.

Each solid {n . x <= d} is moved out by the clearance c: {n . x <= d + c} (mitred: the
faces move, the corners follow). Outside that polytope some moved plane is violated, so a
point there is more than c from the solid; outside the union over the part's solids, a point
is more than c from the part. So the gap between the part and any material outside the union
is never below c, and it is exactly c at every face.

A part goes in along an axis: the planes facing back along it (n . axis > 0, the part's
top) are dropped, and the hole is closed instead by a cap far up the axis, so the hole is
open towards where the part comes from and its straight path is clear.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from assetgen.core.portable import dot, matmul, norm
from assetgen.geometry.polytope import transform_planes

FACING = 1e-9
"""A plane faces back along the insertion axis when n . axis exceeds this."""


def clearance_hole(
    solids: Sequence[np.ndarray],
    clearance: float,
    pose: np.ndarray,
    axis: np.ndarray,
    reach: float,
) -> list[np.ndarray]:
    """The hole (one convex polytope per solid, module frame) for a part whose `solids`
    (part frame) sit at `pose` (4, 4), inserted along -`axis` (module frame, unit): every
    plane moved out by `clearance`, and those facing along `axis` replaced by a cap `reach`
    (m) up the axis from the part frame's origin (beyond every material the hole must cut).
    """
    if not clearance > 0:
        raise ValueError(f"clearance = {clearance!r} m; expected a gap > 0")
    axis = np.asarray(axis, dtype=float)
    axis = axis / norm(axis)
    origin = pose[:3, 3]
    holes = []
    for s in solids:
        planes = transform_planes(np.asarray(s, dtype=float), pose)
        planes[:, 3] += clearance
        keep = matmul(planes[:, :3], axis) <= FACING
        cap = np.array([[*axis, float(dot(axis, origin)) + reach]])
        holes.append(np.vstack([planes[keep], cap]))
    return holes
