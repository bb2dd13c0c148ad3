"""One episode on each of a dataset's first modules, stepped in the open: the loop that the
episode probes (benchmarks/approach.py, benchmarks/jams.py) share. The caller reads the true
poses from `episodes.env` between steps; each env's first episode alone counts (an env whose
episode ends restarts, and what it does afterwards is ignored)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

Act = Callable[[np.ndarray], np.ndarray]
Reset = Callable[[np.ndarray], None]


def checkpoint_policy(
    checkpoint: str, deterministic: bool = True, seed: int = 0
) -> tuple[Act, int, Reset | None]:
    """(observations -> actions, the observation stack it trained with, the hook that restarts
    a recurrent policy's state per env or None) for a run folder or checkpoint, on one torch
    thread and seeded, so that a probe's sampled actions repeat."""
    import torch

    from rl.agents import reset_hook
    from rl.run_state import load_agent

    torch.set_num_threads(1)
    torch.manual_seed(seed)
    agent, meta = load_agent(checkpoint, None)
    act: Act = lambda o: agent.policy(o, deterministic=deterministic)  # noqa: E731
    return act, int(meta.get("stack", 1)), reset_hook(agent)


class ModuleEpisodes:
    """Iterating yields (control step t, the action taken at t) before each step, for the
    env's full step limit. After it: `success` (per env, its first episode succeeded) and
    `end_step` (the control step at which that episode ended; NaN: it ran past the limit)."""

    def __init__(
        self,
        act: Act,
        dataset: str,
        modules: int,
        seed: int = 0,
        stack: int = 1,
        reset: Reset | None = None,
        robot: str | None = None,
        robot_settings: Any = None,
    ) -> None:
        from sim.env import make_eval_env

        self.env: Any = make_eval_env(dataset, None, seed, modules=modules, robot=robot,
                                      robot_settings=robot_settings)  # fmt: skip
        self._policy_env: Any = self.env
        if stack > 1:  # the policy sees its training's stack of observations
            from rl.stack import StackObs

            self._policy_env = StackObs(self.env, stack)
        self._act, self._reset, self._seed = act, reset, seed
        n = self.env.num_envs
        self.steps: int = self.env.cfg.max_steps
        self.success = np.zeros(n, bool)
        self.end_step = np.full(n, np.nan)

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        obs = self._policy_env.reset(self._seed)
        if self._reset is not None:
            self._reset(np.ones(self.env.num_envs, dtype=bool))
        for t in range(self.steps):
            a = self._act(obs)
            yield t, a
            obs, _, terminated, truncated, info = self._policy_env.step(a)
            done = terminated | truncated
            if self._reset is not None:
                self._reset(done)
            first = done & ~self.ended
            self.success[first] = np.asarray(info["success"])[first]
            self.end_step[first] = t

    @property
    def ended(self) -> np.ndarray:
        """Per env: its first episode has ended."""
        return ~np.isnan(self.end_step)

    def jammed(self) -> np.ndarray:
        """Per env: its first episode neither succeeded nor ended before the last step (the
        step limit cut it short)."""
        cut = ~self.ended | (self.end_step == self.steps - 1)
        return cut & ~self.success
