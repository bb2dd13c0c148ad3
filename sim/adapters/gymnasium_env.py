"""Gymnasium views of the vector env: a `gymnasium.vector.VectorEnv` (all envs) and a
`gymnasium.Env` (one env, for `gymnasium.utils.env_checker.check_env`), registered as
`assetgen/PegInHole-v0` when this module is imported:

    import gymnasium as gym
    import sim.adapters.gymnasium_env  # registers the id
    env = gym.make("assetgen/PegInHole-v0", dataset="test")
    envs = gym.make_vec("assetgen/PegInHole-v0", num_envs=64, dataset="test")

(or in one line, `gym.make("sim.adapters.gymnasium_env:assetgen/PegInHole-v0", dataset=...)`).

gymnasium is imported here only, so sim/ works without it (it is an optional dependency).
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from sim.env import PegInHoleVecEnv

_EPISODE_KEYS = ("success", "failure", "unstable", "episode_return", "episode_length")


def _spaces() -> tuple[gym.spaces.Box, gym.spaces.Box]:
    # positions: a peg starts within 0.4 m of the entrance and moves at most 0.25 m/s * sqrt 3
    # for 10 s, so 10 m bounds them; rotation-matrix entries lie in [-1, 1]
    high = np.array([10.0] * 3 + [1.0] * 6 + [10.0] * 3 + [1.0] * 6, dtype=np.float32)
    obs = gym.spaces.Box(-high, high, dtype=np.float32)
    act = gym.spaces.Box(-1.0, 1.0, (PegInHoleVecEnv.act_dim,), np.float32)
    return obs, act


class GymVectorEnv(VectorEnv):
    """All envs of a PegInHoleVecEnv as a gymnasium VectorEnv with same-step autoreset.

    On a step that ends episodes, info holds gymnasium's same-step keys: "final_obs" (an
    object array with the last observation where an episode ended, "_final_obs" the mask)
    and "final_info" (the episode's success, failure, unstable, return, length and
    time_to_success, each with its "_key" mask).
    """

    metadata: ClassVar[dict[str, Any]] = {"autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(self, env: PegInHoleVecEnv) -> None:
        self.env = env
        self.num_envs = env.num_envs
        self.single_observation_space, self.single_action_space = _spaces()
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        # one generator for the adapter and the env: seeded resets reproduce both
        self.env.rng = self.np_random
        if seed is not None:
            self.env.restart_modules()
        return self.env.reset(), {}

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
        obs, reward, terminated, truncated, info = self.env.step(actions)
        done = terminated | truncated
        infos: dict[str, Any] = {}
        if done.any():
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(done):
                final_obs[i] = info["final_obs"][i]
            final_info: dict[str, Any] = {}
            for k in _EPISODE_KEYS:
                final_info[k] = np.where(done, info[k], np.zeros_like(info[k]))
                final_info[f"_{k}"] = done.copy()
            ok = done & info["success"]
            final_info["time_to_success"] = np.where(ok, info["time_to_success"], 0.0)
            final_info["_time_to_success"] = ok
            infos = {
                "final_obs": final_obs,
                "_final_obs": done.copy(),
                "final_info": final_info,
                "_final_info": done.copy(),
            }
        return obs, reward, terminated, truncated, infos

    def close_extras(self, **kwargs: Any) -> None:
        self.env.close()


class GymEnv(gym.Env):
    """One environment (a PegInHoleVecEnv with num_envs = 1) as a gymnasium Env.

    The wrapped env resets itself when an episode ends; this view returns that episode's
    last observation (gymnasium's contract), and the next `reset()` starts a new episode.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": []}

    def __init__(self, env: PegInHoleVecEnv) -> None:
        if env.num_envs != 1:
            raise ValueError(f"GymEnv wraps exactly one env, got num_envs = {env.num_envs}")
        self.env = env
        self.observation_space, self.action_space = _spaces()

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self.env.rng = self.np_random
        if seed is not None:
            self.env.restart_modules()
        return self.env.reset()[0], {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(np.asarray(action)[None])
        done = bool(terminated[0] or truncated[0])
        out: dict[str, Any] = {}
        if done:
            obs = info["final_obs"]
            out = {k: info[k][0].item() for k in _EPISODE_KEYS}
            if out["success"]:
                out["time_to_success"] = float(info["time_to_success"][0])
        return obs[0].copy(), float(reward[0]), bool(terminated[0]), bool(truncated[0]), out

    def close(self) -> None:
        self.env.close()


ENV_ID = "assetgen/PegInHole-v0"
"""The gymnasium id of the task (registered when this module is imported)."""


def _vec_env(
    dataset: str, num_envs: int, seed: int, keep_physics: bool, task: dict[str, Any]
) -> PegInHoleVecEnv:
    from dataclasses import replace

    from sim.assets.loading import check_physics, dataset_root
    from sim.task.config import TaskConfig

    root = dataset_root(dataset)
    config = replace(TaskConfig(physics=check_physics(root, keep_physics)), **task)
    # with fewer envs than modules every episode takes the next module (make_train_env)
    return PegInHoleVecEnv(root, num_envs, config, assignment_seed=seed, rotate_modules=True)


def make_env(dataset: str, seed: int = 0, keep_physics: bool = False, **task: Any) -> GymEnv:
    """`gymnasium.make(ENV_ID, dataset=...)`: one env over the dataset (a spec name or a
    folder), a new module every episode; `task`: TaskConfig fields to replace (e.g.
    curriculum_steps=0 for the full spawn ranges); keep_physics: as for make_train_env."""
    return GymEnv(_vec_env(dataset, 1, seed, keep_physics, task))


def make_vector_env(
    dataset: str, num_envs: int = 1, seed: int = 0, keep_physics: bool = False, **task: Any
) -> GymVectorEnv:
    """`gymnasium.make_vec(ENV_ID, num_envs=N, dataset=...)`: N envs stepped together."""
    return GymVectorEnv(_vec_env(dataset, num_envs, seed, keep_physics, task))


if ENV_ID not in gym.registry:
    gym.register(
        ENV_ID,
        entry_point="sim.adapters.gymnasium_env:make_env",
        vector_entry_point="sim.adapters.gymnasium_env:make_vector_env",
    )
