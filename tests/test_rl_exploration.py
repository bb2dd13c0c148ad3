"""SAC's pink exploration noise (rl/exploration.py): unit variance, correlated over time, and
what the actor adds to its mean when acting."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from rl.configs import SACConfig
from rl.exploration import ColoredNoise
from rl.sac import SAC


def _lag1(x: np.ndarray) -> float:
    """Mean lag-1 autocorrelation of (T, n) series."""
    x = (x - x.mean(0)) / x.std(0)
    return float((x[1:] * x[:-1]).mean())


def test_pink_noise_has_unit_variance_and_is_correlated_over_time() -> None:
    steps = 2000
    pink = ColoredNoise(64, 6, 500, 1.0, seed=0)
    white = ColoredNoise(64, 6, 500, 0.0, seed=0)
    p = np.stack([pink.sample() for _ in range(steps)]).reshape(steps, -1)
    w = np.stack([white.sample() for _ in range(steps)]).reshape(steps, -1)
    assert p.shape == (steps, 384) and p.dtype == np.float32
    assert p.std() == pytest.approx(1.0, abs=0.1) and w.std() == pytest.approx(1.0, abs=0.05)
    assert abs(_lag1(w)) < 0.02
    assert _lag1(p) > 0.5  # successive steps mostly push the same way
    # the streams of different envs and dimensions are independent
    assert abs(np.corrcoef(p[:, 0], p[:, 1])[0, 1]) < 0.2


def test_noise_state_restores_the_stream_and_names_a_wrong_shape() -> None:
    a = ColoredNoise(4, 2, 10, 1.0, seed=3)
    for _ in range(7):
        a.sample()
    buffer, values = a.state()
    expected = [a.sample() for _ in range(15)]  # crosses a cut to a new sequence
    b = ColoredNoise(4, 2, 10, 1.0, seed=99)
    b.load_state(buffer, values)
    for e in expected:
        np.testing.assert_array_equal(b.sample(), e)
    with pytest.raises(ValueError, match=r"\(4, 2, 10\), this run's \(8, 2, 10\).*--envs"):
        ColoredNoise(8, 2, 10, 1.0, seed=0).load_state(buffer, values)


def test_a_pink_actor_adds_the_noise_stream_to_its_mean() -> None:
    torch.manual_seed(0)
    cfg = SACConfig(hidden=(8,), batch_size=4, buffer_size=64, warmup_steps=0,
                    exploration="pink", noise_period=20)  # fmt: skip
    agent = SAC(3, 2, 5, cfg)
    obs = np.random.default_rng(0).normal(size=(5, 3)).astype(np.float32)
    shadow = ColoredNoise(5, 2, 20, 1.0, seed=0)
    shadow.load_state(*agent.noise.state())
    with torch.no_grad():
        mu, log_std = agent.actor.net(agent.actor.encode(torch.as_tensor(obs))).chunk(2, -1)
        mu, std = mu.numpy(), log_std.clamp(-5.0, 2.0).exp().numpy()
    for _ in range(3):  # the stream goes on step after step
        eps = shadow.sample()
        np.testing.assert_allclose(agent.act(obs), np.tanh(mu + std * eps), atol=1e-5)


def test_exploration_is_validated() -> None:
    with pytest.raises(ValueError, match="exploration in"):
        SACConfig(exploration="brown").validate()
