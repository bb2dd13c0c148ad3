"""Temporally correlated exploration noise for SAC's actor: pink (1/f) noise per env and
action dimension, from pink-noise-rl (Eberhard et al., "Pink Noise Is All You Need", ICLR
2023), in place of the actor's independent Gaussian draw at every step.

Each sample has unit variance, so the actor's std means what it meant; what changes is that
successive steps' noise is correlated, and a policy that hovers (its mean holding the peg
still) is carried millimetres away over a few dozen steps instead of jittering in place.
The stream runs across episode ends (a cut every `period` steps, pink-noise-rl's buffer),
and its buffer, position and generator state are saved with the checkpoint so a resumed run
draws what an uninterrupted one would.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch


class ColoredNoise:
    """Noise (num_envs, act_dim) with a power-law spectrum 1/f^beta along time (beta 1:
    pink, 0: white), one independent stream per env and action dimension."""

    def __init__(self, num_envs: int, act_dim: int, period: int, beta: float, seed: int) -> None:
        from pink import ColoredNoiseProcess

        self.process = ColoredNoiseProcess(
            beta=beta, size=(num_envs, act_dim, period), rng=np.random.default_rng(seed)
        )

    def sample(self) -> np.ndarray:
        """The next step's noise, (num_envs, act_dim) float32."""
        return np.asarray(self.process.sample(), dtype=np.float32)

    def state(self) -> tuple[torch.Tensor, dict[str, Any]]:
        """(the current buffer, JSON-able position and generator state)."""
        p = self.process
        return torch.as_tensor(p.buffer, dtype=torch.float64), {
            "idx": int(p.idx),
            "rng": p.rng.bit_generator.state,
        }

    def load_state(self, buffer: torch.Tensor, values: dict[str, Any]) -> None:
        p = self.process
        if tuple(buffer.shape) != tuple(p.buffer.shape):
            raise ValueError(
                f"the checkpoint's exploration noise is {tuple(buffer.shape)}, this run's "
                f"{tuple(p.buffer.shape)} (envs, action dims, period): resume with the run's "
                "own --envs"
            )
        p.buffer = buffer.numpy().copy()
        p.idx = int(values["idx"])
        p.rng.bit_generator.state = values["rng"]
