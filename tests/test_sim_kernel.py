"""The compiled per-step kernels (sim/task/kernel.py) against the task's definitions on
numpy arrays (the functions of sim/task/rules.py, which test_sim_task.py holds to their matrix
definitions), on random batches that reach every branch: success, failure below the surface
outside the hole, inside the hole, unstable rows; and against the shard layout they serve."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sim.task import kernel as K
from sim.task import rules as T
from sim.task.config import TaskConfig

N = 400
V = 12


def _quats(rng: np.random.Generator, n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _batch(seed: int) -> dict:
    """Random envs: frames, peg vertices, and peg poses spread from far above the plate to
    below it, a quarter of them next to the seat (successes)."""
    rng = np.random.default_rng(seed)
    entrance = T.pose(rng.uniform(-0.05, 0.05, (N, 3)) * [1, 1, 0], _quats(rng, N))
    bottom = entrance.copy()
    bottom[:, :3, 3] -= 0.03 * bottom[:, :3, 2]
    pos = rng.uniform(-0.1, 0.1, (N, 3))
    pos[:, 2] = rng.uniform(-0.03, 0.1, N)
    quat = _quats(rng, N)
    seat = rng.random(N) < 0.25
    pos[seat] = bottom[seat, :3, 3] + rng.normal(0, 0.002, (seat.sum(), 3))
    vertices = rng.uniform(-0.02, 0.02, (N, V, 3))
    state = np.zeros((N, 14))
    state[:, 1:4], state[:, 4:8] = pos, quat
    unstable = rng.random(N) < 0.05
    return {
        "rng": rng,
        "entrance": entrance,
        "bottom": bottom,
        "state": state,
        "vertices": vertices,
        "reach": np.linalg.norm(vertices, axis=2).max(axis=1),
        "hole_radius": rng.uniform(0.005, 0.03, N),
        "unstable": unstable,
        "d0": rng.uniform(0.05, 0.3, N),
        "c_prev": rng.uniform(-0.5, 0.9, N),
        "returns": rng.uniform(-0.5, 0.9, N),
        "last_obs": rng.normal(size=(N, 18)).astype(np.float32),
        "e": rng.standard_normal((N, 6), dtype=np.float32),
    }


def _reference(b: dict, cfg: TaskConfig) -> tuple[np.ndarray, ...]:
    """What one step scores, from sim/task/rules.py's functions: obs, reward, success, failure,
    returns, c_prev."""
    frames = T.ObsFrames.of(b["entrance"], b["bottom"])
    pos, quat = b["state"][:, 1:4].copy(), b["state"][:, 4:8].copy()
    unstable = b["unstable"]
    pos[unstable], quat[unstable] = 0.0, (1.0, 0.0, 0.0, 0.0)
    d = T.seat_distance(pos, quat, frames.bottom_pos, frames.bottom_quat_conj,
                        cfg.dist_pos_weight, cfg.dist_rot_weight)  # fmt: skip
    c = T.progress(d, b["d0"])
    r = c - b["c_prev"]
    ok = T.succeeded(pos, frames.bottom_pos, cfg.success_radius) & ~unstable
    bad = T.failed(pos, quat, b["vertices"], b["bottom"], b["hole_radius"], cfg.failure_depth,
                   b["reach"]) & ~ok & ~unstable  # fmt: skip
    r[ok] = 1.0 - b["returns"][ok]
    r[bad] = cfg.failure_reward
    r[unstable] = 0.0
    if cfg.noise:
        pos, quat = T.perturb(pos, quat, b["e"], cfg.obs_pos_noise, cfg.obs_rot_noise)
    obs = T.observe_rows(pos, quat, frames.rows, frames.origin_in)
    obs[unstable] = b["last_obs"][unstable]
    return obs, r, ok, bad, b["returns"] + r, c


def _kernel_frames(b: dict) -> K.Frames:
    f = T.ObsFrames.of(b["entrance"], b["bottom"])
    return K.Frames(rows=f.rows, origin=f.origin_in, bottom_pos=f.bottom_pos,
                    bottom_quat_conj=f.bottom_quat_conj, bottom=b["bottom"],
                    vertices=b["vertices"], hole_radius=b["hole_radius"],
                    reach=b["reach"])  # fmt: skip


def _score(b: dict, cfg: TaskConfig) -> tuple[np.ndarray, ...]:
    """K.score on batch b: obs, reward, success, failure, returns, c_prev."""
    out = K.Outcome(obs=np.empty((N, 18), dtype=np.float32), reward=np.empty(N),
                    success=np.empty(N, bool), failure=np.empty(N, bool))  # fmt: skip
    episode = K.Episode(d0=b["d0"], c_prev=b["c_prev"].copy(), returns=b["returns"].copy(),
                        last_obs=b["last_obs"])  # fmt: skip
    K.score(b["state"], b["unstable"], b["e"], _kernel_frames(b), episode,
            K.StepParams.of(cfg), out)  # fmt: skip
    return *out, episode.returns, episode.c_prev


def test_step_params_are_taken_by_name() -> None:
    """Every field of StepParams is the TaskConfig field of that name: no order to keep."""
    cfg = TaskConfig(noise=True)
    fields = {f.name for f in dataclasses.fields(TaskConfig)}
    params = K.StepParams.of(cfg)
    assert set(params._fields) <= fields
    for name, value in params._asdict().items():
        assert value == getattr(cfg, name), name
    # every field differs from the others, so a swapped pair would show
    changed = dataclasses.replace(cfg, failure_depth=0.0123, success_radius=0.0045)
    assert K.StepParams.of(changed).failure_depth == 0.0123
    assert K.StepParams.of(changed).success_radius == 0.0045


@pytest.mark.parametrize("noise", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_score_equals_the_numpy_task_functions(noise: bool, seed: int) -> None:
    b = _batch(seed)
    cfg = TaskConfig(noise=noise)
    want = _reference(b, cfg)
    obs, reward, success, failure, returns, c_prev = _score(b, cfg)
    # every branch is reached, or the comparison proves little
    assert want[2].sum() > 10 and want[3].sum() > 10 and b["unstable"].sum() > 5
    low_unfailed = (b["state"][:, 3] < -0.01) & ~want[3] & ~b["unstable"]
    assert low_unfailed.sum() > 5, "some pegs below the surface must be inside the hole"
    np.testing.assert_array_equal(success, want[2])
    np.testing.assert_array_equal(failure, want[3])
    np.testing.assert_allclose(obs, want[0], rtol=0, atol=2e-7)
    np.testing.assert_allclose(reward, want[1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(returns, want[4], rtol=0, atol=1e-12)
    np.testing.assert_allclose(c_prev, want[5], rtol=0, atol=1e-12)


def test_observe_of_chosen_envs_equals_the_reference() -> None:
    b = _batch(3)
    cfg = TaskConfig()
    frames = T.ObsFrames.of(b["entrance"], b["bottom"])
    idx = np.array([5, 0, 399, 17])
    e = b["e"][: len(idx)]
    got = np.empty((len(idx), 18), dtype=np.float32)
    K.observe(b["state"], idx, _kernel_frames(b), e, K.StepParams.of(cfg), out=got)
    # the task's observation of the perturbed pose
    pos, quat = T.perturb(
        b["state"][idx, 1:4], b["state"][idx, 4:8], e, cfg.obs_pos_noise, cfg.obs_rot_noise
    )
    np.testing.assert_allclose(got, T.observe(pos, quat, frames[idx]), rtol=0, atol=2e-7)


def command_case() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(actions (50, 6) past the bounds too, float32 draws e, scale, noise std) for command."""
    rng = np.random.default_rng(4)
    actions = rng.uniform(-3, 3, (50, 6))
    e = rng.standard_normal((50, 6), dtype=np.float32)
    return actions, e, np.array([0.25] * 3 + [1.5] * 3), np.array([5e-4] * 3 + [0.017] * 3)


