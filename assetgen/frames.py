"""Rigid frames: position in metres and unit quaternion (w, x, y, z)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """(4,) quaternion (w, x, y, z) -> (3, 3) rotation matrix."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """(3, 3) rotation matrix -> (4,) quaternion (w, x, y, z) with w >= 0."""
    m = np.asarray(r, dtype=float)
    t = np.trace(m)
    if t > 0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q = np.array(q)
    q /= np.linalg.norm(q)
    return -q if q[0] < 0 else q


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
