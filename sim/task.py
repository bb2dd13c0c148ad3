"""The task's pure functions on batches: observation, distance, reward terms, success,
failure, spawn. Shapes lead with the batch (n); poses are (n, 4, 4) homogeneous transforms
in the module frame unless stated.
"""

from __future__ import annotations

import numpy as np

from sim.config import TaskConfig
from sim.rotations import axis_angle_to_matrix, quat_to_matrix, random_axes, rot6d, rotvec_to_matrix

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


def observe(peg: np.ndarray, entrance_inv: np.ndarray, bottom_inv: np.ndarray) -> np.ndarray:
    """(n, 18) float32: the peg's pose in the entrance frame, then in the bottom frame, each
    as translation (3) + the first two rotation columns (6)."""
    in_e = entrance_inv @ peg
    in_b = bottom_inv @ peg
    # rotation entries clipped against rounding just past 1
    r_e = np.clip(rot6d(in_e[:, :3, :3]), -1.0, 1.0)
    r_b = np.clip(rot6d(in_b[:, :3, :3]), -1.0, 1.0)
    return np.concatenate([in_e[:, :3, 3], r_e, in_b[:, :3, 3], r_b], axis=1).astype(np.float32)


def perturb(
    peg: np.ndarray, rng: np.random.Generator, pos_std: float, rot_std: float
) -> np.ndarray:
    """One estimation error per peg: position + N(0, pos_std) per axis, orientation rotated
    by a rotation vector with N(0, rot_std) components (module frame). Both observed
    transforms come from this one estimate, so they stay consistent."""
    n = len(peg)
    out = peg.copy()
    out[:, :3, 3] += rng.normal(0.0, pos_std, (n, 3))
    out[:, :3, :3] = rotvec_to_matrix(rng.normal(0.0, rot_std, (n, 3))) @ peg[:, :3, :3]
    return out


def seat_distance(peg_in_bottom: np.ndarray, cfg: TaskConfig) -> np.ndarray:
    """(n,) d = w_t ||t|| + w_r ||R - I||_F of the peg-to-bottom transform (t in metres)."""
    t = np.linalg.norm(peg_in_bottom[:, :3, 3], axis=1)
    r = np.linalg.norm(peg_in_bottom[:, :3, :3] - np.eye(3), axis=(1, 2))
    return cfg.dist_pos_weight * t + cfg.dist_rot_weight * r


def progress(d: np.ndarray, d0: np.ndarray) -> np.ndarray:
    """(n,) c = 1 - sqrt(d / d0): 0 at the start, 1 at the seat, negative when farther."""
    return 1.0 - np.sqrt(d / d0)


def succeeded(peg_in_bottom: np.ndarray, cfg: TaskConfig) -> np.ndarray:
    """(n,) bool: the peg frame's origin within `success_radius` of the bottom frame's."""
    return np.linalg.norm(peg_in_bottom[:, :3, 3], axis=1) < cfg.success_radius


def lowest_points(peg: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """(n, V, 3) peg vertices (peg frame) -> (n, V, 3) in the module frame."""
    return vertices @ np.swapaxes(peg[:, :3, :3], 1, 2) + peg[:, None, :3, 3]


def failed(
    peg: np.ndarray,
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
    vertices: (n, V, 3) peg frame; bottom: (n, 4, 4); hole_radius: (n,) m; reach: (n,)
    largest vertex distance from the peg origin (computed if not given).
    """
    out = np.zeros(len(peg), dtype=bool)
    # only pegs whose origin is low enough for some vertex to be below -depth
    if reach is None:
        reach = np.sqrt(np.max(np.sum(vertices**2, axis=-1), axis=1))
    idx = np.flatnonzero(peg[:, 2, 3] - reach < -depth)
    if len(idx) == 0:
        return out
    pts = lowest_points(peg[idx], vertices[idx])
    below = pts[..., 2] < -depth
    rel = pts - bottom[idx, None, :3, 3]
    axis = bottom[idx, None, :3, 2]
    radial = rel - np.sum(rel * axis, axis=-1, keepdims=True) * axis
    outside = np.sum(radial**2, axis=-1) > hole_radius[idx, None] ** 2
    out[idx] = np.any(below & outside, axis=1)
    return out


def sample_spawn(
    rng: np.random.Generator,
    entrance: np.ndarray,
    vertices: np.ndarray,
    scale: float,
    cfg: TaskConfig,
    min_clearance: float = 0.001,
) -> np.ndarray:
    """(n, 4, 4) spawn poses: x, y within +-scale * spawn_xy of the entrance, z
    scale * U(spawn_z) above it, orientation = entrance frame turned about a random axis by
    U(0, scale * spawn_max_angle). A peg whose lowest point would be less than
    `min_clearance` above the mounting surface is raised to that height (only tall pegs
    spawned upside down near the lowest height, or every peg at scale 0, whose bottom
    would sit exactly at the entrance)."""
    n = len(entrance)
    offset = np.empty((n, 3))
    offset[:, :2] = rng.uniform(-1.0, 1.0, (n, 2)) * cfg.spawn_xy * scale
    offset[:, 2] = rng.uniform(*cfg.spawn_z, n) * scale
    angle = rng.uniform(0.0, 1.0, n) * cfg.spawn_max_angle * scale
    rot = axis_angle_to_matrix(random_axes(rng, n), angle)
    out = np.zeros((n, 4, 4))
    out[:, :3, :3] = entrance[:, :3, :3] @ rot
    out[:, :3, 3] = entrance[:, :3, 3] + np.einsum("nij,nj->ni", entrance[:, :3, :3], offset)
    out[:, 3, 3] = 1.0
    low = lowest_points(out, vertices)[..., 2].min(axis=1)
    out[:, 2, 3] += np.maximum(0.0, min_clearance - low)
    return out
