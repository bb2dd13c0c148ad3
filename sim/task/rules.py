"""The task's pure functions on batches: observation, distance, reward terms, success,
failure, spawn. Shapes lead with the batch (n); poses are (n, 4, 4) homogeneous transforms
in the module frame unless stated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from assetgen.core.mesh import cross3
from assetgen.core.rotations import (
    matrix_to_quat,
    quat_conj,
    quat_mul,
    quat_rot6d,
    quat_to_matrix,
    random_axes,
    rot6d,
    rotvec_to_quat,
)
from sim.task.config import TaskConfig

OBS_DIM = 18
ACT_DIM = 6


def pose(pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """(n, 3) positions and (n, 4) quaternions -> (n, 4, 4) transforms."""
    t = np.zeros((len(pos), 4, 4))
    t[:, :3, :3] = quat_to_matrix(quat)
    t[:, :3, 3] = pos
    t[:, 3, 3] = 1.0
    return t


def inverse(t: np.ndarray) -> np.ndarray:
    """(..., 4, 4) rigid transforms -> their inverses."""
    r = t[..., :3, :3]
    out = np.zeros_like(t)
    out[..., :3, :3] = np.swapaxes(r, -1, -2)
    out[..., :3, 3] = -np.einsum("...ji,...j->...i", r, t[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def observe_matrices(
    peg: np.ndarray, entrance_inv: np.ndarray, bottom_inv: np.ndarray
) -> np.ndarray:
    """(n, 18) float32: the peg's pose in the entrance frame, then in the bottom frame, each
    as translation (3) + the first two rotation columns (6)."""
    in_e = entrance_inv @ peg
    in_b = bottom_inv @ peg
    # rotation entries clipped against rounding just past 1
    r_e = np.clip(rot6d(in_e[:, :3, :3]), -1.0, 1.0)
    r_b = np.clip(rot6d(in_b[:, :3, :3]), -1.0, 1.0)
    return np.concatenate([in_e[:, :3, 3], r_e, in_b[:, :3, 3], r_b], axis=1).astype(np.float32)


@dataclass(frozen=True)
class ObsFrames:
    """The entrance and bottom frames of n envs, in the forms the per-step path uses: both
    observed transforms come out of one batched 6 x 3 product."""

    rows: np.ndarray
    """(n, 6, 3) R_e^T over R_b^T: module-frame vectors into the entrance and bottom frames."""
    origin_in: np.ndarray
    """(n, 6) R_e^T p_e, R_b^T p_b: a point p is at R_f^T p - R_f^T p_f in frame f."""
    bottom_pos: np.ndarray
    """(n, 3) bottom frame origins in the module frame."""
    bottom_quat_conj: np.ndarray
    """(n, 4) inverse bottom frame orientations (w, x, y, z)."""

    @classmethod
    def of(cls, entrance: np.ndarray, bottom: np.ndarray) -> ObsFrames:
        """From (n, 4, 4) entrance and bottom frames in the module frame."""
        rows = np.concatenate(
            [np.swapaxes(entrance[:, :3, :3], 1, 2), np.swapaxes(bottom[:, :3, :3], 1, 2)], 1
        )
        origins = np.concatenate([entrance[:, :3, 3], bottom[:, :3, 3]], 1).reshape(-1, 2, 3)
        origin_in = np.einsum("nfij,nfj->nfi", rows.reshape(-1, 2, 3, 3), origins)
        quat_b = quat_conj(matrix_to_quat(bottom[:, :3, :3]))
        return cls(rows, origin_in.reshape(-1, 6), bottom[:, :3, 3].copy(), quat_b)

    def __getitem__(self, idx: np.ndarray | slice) -> ObsFrames:
        return ObsFrames(
            self.rows[idx], self.origin_in[idx], self.bottom_pos[idx], self.bottom_quat_conj[idx]
        )


def observe(pos: np.ndarray, quat: np.ndarray, frames: ObsFrames) -> np.ndarray:
    """(n, 18) float32: `observe_matrices` of the poses pos (n, 3), quat (n, 4) (unit)."""
    return observe_rows(pos, quat, frames.rows, frames.origin_in)


def observe_rows(
    pos: np.ndarray, quat: np.ndarray, rows: np.ndarray, origin_in: np.ndarray
) -> np.ndarray:
    """`observe` given the frames' rows (n, 6, 3) and origin_in (n, 6) (see ObsFrames).

    The peg's position and first two rotation columns (three module-frame vectors, the
    columns of v) go into both frames at once: rows @ v, then R_f^T p_f off the position."""
    n = len(pos)
    v = np.empty((n, 3, 3))
    v[:, :, 0] = pos
    v[:, :, 1:] = quat_rot6d(quat).reshape(n, 2, 3).transpose(0, 2, 1)
    res = rows @ v  # (n, frame * 3 + component, vector)
    res[:, :, 0] -= origin_in
    # no clip to [-1, 1] as in `observe_matrices`: rotation entries past 1 by rounding (~1e-16)
    # round to 1 in float32
    out = np.empty((n, 2, 3, 3), dtype=np.float32)  # (n, frame, vector, component)
    out[:] = res.reshape(n, 2, 3, 3).transpose(0, 1, 3, 2)
    return out.reshape(n, OBS_DIM)


def perturb(
    pos: np.ndarray, quat: np.ndarray, e: np.ndarray, pos_std: float, rot_std: float
) -> tuple[np.ndarray, np.ndarray]:
    """One estimation error per peg of poses pos (n, 3), quat (n, 4): position + N(0, pos_std)
    per axis, orientation turned by a rotation vector with N(0, rot_std) components (module
    frame). Both observed transforms come from this one estimate, so they stay consistent.
    e (n, 6): standard normal draws (`pose_noise`), position first, then rotation vector.
    Returns the noisy (pos, quat)."""
    noisy_pos = pos + pos_std * e[:, :3]
    noisy_quat = quat_mul(rotvec_to_quat(rot_std * e[:, 3:].astype(np.float64)), quat)
    return noisy_pos, noisy_quat


def pose_noise(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 6) float32 standard normal draws for `perturb` (the noise needs no more digits)."""
    return rng.standard_normal((n, 6), dtype=np.float32)


