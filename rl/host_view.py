"""An env on torch tensors seen through numpy arrays, for the agents and wrappers that take
the rl/vec_env.py contract's arrays.

An env whose states live on a GPU (sim/engines/warp/env.py, `tensor_io = True`) takes and returns
torch tensors on its device, so that an agent on that device (PPO) steps it without a copy
through the host. Every other consumer (SAC, DreamerV3, the observation stack, the scripted
agents) gets it through this view: actions go down, observations, rewards, flags and the
info arrays come back as numpy arrays, one copy each way per step.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch


def host(x: Any) -> np.ndarray:
    """`x` as a numpy array (a tensor is copied to the host)."""
    return x.detach().cpu().numpy() if isinstance(x, torch.Tensor) else np.asarray(x)


class HostView:
    """`env` (tensors on `env.device`) with numpy arrays in and out (module doc)."""

    stateful = False
    """Its state is on the device and not saved: a resumed run starts from a reset."""

    def __init__(self, env: Any) -> None:
        self.env = env
        self.num_envs = env.num_envs
        self.obs_dim = env.obs_dim
        self.act_dim = env.act_dim
        self.control_dt = getattr(env, "control_dt", None)

    def reset(self, seed: int | None = None) -> np.ndarray:
        return host(self.env.reset(seed))

    def step(self, actions: np.ndarray) -> tuple[Any, ...]:
        a = torch.as_tensor(np.asarray(actions, dtype=np.float32), device=self.env.device)
        obs, reward, terminated, truncated, info = self.env.step(a)
        return (
            host(obs),
            host(reward),
            host(terminated),
            host(truncated),
            {k: host(v) for k, v in info.items()},
        )

    def close(self) -> None:
        self.env.close()
