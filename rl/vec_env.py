"""The vector-env contract: everything rl/ knows about an environment.

N = num_envs environments step together on numpy arrays. Shapes:

    reset(seed)   -> obs (N, obs_dim) float32
    step(actions (N, act_dim) float32 in [-1, 1])
                  -> obs        (N, obs_dim) float32
                     reward     (N,) float32 (float64 accepted; rl/ casts)
                     terminated (N,) bool   the episode ended in a terminal state
                                            (success or failure): no bootstrapping
                     truncated  (N,) bool   the episode was cut (time limit, unstable
                                            physics): bootstrap from info["final_obs"]
                     info       dict of arrays, valid where terminated | truncated:
                         final_obs        (N, obs_dim) float32  last obs of the finished episode
                         success          (N,) bool
                         episode_return   (N,) float   sum of that episode's rewards
                         episode_length   (N,) int     its steps
                         time_to_success  (N,) float   seconds; NaN where no success

Automatic reset: where terminated | truncated, the returned `obs` row is already the
first observation of that env's next episode. Other info keys are allowed and ignored.

Exact resume (optional): an env that also has `get_state() -> dict` and
`set_state(state: dict)` (values: numpy arrays or JSON-able scalars, lists and dicts,
e.g. physics state, RNG state, episode counters, curriculum counter) is checkpointed with
the agent and resumed mid-episode, unless it sets `stateful = False` (an engine whose state
cannot be saved, such as PhysX's scene). Without them the runner re-seeds the env with
`reset(seed=...)` at every checkpoint boundary, which makes resume exact for any env
whose trajectories depend only on that seed and the actions.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

StepResult = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]
"""(obs (N, obs_dim), reward (N,), terminated (N,), truncated (N,), info)."""

EPISODE_KEYS = ("final_obs", "success", "episode_return", "episode_length", "time_to_success")
"""The info keys every env must provide (see the module docstring)."""


@runtime_checkable
class VecEnv(Protocol):
    """N environments with automatic reset (shapes in the module docstring)."""

    num_envs: int
    """N, the number of environments stepping together."""
    obs_dim: int
    """Length of one observation."""
    act_dim: int
    """Length of one action; actions lie in [-1, 1]."""

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Start a new episode in every env; returns obs (N, obs_dim) float32. A seed makes
        everything after it reproducible."""
        ...

    def step(self, actions: np.ndarray) -> StepResult:
        """Advance every env by one step with actions (N, act_dim) in [-1, 1]."""
        ...


@runtime_checkable
class StatefulVecEnv(VecEnv, Protocol):
    """A VecEnv whose full state can be saved and restored (exact mid-episode resume)."""

    def get_state(self) -> dict[str, Any]:
        """Everything needed to continue identically: numpy arrays or JSON-able values."""
        ...

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a state returned by `get_state` (on an env built the same way)."""
        ...


def is_stateful(env: Any) -> bool:
    """Whether `env` saves and restores its state (StatefulVecEnv): it has both methods and
    does not say otherwise (`stateful = False`: an env whose engine cannot, e.g. PhysX)."""
    has = hasattr(env, "get_state") and hasattr(env, "set_state")
    return has and bool(getattr(env, "stateful", True))


def check_step(env: VecEnv, result: StepResult) -> None:
    """Raise ValueError naming the first array of a step result that breaks the contract."""
    n, d = env.num_envs, env.obs_dim
    obs, reward, terminated, truncated, info = result
    want = {
        "obs": (obs, (n, d)),
        "reward": (reward, (n,)),
        "terminated": (terminated, (n,)),
        "truncated": (truncated, (n,)),
    }
    for k in EPISODE_KEYS:
        if k not in info:
            raise ValueError(f"info lacks {k!r}; every step's info needs {list(EPISODE_KEYS)}")
        want[f'info["{k}"]'] = (info[k], (n, d) if k == "final_obs" else (n,))
    for name, (a, shape) in want.items():
        if np.shape(a) != shape:
            raise ValueError(f"{name} has shape {np.shape(a)}, the contract says {shape}")
    for name, a in (("terminated", terminated), ("truncated", truncated)):
        if np.asarray(a).dtype != np.bool_:
            raise ValueError(f"{name} has dtype {np.asarray(a).dtype}, the contract says bool")
