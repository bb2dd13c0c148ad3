"""A tiny, fast env implementing the vector-env contract: a point in the plane reaching a
goal. For tests, smoke runs and examples; no physics, no dependencies beyond numpy.

    obs (N, 4)       [position x, y, goal - position x, y]
    action (N, 2)    velocity in [-1, 1]; position += step_size * action
    reward           distance progress d_(t-1) - d_t; +1 on success; -1 on failure
    terminated       success (distance < goal_radius) or failure (|position| > bound)
    truncated        max_steps reached
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rl.vec_env import StepResult


class ToyEnv:
    """`num_envs` point-reaching envs with automatic reset (module docstring)."""

    obs_dim = 4
    act_dim = 2

    def __init__(
        self,
        num_envs: int,
        max_steps: int = 20,
        step_size: float = 0.1,
        goal_radius: float = 0.1,
        bound: float = 3.0,
        control_dt: float = 0.02,
    ) -> None:
        self.num_envs = num_envs
        self.max_steps, self.step_size = max_steps, step_size
        self.goal_radius, self.bound, self.control_dt = goal_radius, bound, control_dt
        self.rng = np.random.default_rng()
        self.pos = np.zeros((num_envs, 2))
        self.goal = np.zeros((num_envs, 2))
        self.steps = np.zeros(num_envs, dtype=np.int64)
        self.ret = np.zeros(num_envs)

    def _obs(self) -> np.ndarray:
        return np.concatenate([self.pos, self.goal - self.pos], axis=1).astype(np.float32)

    def _reset_envs(self, idx: np.ndarray) -> None:
        self.pos[idx] = self.rng.uniform(-1.0, 1.0, (len(idx), 2))
        self.goal[idx] = self.rng.uniform(-1.0, 1.0, (len(idx), 2))
        self.steps[idx] = 0
        self.ret[idx] = 0.0

    def reset(self, seed: int | None = None) -> np.ndarray:
        """obs (N, 4) float32."""
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self._reset_envs(np.arange(self.num_envs))
        return self._obs()

    def step(self, actions: np.ndarray) -> StepResult:
        """actions (N, 2) in [-1, 1] -> obs, reward, terminated, truncated, info."""
        a = np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)
        d_prev = np.linalg.norm(self.goal - self.pos, axis=1)
        self.pos = self.pos + self.step_size * a
        d = np.linalg.norm(self.goal - self.pos, axis=1)
        success = d < self.goal_radius
        failure = ~success & (np.abs(self.pos).max(axis=1) > self.bound)
        reward = d_prev - d + success * 1.0
        reward = np.where(failure, -1.0, reward).astype(np.float32)
        self.steps += 1
        self.ret += reward
        terminated = success | failure
        truncated = ~terminated & (self.steps >= self.max_steps)
        done = terminated | truncated
        info = {
            "final_obs": self._obs(),
            "success": success,
            "episode_return": self.ret.copy(),
            "episode_length": self.steps.copy(),
            "time_to_success": np.where(success, self.steps * self.control_dt, np.nan),
        }
        self._reset_envs(np.flatnonzero(done))
        return self._obs(), reward, terminated, truncated, info


class StatefulToyEnv(ToyEnv):
    """ToyEnv with get_state/set_state: checkpointed mid-episode for an exact resume."""

    def get_state(self) -> dict[str, Any]:
        return {
            "rng": self.rng.bit_generator.state,
            "pos": self.pos.copy(),
            "goal": self.goal.copy(),
            "steps": self.steps.copy(),
            "ret": self.ret.copy(),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        self.rng = np.random.default_rng()
        self.rng.bit_generator.state = state["rng"]
        self.pos, self.goal = np.array(state["pos"]), np.array(state["goal"])
        self.steps, self.ret = np.array(state["steps"]), np.array(state["ret"])
