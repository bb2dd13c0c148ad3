"""Starts near the hole for a share of the training episodes (TaskConfig.near_starts): those
episodes spawn within near_start_scale of the full ranges whatever the curriculum, the rest
as without it, and an env without it draws exactly as before."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sim.task.config import TaskConfig
from tests.test_cli import run as cli
from tests.test_sim_common import debug_train_args, make_env, quiet, sim_dataset


def _spawn_offsets(cfg: TaskConfig, resets: int = 20) -> np.ndarray:
    """(resets * envs,) spawn heights above the entrance, m, over repeated resets."""
    env = make_env(4, replace(cfg, curriculum_steps=0), num_envs=8)
    heights = []
    for seed in range(resets):
        env.reset(seed=seed)
        heights.append(env.peg_poses()[:, 2, 3] - env.entrance[:, 2, 3])
    return np.concatenate(heights)


def test_near_starts_spawn_within_their_scale_and_the_rest_at_full_range() -> None:
    cfg = quiet()
    full_low = cfg.spawn_z[0]
    everyone = _spawn_offsets(replace(cfg, near_starts=1.0))
    assert everyone.max() <= cfg.near_start_scale * cfg.spawn_z[1] + 0.005
    none = _spawn_offsets(cfg)
    assert none.min() >= full_low - 0.005  # full ranges: 15-25 cm above the entrance
    half = _spawn_offsets(replace(cfg, near_starts=0.5))
    near = half < full_low - 0.02
    assert 0.35 < near.mean() < 0.65, near.mean()


def test_without_it_the_draws_are_those_of_a_run_that_never_had_it() -> None:
    a, b = make_env(4, quiet(), num_envs=8), make_env(4, quiet(), num_envs=8)
    assert TaskConfig().near_starts is None
    rng = np.random.default_rng(0)
    oa, ob = a.reset(seed=3), b.reset(seed=3)
    for _ in range(30):
        act = rng.uniform(-1, 1, (8, 6))
        oa, ob = a.step(act)[0], b.step(act)[0]
    np.testing.assert_array_equal(oa, ob)


@pytest.mark.parametrize("kw", [{"near_starts": 0.0}, {"near_starts": 1.5},
                                {"near_starts": 0.5, "near_start_scale": -0.1}])  # fmt: skip
def test_bad_settings_are_named(kw) -> None:
    with pytest.raises(ValueError, match="near_start"):
        TaskConfig(**kw).validate()


def test_the_env_on_the_device_refuses_it() -> None:
    pytest.importorskip("mujoco_warp")
    from sim.engines.warp.env import make_device_train_env

    with pytest.raises(ValueError, match="host env only"):
        make_device_train_env(str(sim_dataset()), 2, 0, near_starts=0.5)


def test_train_takes_it_and_refuses_bad_shares(tmp_path) -> None:
    base = debug_train_args()
    p = cli(*base, "--near-starts", "0.25", "--out", str(tmp_path / "run"))
    assert p.returncode == 0, p.stderr
    config = (tmp_path / "run" / "config.json").read_text()
    assert '"near_starts": 0.25' in config
    p = cli(*base, "--near-starts", "1.5", "--out", str(tmp_path / "bad"))
    assert p.returncode != 0 and "--near-starts 1.5" in p.stdout + p.stderr
