"""Labels a camera can tell apart: the teacher aims at the nearest seat that looks the same.

A privileged teacher turns the peg to its seat's own frame. A peg that looks the same turned
by half a turn about its axis (a Table I peg with an even number of corners, or its squashed
circle) fits its hole both ways, and an image cannot say which of the two the seat's frame
is: the same picture would be labelled with opposite turns on different modules. So for such
a peg the teacher is shown the seat's frame turned by half a turn about the hole's axis
whenever that one is nearer the peg's orientation: the same hole, so the teacher inserts as
well, and its label is then a function of what the camera sees.

The 18-D observation holds the peg's pose in the entrance frame and then in the seat's
(bottom) frame, each as a position and two rotation columns (sim/task/rules.py). Turning the
seat's frame by half a turn about its own z axis negates the x and y of each of the seat
part's three vectors; the entrance part, the plate's, does not change.
"""

from __future__ import annotations

import numpy as np

from assetgen.core.mesh import Mesh

HALF_TURN = np.array([1.0] * 9 + [-1.0, -1.0, 1.0] * 3, dtype=np.float32)
"""The 18-D observation with the seat's frame turned by half a turn about its axis."""


def half_turn_symmetric(peg: Mesh, tol: float = 1e-6) -> bool:
    """Whether the peg (peg frame, z its axis) maps onto itself turned by half a turn about
    its axis: every vertex turned lands within `tol` (m) of a vertex."""
    v = np.asarray(peg.vertices, dtype=float)
    turned = v * np.array([-1.0, -1.0, 1.0])
    gap = np.linalg.norm(turned[:, None, :] - v[None, :, :], axis=2).min(axis=1)
    return bool(gap.max() <= tol)


def nearest_seat(obs: np.ndarray, symmetric: np.ndarray) -> np.ndarray:
    """The teacher's observations (n, 18): where `symmetric` (n,) and the half-turned seat is
    nearer the peg's orientation (a larger trace of the peg's rotation in the seat's frame),
    that seat's; elsewhere as they are."""
    col1, col2 = obs[:, 12:15], obs[:, 15:18]
    # trace of R = [c1, c2, c1 x c2]: its z-z entry, c1x c2y - c1y c2x, is the same both ways
    xy = col1[:, 0] + col2[:, 1]
    flip = symmetric & (xy < 0.0)  # the half turn negates c1x + c2y
    return np.where(flip[:, None], obs * HALF_TURN, obs)
