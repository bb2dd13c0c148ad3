"""The random agent: actions uniform in [-1, 1], independent of the observation.

`RandomAgent(act_dim, seed)` is a policy (obs (N, obs_dim) -> actions (N, act_dim)) for
`evaluation.protocol.evaluate`; it also speaks the runner's agent interface, so
`assetgen train --algo random` logs the baseline's returns and success rate.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from rl.configs import RandomConfig


class RandomAgent:
    """Uniform random actions from its own seeded generator."""

    log_keys: tuple[str, ...] = ()

    def __init__(
        self,
        act_dim: int,
        seed: int = 0,
        cfg: RandomConfig | None = None,
    ) -> None:
        self.cfg = cfg or RandomConfig()
        self.act_dim = act_dim
        self.steps_per_iteration = self.cfg.steps_per_iteration
        self.gen = torch.Generator().manual_seed(seed)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """Actions (N, act_dim) uniform in [-1, 1] for obs (N, ...)."""
        return (torch.rand(len(obs), self.act_dim, generator=self.gen) * 2 - 1).numpy()

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self(obs)

    def policy(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        del deterministic
        return self(obs)

    def process_step(self, *args: Any) -> None:
        """Nothing to store."""

    def update(self, last_obs: np.ndarray) -> dict[str, float]:
        """Nothing to learn."""
        del last_obs
        return {}

    def modules(self) -> dict[str, torch.nn.Module | torch.optim.Optimizer]:
        return {}

    def extra_state(self) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
        """The generator's state, so a resumed run draws the same actions."""
        return {"generator": self.gen.get_state()}, {}

    def load_extra_state(self, tensors: dict[str, torch.Tensor], values: dict[str, Any]) -> None:
        del values
        self.gen.set_state(tensors["generator"])
