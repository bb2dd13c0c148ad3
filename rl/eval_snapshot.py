"""Snapshots of an evaluation in progress, so that a cut one goes on where it stopped.

The paper's protocol plays every module ten times; on contact-heavy policies that is an hour
or more of a CPU core, and a stopped machine would otherwise lose all of it. Every `every_s`
seconds `evaluate` hands its whole state (the env's, the counters, torch's RNG) to `save`;
a later evaluation with the same `key` (checkpoint, dataset, seed, flags) loads it and ends
with the same results, episode for episode, as an uncut one. The file sits beside the
result (`OUT.partial.npz`), written to a temporary name and renamed, and is removed when the
result is written. Arrays go into the npz as they are; everything else into one JSON entry
(Python's ints and floats round-trip exactly), so loading unpickles nothing.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

_ARRAY = "__array__"


def _split(value: Any, arrays: dict[str, np.ndarray], path: str) -> Any:
    """value with every numpy array replaced by a reference into `arrays`."""
    if isinstance(value, np.ndarray):
        arrays[path] = value
        return {_ARRAY: path}
    if isinstance(value, dict):
        return {k: _split(v, arrays, f"{path}/{k}") for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_split(v, arrays, f"{path}/{i}") for i, v in enumerate(value)]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _join(value: Any, arrays: Any) -> Any:
    if isinstance(value, dict):
        if set(value) == {_ARRAY}:
            return np.array(arrays[value[_ARRAY]])
        return {k: _join(v, arrays) for k, v in value.items()}
    if isinstance(value, list):
        return [_join(v, arrays) for v in value]
    return value


class EvalSnapshots:
    """Where and how often an evaluation saves itself, and what it must match to resume.

    path: the snapshot file (.npz). key: JSON-able facts a resumed evaluation must share with
    the saved one (a snapshot of another key is set aside with a message, not loaded).
    every_s: seconds between snapshots."""

    def __init__(self, path: Path, key: dict[str, Any], every_s: float = 300.0) -> None:
        if every_s < 0:
            raise ValueError(f"every_s = {every_s}: give 0 or more seconds between snapshots")
        self.path = Path(path)
        self.key = json.loads(json.dumps(key))
        self.every_s = every_s
        self._last = time.monotonic()

    def load(self) -> dict[str, Any] | None:
        """The saved state of this evaluation, or None (no snapshot, or one of another key)."""
        if not self.path.exists():
            return None
        with np.load(self.path, allow_pickle=False) as z:
            doc = json.loads(str(z["json"]))
            if doc.get("key") != self.key:
                print(
                    f"{self.path}: a snapshot of another evaluation (its checkpoint, dataset "
                    "or flags differ); starting from the first episode",
                    file=sys.stderr,
                )
                return None
            return _join(doc["state"], {k: z[k] for k in z.files if k != "json"})

    def due(self) -> bool:
        """Whether every_s seconds have passed since the last snapshot (or the start)."""
        return time.monotonic() - self._last >= self.every_s

    def save(self, state: dict[str, Any]) -> None:
        """Write `state` whole or not at all: a temporary file, renamed over the last."""
        arrays: dict[str, np.ndarray] = {}
        doc = {"key": self.key, "state": _split(state, arrays, "s")}
        tmp = self.path.with_name(f".{self.path.name}.tmp")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "wb") as f:
            np.savez(f, json=np.array(json.dumps(doc)), **arrays)
        os.replace(tmp, self.path)
        self._last = time.monotonic()

    def clear(self) -> None:
        """Remove the snapshot (its evaluation is finished)."""
        self.path.unlink(missing_ok=True)
