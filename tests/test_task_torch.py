"""The task arithmetic on torch tensors (sim/task/rules_torch.py) against the compiled kernels it
ports (sim/task/kernel.py), on the kernels' own random batches: every branch (success,
failure outside the hole, pegs inside it, unstable rows), with and without noise."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from sim.task import kernel as K
from sim.task import rules_torch as TT
from sim.task.config import TaskConfig
from tests.test_sim_kernel import N, _batch, _kernel_frames, _score, command_case


def _t(a: np.ndarray) -> torch.Tensor:
    return torch.as_tensor(a)


def _episode(b: dict) -> TT.TorchEpisode:
    return TT.TorchEpisode(
        d0=_t(b["d0"]),
        c_prev=_t(b["c_prev"].copy()),
        returns=_t(b["returns"].copy()),
        last_obs=_t(b["last_obs"]),
    )


@pytest.mark.parametrize("noise", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_score_equals_the_kernel(noise: bool, seed: int) -> None:
    b = _batch(seed)
    cfg = TaskConfig(noise=noise)
    obs, reward, success, failure, returns, c_prev = _score(b, cfg)
    # every branch is reached, or the comparison proves little
    assert success.sum() > 10 and failure.sum() > 10 and b["unstable"].sum() > 5
    episode = _episode(b)
    frames = TT.TorchFrames.of(_kernel_frames(b), "cpu")
    got = TT.score(_t(b["state"][:, 1:4]), _t(b["state"][:, 4:8]), _t(b["unstable"]),
                   _t(b["e"]), frames, episode, K.StepParams.of(cfg))  # fmt: skip
    assert got[0].dtype == torch.float32 and got[0].shape == (N, 18)
    np.testing.assert_array_equal(got[2].numpy(), success)
    np.testing.assert_array_equal(got[3].numpy(), failure)
    np.testing.assert_allclose(got[0].numpy(), obs, rtol=0, atol=2e-7)
    np.testing.assert_allclose(got[1].numpy(), reward, rtol=0, atol=1e-12)
    np.testing.assert_allclose(episode.returns.numpy(), returns, rtol=0, atol=1e-12)
    np.testing.assert_allclose(episode.c_prev.numpy(), c_prev, rtol=0, atol=1e-12)


def test_score_takes_float32_states_as_warp_gives_them() -> None:
    """Warp's states are float32: promoted, they score as the kernel scores the same
    (rounded) states in float64."""
    b = _batch(4)
    b["state"] = b["state"].astype(np.float32).astype(np.float64)
    cfg = TaskConfig(noise=True)
    want = _score(b, cfg)
    episode = _episode(b)
    state32 = torch.as_tensor(b["state"], dtype=torch.float32)
    got = TT.score(state32[:, 1:4], state32[:, 4:8], _t(b["unstable"]), _t(b["e"]),
                   TT.TorchFrames.of(_kernel_frames(b), "cpu"), episode,
                   K.StepParams.of(cfg))  # fmt: skip
    np.testing.assert_array_equal(got[3].numpy(), want[3])
    np.testing.assert_allclose(got[1].numpy(), want[1], rtol=0, atol=1e-12)


def test_observe_of_chosen_envs_equals_the_kernel() -> None:
    b = _batch(3)
    cfg = TaskConfig()
    idx = np.array([5, 0, 399, 17])
    e = b["e"][: len(idx)]
    want = np.empty((len(idx), 18), dtype=np.float32)
    K.observe(b["state"], idx, _kernel_frames(b), e, K.StepParams.of(cfg), out=want)
    f = TT.TorchFrames.of(_kernel_frames(b), "cpu")
    got = TT.observe(_t(b["state"][idx, 1:4]), _t(b["state"][idx, 4:8]), f.rows[idx],
                     f.origin[idx], _t(e), K.StepParams.of(cfg))  # fmt: skip
    np.testing.assert_allclose(got.numpy(), want, rtol=0, atol=2e-7)


def test_command_equals_the_kernel() -> None:
    actions, e, scale, std = command_case()
    for noisy in (False, True):
        want = np.empty((50, 6))
        K.command(actions, e, noisy, scale, std, want)
        got = TT.command(_t(actions).float(), _t(e) if noisy else None, _t(scale), _t(std))
        # float32 actions (a torch policy's) clip and scale as the float64 ones, to 1e-7 m/s
        np.testing.assert_allclose(got.numpy(), want, rtol=0, atol=1e-7)


def test_check_unstable_equals_the_kernel() -> None:
    rng = np.random.default_rng(6)
    state = rng.normal(0, 4, (200, 14))
    state[rng.random(200) < 0.1, 5] = np.nan
    state[rng.random(200) < 0.1, 2] = np.inf
    checks = K.Checks(control_step=0.02, timestep=0.0005, runaway_speed=10.0)
    want = np.empty(200, dtype=bool)
    K.check_unstable(state, checks, want)
    assert 10 < want.sum() < 190
    np.testing.assert_array_equal(TT.check_unstable(_t(state), checks).numpy(), want)


@pytest.mark.parametrize("scale", [1.0, 0.3])
def test_spawn_draws_the_host_spawns_distribution(scale: float) -> None:
    """The torch spawn (its own generator) keeps task.sample_spawn's ranges and matches its
    distribution: offsets within +-scale spawn_xy and scale spawn_z of the entrance, turns
    up to scale spawn_max_angle, the peg's lowest point at least 1 mm above the surface,
    and the same means and spreads as the host's draws within sampling error."""
    from assetgen.core.rotations import quat_conj, quat_mul
    from sim.task import rules as T

    n, cfg = 20000, TaskConfig()
    rng = np.random.default_rng(0)
    pos0 = np.tile([0.01, -0.02, 0.0], (n, 1))
    quat0 = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    verts = np.tile(rng.uniform(-0.02, 0.02, (1, 30, 3)), (n, 1, 1))
    host = T.sample_spawn(rng, pos0, quat0, verts, scale, cfg)
    gen = torch.Generator().manual_seed(0)
    dev = TT.sample_spawn(gen, _t(pos0), _t(quat0), _t(verts), scale, cfg)
    dev = tuple(x.numpy() for x in dev)
    for pos, quat in (host, dev):
        off = pos - pos0
        assert np.abs(off[:, :2]).max() <= cfg.spawn_xy * scale + 1e-12
        np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-12)
        angle = 2 * np.arcsin(np.clip(np.linalg.norm(quat_mul(quat_conj(quat0), quat)[:, 1:],
                                                     axis=1), 0, 1))  # fmt: skip
        assert angle.max() <= cfg.spawn_max_angle * scale + 1e-9
        assert T.heights(pos, quat, verts).min() >= 0.001 - 1e-12
    for h, d in zip(host, dev, strict=True):
        se = h.std(0) / np.sqrt(n)
        assert (np.abs(h.mean(0) - d.mean(0)) < 5 * se + 1e-12).all()
        np.testing.assert_allclose(d.std(0), h.std(0), rtol=0.05, atol=1e-9)