def seat_distance(
    pos: np.ndarray,
    quat: np.ndarray,
    bottom_pos: np.ndarray,
    bottom_quat_conj: np.ndarray,
    pos_weight: float,
    rot_weight: float,
    axis_weight: float = 0.0,
    axis: np.ndarray | None = None,
) -> np.ndarray:
    """(n,) d = w_t ||t|| + w_r ||R - I||_F of the peg-to-bottom transforms (t in metres),
    for poses pos (n, 3), quat (n, 4) (unit) and bottom frames with origins (n, 3) and
    inverse orientations (n, 4); w_t, w_r: TaskConfig.dist_pos_weight, dist_rot_weight.
    With axis_weight (TaskConfig.dist_axis_weight) > 0, plus w_a times the distance of pos
    from the hole's axis, the bottom frames' unit z axes (n, 3).

    ||t|| is the distance of the origins; ||R - I||_F = 2 sqrt(2) |sin(angle / 2)| =
    sqrt(8) ||vector part of the relative quaternion|| (exact near the seat, where
    1 - cos would lose digits)."""
    d = pos - bottom_pos
    t = np.sqrt(np.einsum("ni,ni->n", d, d))
    # vector part of a q for a = bottom_quat_conj: a_w q_v + q_w a_v + a_v x q_v
    a_v, q_v = bottom_quat_conj[:, 1:], quat[:, 1:]
    v = bottom_quat_conj[:, :1] * q_v + quat[:, :1] * a_v + cross3(a_v, q_v)
    r = np.sqrt(8.0 * np.einsum("ni,ni->n", v, v))
    out = pos_weight * t + rot_weight * r
    if axis_weight > 0.0:
        along = np.einsum("ni,ni->n", d, axis)
        out += axis_weight * np.sqrt(np.maximum(t * t - along * along, 0.0))
    return out


def progress(d: np.ndarray, d0: np.ndarray) -> np.ndarray:
    """(n,) c = 1 - sqrt(d / d0): 0 at the start, 1 at the seat, negative when farther."""
    return 1.0 - np.sqrt(d / d0)


def succeeded(pos: np.ndarray, bottom_pos: np.ndarray, radius: float) -> np.ndarray:
    """(n,) bool: the peg frame's origin pos (n, 3) within `radius` (TaskConfig.success_radius)
    of the bottom frame's origin bottom_pos (n, 3)."""
    d = pos - bottom_pos
    return np.einsum("ni,ni->n", d, d) < radius * radius


