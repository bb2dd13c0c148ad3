"""Gymnasium and torch views of the vector env."""

from __future__ import annotations

import warnings
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from sim.adapters.gymnasium_env import GymEnv, GymVectorEnv
from sim.env import PegInHoleVecEnv
from tests.test_sim_common import modules, quiet


def test_single_env_passes_gymnasiums_checker() -> None:
    env = GymEnv(PegInHoleVecEnv(list(modules()[:1]), 1, replace(quiet(), noise=True)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*render modes.*")  # no rendering
        check_env(env)


def test_gymnasium_make_and_make_vec() -> None:
    """The registered id gives the single env (gymnasium's checker passes on it) and the
    batched one, over a dataset folder."""
    from sim.adapters.gymnasium_env import ENV_ID
    from tests.test_sim_common import sim_dataset

    env = gym.make(ENV_ID, dataset=str(sim_dataset()), curriculum_steps=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*render modes.*")
        check_env(env.unwrapped)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (18,) and env.unwrapped.env.cfg.curriculum_steps == 0
    env.close()
    envs = gym.make_vec(ENV_ID, num_envs=3, dataset=str(sim_dataset()))
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (3, 18)
    obs, r, term, trunc, _ = envs.step(envs.action_space.sample())
    assert r.shape == term.shape == trunc.shape == (3,)
    envs.close()
    with pytest.raises(ValueError, match="no dataset spec named"):
        gym.make(ENV_ID, dataset="no-such-dataset")


def test_vector_env_follows_gymnasiums_same_step_autoreset() -> None:
    inner = PegInHoleVecEnv(list(modules()[:2]), 3, replace(quiet(), noise=True, max_steps=4))
    env = gym.wrappers.vector.RecordEpisodeStatistics(GymVectorEnv(inner))
    assert env.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    obs, info = env.reset(seed=0)
    assert obs in env.observation_space and info == {}
    returns = np.zeros(3)
    for _ in range(4):
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        assert obs in env.observation_space
        assert r.shape == term.shape == trunc.shape == (3,)
        returns += r
    assert trunc.all() and info["_final_obs"].all()
    assert all(o in env.single_observation_space for o in info["final_obs"])
    assert info["episode"]["l"].tolist() == [4, 4, 4]
    assert info["episode"]["r"] == pytest.approx(returns)
    assert info["final_info"]["episode_return"] == pytest.approx(returns)
    env.close()


def test_torch_adapter_speaks_tensors() -> None:
    torch = pytest.importorskip("torch")
    from sim.adapters.torch_env import TorchVecEnv

    env = TorchVecEnv(PegInHoleVecEnv(list(modules()[:2]), 2, quiet()))
    obs = env.reset(seed=0)
    assert obs.dtype == torch.float32 and obs.shape == (2, 18)
    obs, r, term, trunc, info = env.step(torch.zeros(2, 6))
    assert r.dtype == torch.float32 and term.dtype == torch.bool and trunc.dtype == torch.bool
    assert info["final_obs"].shape == (2, 18)
    with pytest.raises(ValueError, match="envs \\[0\\]"):
        env.step(torch.tensor([[float("nan")] * 6, [0.0] * 6]))
