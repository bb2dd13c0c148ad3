"""Which implementation of the per-step arithmetic the simulator runs: the compiled kernels
(sim/step_kernel.py, numba) where numba imports, else their numpy forms (sim/step_numpy.py).
Both have the same functions and signatures and give the same results."""

from __future__ import annotations

from types import ModuleType

import numpy as np

from sim.config import TaskConfig

KERNELS = ("auto", "numba", "numpy")
"""Accepted names: auto (numba if it imports, else numpy), numba, numpy."""


def kernels(name: str = "auto") -> ModuleType:
    """The module of step functions for `name` (see KERNELS); ValueError for an unknown
    name, ImportError naming the fix when numba is asked for and missing."""
    if name not in KERNELS:
        raise ValueError(f"kernels = {name!r}; expected one of {KERNELS}")
    if name != "numpy":
        try:
            from sim import step_kernel

            return step_kernel
        except ImportError as e:
            if name == "numba":
                raise ImportError(
                    f"kernels='numba' needs numba ({e}): `pip install numba`, or use "
                    "kernels='numpy' (same results, slower)"
                ) from e
    from sim import step_numpy

    return step_numpy


def score_params(cfg: TaskConfig) -> np.ndarray:
    """The `params` array that `score` takes, in its order: dist_pos_weight,
    dist_rot_weight, success_radius, failure_depth, failure_reward, obs_pos_noise,
    obs_rot_noise."""
    return np.array(
        [cfg.dist_pos_weight, cfg.dist_rot_weight, cfg.success_radius, cfg.failure_depth,
         cfg.failure_reward, cfg.obs_pos_noise, cfg.obs_rot_noise]
    )  # fmt: skip
