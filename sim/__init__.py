"""Batched simulation of the peg-in-hole task over a dataset of modules.

    from sim import PegInHoleVecEnv, TaskConfig
    env = PegInHoleVecEnv("datasets/test", num_envs=1024, config=TaskConfig())
    obs = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(actions)

Folders: engines/ (the physics engines behind one interface, and their registry), task/ (the
task's numbers and rules, the per-step kernels, curricula and a scripted expert), assets/
(what the simulator reads of a dataset), bench/ (throughput, load and contact stress
benchmarks), adapters/ (gymnasium and torch views); env.py is the vector env.

The names below are imported on first use, so that `import sim.engines.registry` (the
command line's parsers) loads neither MuJoCo nor the compiled kernels.
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "AssetError": "sim.assets.loading",
    "load_dataset": "sim.assets.loading",
    "load_module": "sim.assets.loading",
    "EVAL_CONFIG": "sim.task.config",
    "PhysicsConfig": "sim.task.config",
    "TaskConfig": "sim.task.config",
    "PegInHoleVecEnv": "sim.env",
    "make_eval_env": "sim.env",
    "make_train_env": "sim.env",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'sim' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])
