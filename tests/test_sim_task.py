"""The task's per-step functions (quaternion forms) against their matrix definitions."""

from __future__ import annotations

import numpy as np
import pytest

from assetgen.core.rotations import (
    matrix_to_quat,
    matrix_to_rotvec,
    quat_to_matrix,
    random_axes,
    rotvec_to_quat,
)
from sim.task import rules as T
from sim.task.config import TaskConfig


def _random_frames(rng: np.random.Generator, n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return T.pose(rng.uniform(-0.2, 0.2, (n, 3)), q / np.linalg.norm(q, axis=1, keepdims=True))


def _quats(t: np.ndarray) -> np.ndarray:
    return matrix_to_quat(t[:, :3, :3])


def test_observe_equals_the_matrix_definition() -> None:
    rng = np.random.default_rng(0)
    n = 64
    peg, entrance, bottom = (_random_frames(rng, n) for _ in range(3))
    want = T.observe_matrices(peg, T.inverse(entrance), T.inverse(bottom))
    got = T.observe(peg[:, :3, 3], _quats(peg), T.ObsFrames.of(entrance, bottom))
    assert got.dtype == np.float32 and got.shape == (n, 18)
    assert got == pytest.approx(want, abs=1e-6)
    # a subset of envs sees its own frames
    idx = np.array([5, 2, 40])
    sub = T.observe(peg[idx, :3, 3], _quats(peg[idx]), T.ObsFrames.of(entrance, bottom)[idx])
    assert sub == pytest.approx(want[idx], abs=1e-6)


def test_seat_distance_equals_the_matrix_definition() -> None:
    rng = np.random.default_rng(1)
    n = 64
    peg, bottom = _random_frames(rng, n), _random_frames(rng, n)
    rel = T.inverse(bottom) @ peg
    cfg = TaskConfig()
    want = cfg.dist_pos_weight * np.linalg.norm(rel[:, :3, 3], axis=1)
    want += cfg.dist_rot_weight * np.linalg.norm(rel[:, :3, :3] - np.eye(3), axis=(1, 2))
    frames = T.ObsFrames.of(bottom, bottom)
    weights = cfg.dist_pos_weight, cfg.dist_rot_weight
    got = T.seat_distance(
        peg[:, :3, 3], _quats(peg), frames.bottom_pos, frames.bottom_quat_conj, *weights
    )
    assert got == pytest.approx(want, rel=1e-9, abs=1e-12)
    # at the seat, exactly zero; a 1e-6 rad turn reads as such (no 1 - cos cancellation)
    turned = bottom.copy()
    turned[:, :3, :3] = bottom[:, :3, :3] @ quat_to_matrix(
        np.array([np.cos(5e-7), np.sin(5e-7), 0, 0])
    )
    for pose, rot in ((bottom, 0.0), (turned, np.sqrt(2) * 1e-6)):
        d = T.seat_distance(
            pose[:, :3, 3], _quats(pose), frames.bottom_pos, frames.bottom_quat_conj, *weights
        )
        assert d == pytest.approx(np.full(n, cfg.dist_rot_weight * rot), rel=1e-6, abs=1e-15)


def test_heights_are_the_vertices_z() -> None:
    rng = np.random.default_rng(2)
    peg = _random_frames(rng, 16)
    verts = rng.normal(size=(16, 10, 3)) * 0.03
    want = T.lowest_points(peg, verts)[..., 2]
    assert T.heights(peg[:, :3, 3], _quats(peg), verts) == pytest.approx(want, abs=1e-12)


def test_perturb_draws_the_stated_noise() -> None:
    rng = np.random.default_rng(3)
    n = 20000
    pos = np.zeros((n, 3))
    quat = np.tile([1.0, 0, 0, 0], (n, 1))
    noisy_pos, noisy_quat = T.perturb(pos, quat, T.pose_noise(rng, n), 0.0005, np.radians(1.0))
    assert noisy_pos.std(axis=0) == pytest.approx([0.0005] * 3, rel=0.03)
    rotvec = matrix_to_rotvec(quat_to_matrix(noisy_quat))
    assert rotvec.std(axis=0) == pytest.approx([np.radians(1.0)] * 3, rel=0.03)
    assert np.linalg.norm(noisy_quat, axis=1) == pytest.approx(np.ones(n), abs=1e-12)


def test_spawn_stays_in_its_ranges() -> None:
    rng = np.random.default_rng(4)
    n = 4000
    cfg = TaskConfig()
    # entrances on the mounting surface, tilted up to 15 degrees, any yaw
    tilt = np.zeros((n, 3))
    tilt[:, :2] = rng.uniform(-np.radians(15), np.radians(15), (n, 2))
    yaw = np.zeros((n, 3))
    yaw[:, 2] = rng.uniform(-np.pi, np.pi, n)
    entrance = T.pose(np.zeros((n, 3)), np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)))
    entrance[:, :3, :3] = quat_to_matrix(rotvec_to_quat(tilt)) @ quat_to_matrix(rotvec_to_quat(yaw))
    entrance[:, :2, 3] = rng.uniform(-0.025, 0.025, (n, 2))
    verts = np.tile(random_axes(rng, 12) * 0.01, (n, 1, 1))
    for scale in (0.3, 1.0):
        pos, quat = T.sample_spawn(rng, entrance[:, :3, 3], _quats(entrance), verts, scale, cfg)
        offset = np.einsum("nji,nj->ni", entrance[:, :3, :3], pos - entrance[:, :3, 3])
        assert np.abs(offset[:, :2]).max() <= cfg.spawn_xy * scale
        assert np.abs(offset[:, :2]).max() > 0.95 * cfg.spawn_xy * scale
        turn = entrance[:, :3, :3].transpose(0, 2, 1) @ quat_to_matrix(quat)
        angle = np.linalg.norm(matrix_to_rotvec(turn), axis=1)
        assert angle.max() <= cfg.spawn_max_angle * scale + 1e-9
        assert angle.mean() == pytest.approx(0.5 * cfg.spawn_max_angle * scale, rel=0.05)
        assert offset[:, 2].min() >= cfg.spawn_z[0] * scale - 1e-12
        assert offset[:, 2].max() <= cfg.spawn_z[1] * scale + 1e-12
        assert T.heights(pos, quat, verts).min() >= 0.001 - 1e-12  # above the surface
