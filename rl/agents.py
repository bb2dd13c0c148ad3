"""The algorithms the runner trains: the Agent protocol the runner drives, building a fresh
agent, and an agent's optional hooks (a recurrent agent's `reset(mask)`, its acting state).
Their names and config classes are rl/algorithms.py's registry (ALGOS).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields
from typing import Any, Protocol

import numpy as np
import torch

from rl.algorithms import ALGOS, config_class
from rl.dreamer.agent import Dreamer
from rl.ppo import PPO
from rl.presets import AlgoConfig
from rl.random_agent import RandomAgent
from rl.sac import SAC


class Agent(Protocol):
    """What the runner needs of an algorithm (PPO, SAC, Dreamer, RandomAgent).

    A recurrent agent (Dreamer) also has `reset(mask (N,) bool)`: new episodes start where
    mask is True. The runner calls it after every env.reset, evaluation/protocol.py after each
    step; stateless agents need not define it (see `reset_hook`).
    """

    steps_per_iteration: int
    log_keys: tuple[str, ...]

    def act(self, obs: np.ndarray) -> np.ndarray: ...
    def policy(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray: ...
    def process_step(
        self,
        next_obs: np.ndarray,
        reward: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        info: dict[str, Any],
    ) -> None: ...
    def update(self, last_obs: np.ndarray) -> dict[str, float]: ...
    def modules(self) -> dict[str, torch.nn.Module | torch.optim.Optimizer]: ...
    def extra_state(self) -> tuple[dict[str, torch.Tensor], dict[str, Any]]: ...
    def load_extra_state(
        self, tensors: dict[str, torch.Tensor], values: dict[str, Any]
    ) -> None: ...


def build_agent(
    algo: str,
    obs_dim: int,
    act_dim: int,
    num_envs: int,
    config: AlgoConfig,
    device: str | torch.device,
    seed: int = 0,
) -> Agent:
    """A fresh agent of `algo` ("ppo", "sac", "dreamer", "random")."""
    if algo == "ppo":
        return PPO(obs_dim, act_dim, num_envs, config, device)  # type: ignore[arg-type]
    if algo == "sac":
        return SAC(obs_dim, act_dim, num_envs, config, device)  # type: ignore[arg-type]
    if algo == "dreamer":
        return Dreamer(obs_dim, act_dim, num_envs, config, device, seed)  # type: ignore[arg-type]
    if algo == "random":
        return RandomAgent(act_dim, seed, config)  # type: ignore[arg-type]
    raise ValueError(f"unknown algorithm {algo!r}; valid algorithms: {sorted(ALGOS)}")


def reset_hook(agent: Any) -> Callable[[np.ndarray], None] | None:
    """The agent's `reset(mask)` when it keeps a recurrent state, else None."""
    fn = getattr(agent, "reset", None)
    return fn if callable(fn) else None


def acting_state_hooks(agent: Any) -> tuple[Callable[[], Any], Callable[[Any], None]] | None:
    """(acting_state, load_acting_state) of an agent with a recurrent state, else None: what
    an evaluation's snapshot saves of the policy (evaluation/protocol.py)."""
    get, put = getattr(agent, "acting_state", None), getattr(agent, "load_acting_state", None)
    return (get, put) if callable(get) and callable(put) else None


def config_from_dict(algo: str, d: dict[str, Any]) -> AlgoConfig:
    """Rebuild a config dataclass from its JSON form (lists back to tuples)."""
    cls = config_class(algo)
    tuples = {f.name for f in fields(cls) if isinstance(f.default, tuple)}
    return cls(**{k: tuple(v) if k in tuples else v for k, v in d.items()})


def default_device() -> str:
    """CUDA when present, else CPU."""
    return "cuda" if torch.cuda.is_available() else "cpu"
