"""N copies of a gymnasium env behind the vector-env contract (rl/vec_env.py).

Used by the tests and the Pendulum benchmark. Actions in [-1, 1] are rescaled linearly onto
the env's Box action bounds; observations are flattened to float32. `success` is the
env's `info["is_success"]` when it gives one (else False), `time_to_success` is the
episode's length times the env's `dt` (when it has one) where it succeeded, else NaN.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from rl.vec_env import StepResult


class GymVecEnv:
    """`num_envs` gymnasium envs, stepped in turn, with automatic reset.

    `env` is a registered id (e.g. "Pendulum-v1") or a callable that builds one env.
    `reset(seed)` seeds env i with seed + i, so a seeded run is reproducible.
    """

    def __init__(self, env: str | Callable[[], Any], num_envs: int, **make_kwargs: Any) -> None:
        try:
            import gymnasium as gym
        except ImportError as e:  # an optional dependency: fail where it is used
            raise ImportError("GymVecEnv needs gymnasium: pip install gymnasium") from e
        if num_envs < 1:
            raise ValueError(f"num_envs = {num_envs}: need at least 1")
        build = (lambda: gym.make(env, **make_kwargs)) if isinstance(env, str) else env
        self.envs = [build() for _ in range(num_envs)]
        space = self.envs[0].action_space
        if not isinstance(space, gym.spaces.Box):
            raise ValueError(f"GymVecEnv needs a Box action space, got {space}")
        self.num_envs = num_envs
        self.obs_dim = int(np.prod(self.envs[0].observation_space.shape))
        self.act_dim = int(np.prod(space.shape))
        self._act_shape = space.shape
        self._low = space.low.astype(np.float64).ravel()
        self._high = space.high.astype(np.float64).ravel()
        self.control_dt = float(getattr(self.envs[0].unwrapped, "dt", np.nan))
        """Seconds per step (NaN when the env does not say)."""
        self._return = np.zeros(num_envs)
        self._length = np.zeros(num_envs, dtype=np.int64)

    def reset(self, seed: int | None = None) -> np.ndarray:
        """obs (N, obs_dim) float32; env i is seeded with seed + i."""
        obs = [e.reset(seed=None if seed is None else seed + i)[0] for i, e in enumerate(self.envs)]
        self._return[:] = 0.0
        self._length[:] = 0
        return np.stack([np.ravel(o) for o in obs]).astype(np.float32)

    def step(self, actions: np.ndarray) -> StepResult:
        """actions (N, act_dim) in [-1, 1] -> obs, reward, terminated, truncated, info."""
        a = np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)
        # [-1, 1] -> [low, high]: low + (a + 1) / 2 * (high - low)
        a = self._low + 0.5 * (a + 1.0) * (self._high - self._low)
        n = self.num_envs
        obs = np.empty((n, self.obs_dim), dtype=np.float32)
        final_obs = np.zeros((n, self.obs_dim), dtype=np.float32)
        reward = np.empty(n, dtype=np.float32)
        terminated = np.zeros(n, dtype=bool)
        truncated = np.zeros(n, dtype=bool)
        success = np.zeros(n, dtype=bool)
        for i, e in enumerate(self.envs):
            o, r, term, trunc, inf = e.step(a[i].reshape(self._act_shape))
            obs[i] = np.ravel(o)
            reward[i] = r
            terminated[i], truncated[i] = term, trunc
            success[i] = bool(inf.get("is_success", False))
        self._return += reward
        self._length += 1
        done = terminated | truncated
        info = {
            "final_obs": final_obs,
            "success": success & done,
            "episode_return": self._return.copy(),
            "episode_length": self._length.copy(),
            "time_to_success": np.where(success & done, self._length * self.control_dt, np.nan),
        }
        for i in np.flatnonzero(done):
            final_obs[i] = obs[i]
            obs[i] = np.ravel(self.envs[i].reset()[0])
            self._return[i] = 0.0
            self._length[i] = 0
        return obs, reward, terminated, truncated, info

    def close(self) -> None:
        for e in self.envs:
            e.close()
