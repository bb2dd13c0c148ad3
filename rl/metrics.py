"""What a training run logs: the columns of metrics.csv, the window of finished episodes
its statistics come from (saved with every checkpoint), and the writer of metrics.csv and
TensorBoard scalars.
"""

from __future__ import annotations

import csv
import math
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from rl.host_view import host
from rl.progress import console

BASE_COLUMNS = (
    "iteration",
    "env_steps",
    "wall_s",
    "steps_per_s",
    "episodes",
    "success_rate",
    "return_mean",
    "length_mean",
    "time_to_success_median",
)
"""Columns every metrics.csv has. wall_s: wall-clock seconds of training since the run
began (logs, probes and checkpoints included; a resumed run goes on from its checkpoint's);
steps_per_s: the env steps of the row's iteration over its own time."""

PROBE_COLUMNS = ("probe_success_rate", "probe_time_to_success_median", "probe_truncation_rate")
"""Columns of the frozen-policy probe (`train --probe-steps`), empty in other rows."""


class EpisodeStats:
    """The last `size` finished episodes: (return, length, success, time to success)."""

    def __init__(self, size: int) -> None:
        self.window: deque[tuple[float, int, bool, float]] = deque(maxlen=size)
        self.total = 0

    def add(self, done: Any, info: dict[str, Any]) -> None:
        """Record the episodes that ended where done (N,) is True (arrays or tensors), but
        not those the env marks `assisted` (started inside the hole: not the task's starts)."""
        done = host(done)
        if "assisted" in info:
            done = done & ~host(info["assisted"])
        idx = np.flatnonzero(done)
        if not len(idx):
            return
        keys = ("episode_return", "episode_length", "success", "time_to_success")
        r, n, s, t = (host(info[k])[idx] for k in keys)
        for row in zip(r.tolist(), n.tolist(), s.tolist(), t.tolist(), strict=True):
            self.window.append((float(row[0]), int(row[1]), bool(row[2]), float(row[3])))
        self.total += len(idx)

    def summary(self) -> dict[str, float]:
        """Means over the window (NaN when empty)."""
        if not self.window:
            return {
                k: math.nan
                for k in ("success_rate", "return_mean", "length_mean", "time_to_success_median")
            }
        r, n, s, t = (np.array(c, dtype=float) for c in zip(*self.window, strict=True))
        t = t[s > 0]
        return {
            "success_rate": float(s.mean()),
            "return_mean": float(r.mean()),
            "length_mean": float(n.mean()),
            "time_to_success_median": float(np.median(t)) if len(t) else math.nan,
        }

    def state(self) -> dict[str, Any]:
        return {"window": [list(w) for w in self.window], "total": self.total}

    def load(self, state: dict[str, Any]) -> None:
        self.window.extend(tuple(w) for w in state["window"])
        self.total = state["total"]


class MetricsLog:
    """metrics.csv (fixed columns) and, when tensorboard is installed, TensorBoard scalars."""

    def __init__(
        self,
        out_dir: Path,
        columns: tuple[str, ...],
        resume_iteration: int | None,
        tensorboard: bool,
    ) -> None:
        self.path = out_dir / "metrics.csv"
        self.columns = columns
        rows: list[dict[str, str]] = []
        if resume_iteration is not None and self.path.exists():
            # drop rows logged after the checkpoint: the resumed run logs them again
            with open(self.path, newline="") as f:
                rows = [r for r in csv.DictReader(f) if int(r["iteration"]) <= resume_iteration]
        with open(self.path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=columns)
            w.writeheader()
            w.writerows(rows)
        self.tb = None
        if tensorboard:
            try:
                from torch.utils.tensorboard import SummaryWriter
            except ImportError:
                console.print("tensorboard is not installed: logging to metrics.csv only")
            else:
                self.tb = SummaryWriter(str(out_dir / "tb"), purge_step=resume_iteration)

    def write(self, row: dict[str, float]) -> None:
        with open(self.path, "a", newline="") as f:
            csv.DictWriter(f, fieldnames=self.columns).writerow(
                {k: row.get(k, "") for k in self.columns}
            )
        if self.tb is not None:
            step = int(row["env_steps"])
            for k, v in row.items():
                if k not in ("iteration", "env_steps") and not math.isnan(v):
                    self.tb.add_scalar(k, v, step)

    def close(self) -> None:
        if self.tb is not None:
            self.tb.close()
