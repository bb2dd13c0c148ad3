"""The vector env on torch tensors: the same contract as sim/env.py, arrays as tensors.

torch is imported here only (optional dependency). Observations are float32, rewards
float32, flags bool, all on `device`; info arrays become tensors the same way.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from sim.env import PegInHoleVecEnv


class TorchVecEnv:
    """PegInHoleVecEnv with torch tensors in and out (see sim/env.py for the contract)."""

    def __init__(self, env: PegInHoleVecEnv, device: str | torch.device = "cpu") -> None:
        self.env = env
        self.device = torch.device(device)
        self.num_envs = env.num_envs
        self.obs_dim = env.obs_dim
        self.act_dim = env.act_dim
        self.control_dt = env.control_dt

    def _t(self, a: np.ndarray, dtype: torch.dtype | None = None) -> torch.Tensor:
        return torch.as_tensor(np.ascontiguousarray(a), dtype=dtype, device=self.device)

    def reset(self, seed: int | None = None) -> torch.Tensor:
        return self._t(self.env.reset(seed), torch.float32)

    def step(
        self, actions: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, dict[str, Any]]:
        a = actions.detach().to("cpu", torch.float64).numpy()
        obs, reward, terminated, truncated, info = self.env.step(a)
        tinfo = {
            k: self._t(v, torch.float32 if v.dtype.kind == "f" else None) for k, v in info.items()
        }
        return (
            self._t(obs, torch.float32),
            self._t(reward, torch.float32),
            self._t(terminated),
            self._t(truncated),
            tinfo,
        )

    def close(self) -> None:
        self.env.close()
