"""Which implementation of the per-step arithmetic the simulator runs: the compiled kernels
(sim/step_kernel.py, numba) where numba imports, else their numpy forms (sim/step_numpy.py).
Both have the same functions and signatures and give the same results."""

from __future__ import annotations

from types import ModuleType

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