def lowest_points(peg: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """(n, V, 3) peg vertices (peg frame) -> (n, V, 3) in the module frame."""
    return vertices @ np.swapaxes(peg[:, :3, :3], 1, 2) + peg[:, None, :3, 3]


def failed(
    pos: np.ndarray,
    quat: np.ndarray,
    vertices: np.ndarray,
    bottom: np.ndarray,
    hole_radius: np.ndarray,
    depth: float,
    reach: np.ndarray | None = None,
) -> np.ndarray:
    """(n,) bool: the peg went below the mounting surface outside the hole.

    Failure: some peg vertex lies more than `depth` below the mounting surface (z = 0)
    and farther than `hole_radius` from the hole axis (the line through the bottom frame's
    origin along its z). Inside that radius a point below the surface is in the hole;
    outside it, the only way down is around the plate's edge (or through the plate). The
    depth tolerance (2.5 mm: half the plate) is above any contact transient (<= 1.25 mm).
    pos (n, 3), quat (n, 4): peg poses in the module frame; vertices: (n, V, 3) peg frame;
    bottom: (n, 4, 4); hole_radius: (n,) m; reach: (n,) largest vertex distance from the
    peg origin (computed if not given).
    """
    out = np.zeros(len(pos), dtype=bool)
    # only pegs whose origin is low enough for some vertex to be below -depth
    if reach is None:
        reach = np.sqrt(np.max(np.sum(vertices**2, axis=-1), axis=1))
    idx = np.flatnonzero(pos[:, 2] - reach < -depth)
    if len(idx) == 0:
        return out
    # the vertices' heights need only the rotation's last row (from the quaternion); the
    # full transform only for pegs with a vertex below -depth (few: most low pegs are tall
    # ones still high above the plate)
    idx = idx[heights(pos[idx], quat[idx], vertices[idx]).min(axis=1) < -depth]
    if len(idx) == 0:
        return out
    pts = lowest_points(pose(pos[idx], quat[idx]), vertices[idx])
    below = pts[..., 2] < -depth
    rel = pts - bottom[idx, None, :3, 3]
    axis = bottom[idx, None, :3, 2]
    radial = rel - np.sum(rel * axis, axis=-1, keepdims=True) * axis
    outside = np.sum(radial**2, axis=-1) > hole_radius[idx, None] ** 2
    out[idx] = np.any(below & outside, axis=1)
    return out


def heights(pos: np.ndarray, quat: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """(n, V) module-frame z of the vertices (n, V, 3) (peg frame) of pegs at pos (n, 3),
    quat (n, 4): only the rotation's last row is needed, straight from the quaternion."""
    w, x, y, z = quat.T
    row2 = np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], 1)
    return np.einsum("nvi,ni->nv", vertices, row2) + pos[:, 2:3]


def sample_spawn(
    rng: np.random.Generator,
    entrance_pos: np.ndarray,
    entrance_quat: np.ndarray,
    vertices: np.ndarray,
    scale: float | np.ndarray,
    cfg: TaskConfig,
    min_clearance: float = 0.001,
) -> tuple[np.ndarray, np.ndarray]:
    """Spawn poses, positions (n, 3) and unit quaternions (n, 4), of pegs whose entrance
    frames are entrance_pos (n, 3), entrance_quat (n, 4): x, y within +-scale * spawn_xy of
    the entrance, z scale * U(spawn_z) above it, orientation = entrance frame turned about a
    random axis by U(0, scale * spawn_max_angle). A peg whose lowest point would be less
    than `min_clearance` above the mounting surface is raised to that height (only tall
    pegs spawned upside down near the lowest height, or every peg at scale 0, whose bottom
    would sit exactly at the entrance). scale: one for every peg, or (n,) one each."""
    n = len(entrance_pos)
    offset = np.empty((n, 4))
    offset[:, 0] = 0.0
    per_peg = np.ndim(scale) > 0
    offset[:, 1:3] = (
        rng.uniform(-1.0, 1.0, (n, 2))
        * cfg.spawn_xy
        * (np.asarray(scale)[:, None] if per_peg else scale)
    )
    offset[:, 3] = rng.uniform(*cfg.spawn_z, n) * scale
    angle = rng.uniform(0.0, 1.0, n) * cfg.spawn_max_angle * scale
    turn = np.empty((n, 4))
    turn[:, 0] = np.cos(0.5 * angle)
    turn[:, 1:] = random_axes(rng, n) * np.sin(0.5 * angle)[:, None]
    quat = quat_mul(entrance_quat, turn)
    # the offset, given in the entrance frame, into the module frame: q (0, v) q*
    pos = entrance_pos + quat_mul(quat_mul(entrance_quat, offset), quat_conj(entrance_quat))[:, 1:]
    low = heights(pos, quat, vertices).min(axis=1)
    pos[:, 2] += np.maximum(0.0, min_clearance - low)
    return pos, quat
