"""Inside starts until take-off (TaskConfig.inside_starts_until).

Starting a share of the training episodes inside the hole (TaskConfig.inside_starts) lets the
critic meet the success reward before the agent can find the hole, and ends the stalls of a
teacher-free run. Kept on for the whole run, a quarter of the experience is easy, and the
policy's own starts get less of it (the constant-share run on a fresh seed ended at 90 % on
the test split where the recipe ends at 96 %). This gate turns the inside starts off for good
once the agent copes with the task's own starts: when `window` task episodes (inside starts
not counted) in a row have succeeded at `target` or more. It is the reverse curriculum's
hand-over, decided by the same counts as the success-gated spawn curriculum
(sim/task/curriculum.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class TakeoffGate:
    """Whether the inside starts are still on, and the task episodes counted since the last
    decision."""

    target: float
    """Success rate of a window of task episodes at or above which inside starts stop, in
    (0, 1]."""
    window: int = 256
    """Task episodes between two decisions."""
    open: bool = True
    """Inside starts are still drawn."""
    episodes: int = 0
    """Task episodes finished since the last decision."""
    successes: int = 0
    """Successes among them."""
    closed_at: int = -1
    """The env step (the env's global_step) at which the gate closed, -1 while open."""

    def __post_init__(self) -> None:
        if not 0.0 < self.target <= 1.0:
            raise ValueError(f"inside_starts_until = {self.target}: give a rate in (0, 1]")
        if self.window < 1:
            raise ValueError(f"take-off window = {self.window}: give at least 1 episode")

    def update(self, counted: np.ndarray, success: np.ndarray, step: int) -> None:
        """Count the task episodes that ended this step (counted, success: (n,) bool), in env
        order so that the decision falls at the same episode on every run of the seed."""
        if not self.open:
            return
        counted = np.asarray(counted, bool)
        for ok in (np.asarray(success, bool) & counted)[counted].tolist():
            self.episodes += 1
            self.successes += int(ok)
            if self.episodes < self.window:
                continue
            if self.successes >= self.target * self.episodes:
                self.open, self.closed_at = False, int(step)
                return
            self.episodes = self.successes = 0

    def state(self) -> np.ndarray:
        """(4,) int64: open, episodes, successes, closed_at (for the env's exact resume)."""
        return np.array([self.open, self.episodes, self.successes, self.closed_at], dtype=np.int64)

    def load(self, state: np.ndarray) -> None:
        is_open, episodes, successes, closed_at = np.asarray(state, dtype=np.int64).tolist()
        self.open, self.episodes, self.successes = bool(is_open), episodes, successes
        self.closed_at = closed_at
