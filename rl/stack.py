"""Observation stacking (the paper's STACK variants) as a wrapper of the vector-env contract.

The stacked observation of one env is its last K observations, newest first:

    stacked_t = [o_t, o_(t-1), ..., o_(t-K+1)]        shape (K * obs_dim,)

At the start of an episode (reset, or an automatic reset after the episode ended) the
history is filled with the episode's first observation: [o_0, o_0, ..., o_0]. Where an
episode ends, info["final_obs"] is stacked the same way: [o_T, o_(T-1), ...], exactly the
observation the agent would have seen next had the episode gone on.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rl.vec_env import StepResult, VecEnv, is_stateful


class StackObs:
    """Wraps a VecEnv so observations are the last `k` ones, newest first (obs_dim * k)."""

    def __init__(self, env: VecEnv, k: int) -> None:
        if k < 1:
            raise ValueError(f"stack k = {k}: stack at least 1 observation (1 = no stacking)")
        self.env = env
        self.k = k
        self.num_envs = env.num_envs
        self.act_dim = env.act_dim
        self.obs_dim = env.obs_dim * k
        self.control_dt = getattr(env, "control_dt", float("nan"))
        # history (N, K, obs_dim): [:, 0] the newest observation
        self._hist = np.zeros((env.num_envs, k, env.obs_dim), dtype=np.float32)
        if is_stateful(env):
            self.get_state = self._get_state
            self.set_state = self._set_state

    def _flat(self, hist: np.ndarray) -> np.ndarray:
        return hist.reshape(len(hist), self.obs_dim).copy()

    def reset(self, seed: int | None = None) -> np.ndarray:
        """obs (N, K * obs_dim) float32: the first observation repeated K times."""
        obs = np.asarray(self.env.reset(seed), dtype=np.float32)
        self._hist[:] = obs[:, None, :]
        return self._flat(self._hist)

    def step(self, actions: np.ndarray) -> StepResult:
        """As the wrapped env's step, with obs and info["final_obs"] stacked (N, K * obs_dim)."""
        obs, reward, terminated, truncated, info = self.env.step(actions)
        obs = np.asarray(obs, dtype=np.float32)
        done = np.asarray(terminated) | np.asarray(truncated)
        # shift: h_t = [o_t, h_(t-1)[0 : K-1]]; a finished episode's newest entry is final_obs
        newest = np.where(done[:, None], np.asarray(info["final_obs"], np.float32), obs)
        self._hist[:, 1:] = self._hist[:, :-1]
        self._hist[:, 0] = newest
        info = dict(info)
        info["final_obs"] = self._flat(self._hist)
        # a new episode starts from its first observation repeated K times
        self._hist[done] = obs[done][:, None, :]
        return self._flat(self._hist), reward, terminated, truncated, info

    def _get_state(self) -> dict[str, Any]:
        return {"env": self.env.get_state(), "stack_history": self._hist.copy()}  # type: ignore[attr-defined]

    def _set_state(self, state: dict[str, Any]) -> None:
        self.env.set_state(state["env"])  # type: ignore[attr-defined]
        self._hist[:] = state["stack_history"]

    def close(self) -> None:
        if hasattr(self.env, "close"):
            self.env.close()
