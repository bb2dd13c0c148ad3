"""Per-step wall times of the module pipeline, for `assetgen bench assets`.

A step adds its seconds to a plain dict the caller passes in (or to nothing: `None` skips
the clock entirely), so timing costs two perf_counter calls per step and the pipeline's
output never depends on it.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

StepTimes = dict[str, float]
"""Seconds by step name, summed over every module timed into the same dict."""


@contextmanager
def step(times: StepTimes | None, name: str) -> Iterator[None]:
    """Add the wall time of the `with` body to times[name] (nothing when times is None)."""
    if times is None:
        yield
        return
    t0 = time.perf_counter()
    try:
        yield
    finally:
        times[name] = times.get(name, 0.0) + time.perf_counter() - t0


def add_times(total: StepTimes, more: StepTimes) -> None:
    """Sum `more` into `total` in place (merging what worker processes measured)."""
    for k, v in more.items():
        total[k] = total.get(k, 0.0) + v
