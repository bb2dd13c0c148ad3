"""A uniform sequence replay of per-env streams, in numpy.

Each env has its own ring of `capacity // num_envs` steps. A step is what the world model
reads at time t:

    obs          (obs_dim,) float32   o_t (the last observation of an episode included)
    prev_action  (act_dim,) float32   a_(t-1), the action that led to o_t (0 at a first step)
    reward       ()         float32   r_t, received on reaching o_t (0 at a first step)
    is_first     ()         bool      o_t starts an episode
    is_terminal  ()         bool      o_t ends it in a terminal state (truncations: False)

Sequences of `length` consecutive steps of one env are drawn uniformly over all those
stored; they may cross episode boundaries (the RSSM resets its state where is_first), and
the first step of every sequence is marked is_first, so each starts from the initial state.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np


class ReplayMemoryError(ValueError):
    """The replay would not fit in the memory available."""


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (MemAvailable of /proc/meminfo, else
    the free physical pages); None when the system tells neither."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


class SequenceReplay:
    """Per-env rings of steps (module docstring). Memory is taken at the first `add` or
    `load` (an agent loaded only to act never allocates it), after checking that it fits."""

    def __init__(self, capacity: int, num_envs: int, obs_dim: int, act_dim: int) -> None:
        self.num_envs = num_envs
        self.per_env = max(1, capacity // num_envs)
        self.specs: dict[str, tuple[tuple[int, ...], type]] = {
            "obs": ((obs_dim,), np.float32),
            "prev_action": ((act_dim,), np.float32),
            "reward": ((), np.float32),
            "is_first": ((), np.bool_),
            "is_terminal": ((), np.bool_),
        }
        self.data: dict[str, np.ndarray] = {}
        self.pos = np.zeros(num_envs, dtype=np.int64)  # next row written, per env
        self.count = np.zeros(num_envs, dtype=np.int64)  # rows filled, per env

    @property
    def nbytes(self) -> int:
        """Bytes the full replay takes."""
        row = sum(np.dtype(t).itemsize * int(np.prod(s)) for s, t in self.specs.values())
        return row * self.per_env * self.num_envs

    def _allocate(self) -> None:
        if self.data:
            return
        need, have = self.nbytes, available_memory()
        if have is not None and need > have:
            raise ReplayMemoryError(
                f"the replay of {self.per_env * self.num_envs:,} steps needs "
                f"{need / 2**30:.2f} GiB, but only {have / 2**30:.2f} GiB of memory is "
                "available: lower replay_capacity (or the number of envs)"
            )
        self.data = {
            k: np.zeros((self.num_envs, self.per_env, *s), dtype=t)
            for k, (s, t) in self.specs.items()
        }

    def add(self, envs: np.ndarray, **rows: np.ndarray) -> None:
        """Append one step to each env of `envs` (k,) distinct ids; rows: field -> (k, ...)."""
        self._allocate()
        idx = self.pos[envs]
        for k, v in rows.items():
            self.data[k][envs, idx] = v
        self.pos[envs] = (idx + 1) % self.per_env
        self.count[envs] = np.minimum(self.count[envs] + 1, self.per_env)

    def can_sample(self, length: int) -> bool:
        """Whether some env holds a whole sequence of `length` steps."""
        return bool((self.count >= length).any())

    @property
    def size(self) -> int:
        """Steps stored, summed over envs."""
        return int(self.count.sum())

    def sample(self, batch: int, length: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """`batch` sequences (batch, length, ...), drawn uniformly over every stored sequence
        of `length` consecutive steps of one env."""
        starts = np.maximum(self.count - length + 1, 0)  # sequences each env holds
        if starts.sum() == 0:
            raise ValueError(f"no env holds {length} steps yet")
        env = rng.choice(self.num_envs, size=batch, p=starts / starts.sum())
        k = rng.integers(0, starts[env])
        # the oldest row of a full ring is at pos, of a filling one at 0
        oldest = np.where(self.count[env] == self.per_env, self.pos[env], 0)
        rows = (oldest + k)[:, None] + np.arange(length)
        rows %= self.per_env
        out = {key: v[env[:, None], rows] for key, v in self.data.items()}
        out["is_first"][:, 0] = True
        return out

    # ---------------------------------------------------------------- checkpoints

    def filled_bytes(self) -> int:
        """Bytes of the filled part (what a checkpoint would hold)."""
        return self.nbytes * int(self.count.max(initial=0)) // self.per_env

    def state(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """(the filled rows of every field, the counters)."""
        n = int(self.count.max(initial=0))
        arrays = {k: v[:, :n] for k, v in self.data.items()} if n else {}
        return arrays, {"pos": self.pos.tolist(), "count": self.count.tolist()}

    def load(self, arrays: dict[str, np.ndarray], counters: dict[str, Any]) -> None:
        count = np.asarray(counters["count"], dtype=np.int64)
        if len(count) != self.num_envs or count.max(initial=0) > self.per_env:
            raise ValueError("the saved replay does not fit this one (envs or capacity)")
        if arrays:
            self._allocate()
            n = int(count.max())
            for k, v in arrays.items():
                self.data[k][:, :n] = v
        self.pos = np.asarray(counters["pos"], dtype=np.int64)
        self.count = count
