"""Snapshots of an evaluation in progress, so that a cut one goes on where it stopped.

The paper's protocol plays every module ten times; on contact-heavy policies that is an hour
or more of a CPU core, and a stopped machine would otherwise lose all of it. Every `every_s`
seconds `evaluate` hands its whole state (the env's, the counters, torch's RNG, a recurrent
policy's latents) to `save`; a later evaluation with the same `key` (checkpoint, dataset,
seed, flags) loads it and ends with the same results, episode for episode, as an uncut one.
The file sits beside the result (`OUT.partial.safetensors`) and is removed when the result
is written. It is written as a training checkpoint is (rl/checkpoint.py: arrays as tensors,
the rest as JSON, atomic, checked by its digest), so loading unpickles nothing.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any


def snapshot_path(out: Path) -> Path:
    """Where the evaluation that writes `out` keeps its snapshot: OUT.partial.safetensors."""
    return out.with_name(out.name + ".partial.safetensors")


def snapshot_progress(path: Path) -> dict[str, float] | None:
    """{"episodes", "seconds"} an evaluation's snapshot file holds, read from its header
    alone (cheap at any size); None when there is no readable snapshot."""
    from safetensors import SafetensorError, safe_open

    try:
        with safe_open(str(path), framework="pt") as f:
            state = json.loads((f.metadata() or {}).get("json", "{}"))["state"]
            episodes = f.get_slice(state["returns"]["__tensor__"]).get_shape()[0]
        return {"episodes": float(episodes), "seconds": float(state["seconds"])}
    except (SafetensorError, OSError, ValueError, RuntimeError, KeyError, TypeError):
        return None


class EvalSnapshots:
    """Where and how often an evaluation saves itself, and what it must match to resume.

    path: the snapshot file. key: JSON-able facts a resumed evaluation must share with the
    saved one (a snapshot of another key, or a corrupt one, is set aside with a message, not
    loaded). every_s: seconds between snapshots."""

    def __init__(self, path: Path, key: dict[str, Any], every_s: float = 300.0) -> None:
        if every_s < 0:
            raise ValueError(f"every_s = {every_s}: give 0 or more seconds between snapshots")
        self.path = Path(path)
        self.key = json.loads(json.dumps(key))
        self.every_s = every_s
        self._last = time.monotonic()

    def load(self) -> dict[str, Any] | None:
        """The saved state of this evaluation, or None (no snapshot, or one set aside)."""
        from rl import checkpoint as ckpt

        if not self.path.exists():
            return None
        try:
            tensors, doc = ckpt.load(self.path)
        except ckpt.CheckpointError as e:
            print(f"{e}; starting from the first episode", file=sys.stderr)
            return None
        if doc.get("key") != self.key:
            print(
                f"{self.path}: a snapshot of another evaluation (its checkpoint, dataset "
                "or flags differ); starting from the first episode",
                file=sys.stderr,
            )
            return None
        state = ckpt.unpack(doc["state"], tensors)
        print(
            f"{self.path}: resuming after {len(state['returns'])} episodes "
            f"({float(state['seconds']):.0f} s of evaluation saved)",
            file=sys.stderr,
        )
        return state

    def due(self) -> bool:
        """Whether every_s seconds have passed since the last snapshot (or the start)."""
        return time.monotonic() - self._last >= self.every_s

    def save(self, state: dict[str, Any]) -> None:
        """Write `state` whole or not at all (rl/checkpoint.py's save)."""
        from rl import checkpoint as ckpt

        tensors: dict[str, Any] = {}
        ckpt.save(self.path, tensors, {"key": self.key, "state": ckpt.pack(state, "s", tensors)})
        self._last = time.monotonic()

    def clear(self) -> None:
        """Remove the snapshot (its evaluation is finished)."""
        self.path.unlink(missing_ok=True)
