"""Rigid frames: position in metres and unit quaternion (w, x, y, z).

The quaternion arithmetic is assetgen.core.rotations, shared with the simulator."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from assetgen.core.rotations import matrix_to_quat, quat_to_matrix


@dataclass(frozen=True)
class Frame:
    """A frame in the module frame: origin `pos` (metres) and orientation `quat` (w, x, y, z)."""

    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float]

    @staticmethod
    def from_matrix(m: np.ndarray) -> Frame:
        return Frame(
            tuple(float(v) for v in m[:3, 3]), tuple(float(v) for v in matrix_to_quat(m[:3, :3]))
        )

    @staticmethod
    def from_json(d: dict) -> Frame:
        return Frame(tuple(d["pos"]), tuple(d["quat"]))

    def matrix(self) -> np.ndarray:
        """(4, 4) homogeneous transform from this frame to its parent."""
        m = np.eye(4)
        m[:3, :3] = quat_to_matrix(np.array(self.quat))
        m[:3, 3] = self.pos
        return m

    @property
    def z_axis(self) -> np.ndarray:
        return quat_to_matrix(np.array(self.quat))[:, 2]

    def to_json(self) -> dict:
        return {"pos": list(self.pos), "quat": list(self.quat)}