def test_command_clips_scales_and_adds_noise() -> None:
    actions, e, scale, std = command_case()
    for noisy in (False, True):
        want = np.clip(actions, -1, 1) * scale + (e * std if noisy else 0.0)
        out = np.empty((50, 6))
        K.command(actions, e, noisy, scale, std, out)
        np.testing.assert_array_equal(out, want)


def test_scatter_and_gather_follow_the_flat_layout() -> None:
    """Env e's state lives at flat positions flat[e] of the shard states, shifted by its
    offset; gather flags non-finite rows, stalled shards and runaway pegs."""
    rng = np.random.default_rng(5)
    shards, slots, nshard = 3, 2, 40
    n = shards * slots - 1  # one phantom slot
    env = np.arange(n)
    flat = np.empty((n, 14), dtype=np.int64)
    flat[:, 0] = env // slots * nshard  # the shard's time
    flat[:, 1:] = (env // slots * nshard + 1 + env % slots * 13)[:, None] + np.arange(13)
    offset = rng.normal(size=(n, 14))
    offset[:, 0] = 0.0
    state = rng.normal(size=(n, 14)) * 0.1
    state[:, 0] = 1.0
    velocity = rng.normal(size=(n, 6))
    shard_flat = np.zeros(shards * nshard)
    ctrl = np.zeros((shards, 4, 6 * slots))
    layout = K.Layout(flat=flat, offset=offset, shard_of=env // slots)
    K.scatter(state, layout, velocity, shard_flat, ctrl)
    np.testing.assert_array_equal(shard_flat[flat], state + offset)
    for e in range(n):
        for t in range(4):
            np.testing.assert_array_equal(ctrl[e // slots, t, 6 * (e % slots) :][:6], velocity[e])
    assert not ctrl[-1, :, 6:].any(), "the phantom slot's controls stay zero"

    # the physics: shard times advance by the control step, except shard 1 (stalled)
    step, dt, speed = 0.02, 0.005, 10.0
    t0 = np.ones(shards)
    shard_flat[np.arange(shards) * nshard] = 1.0 + step
    shard_flat[1 * nshard] = 1.0
    shard_flat[flat[0, 5]] = np.nan  # env 0: not finite
    shard_flat[flat[4, 8]] = 11.0 + offset[4, 8]  # env 4: runaway linear speed
    out = np.empty((n, 14))
    unstable = np.empty(n, dtype=bool)
    checks = K.Checks(control_step=step, timestep=dt, runaway_speed=speed)
    K.gather(shard_flat, layout, t0, checks, out, unstable)
    np.testing.assert_array_equal(out, shard_flat[flat] - offset)
    assert unstable.tolist() == [True, False, True, True, True]


def test_check_unstable_is_gathers_test_without_shards() -> None:
    state = np.zeros((4, 14))
    state[1, 5] = np.nan  # not finite
    state[2, 9] = 11.0  # linear runaway
    state[3, 12] = 99.0  # angular: under 10 x 10 rad/s
    unstable = np.empty(4, dtype=bool)
    K.check_unstable(
        state, K.Checks(control_step=0.02, timestep=0.0005, runaway_speed=10.0), unstable
    )
    assert unstable.tolist() == [False, True, True, False]
    state[3, 12] = 101.0
    K.check_unstable(
        state, K.Checks(control_step=0.02, timestep=0.0005, runaway_speed=10.0), unstable
    )
    assert unstable.tolist() == [False, True, True, True]
