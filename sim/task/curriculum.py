"""A spawn curriculum gated by success (TaskConfig.curriculum_success).

The default curriculum widens the spawn ranges linearly over a number of env steps, whatever
the agent has learnt: an agent that learns slower than the schedule (SAC without a teacher
on physics version 2 succeeded in 0-6 % of its training episodes for 2 M steps) meets spawns
it cannot handle yet and never gets a foothold. This one widens them when the agent copes,
as IndustReal's sampling-based curriculum does (Tang et al., RSS 2023): the scale starts at
0; each time `window` episodes have finished since its last change, it rises by `increment`
if they succeeded at the target rate or more, falls by as much if they succeeded at less than
half of it, and otherwise stays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class SuccessCurriculum:
    """The scale of the spawn ranges (0: at the entrance, 1: the full ranges) and the
    episodes counted since it last changed."""

    target: float
    """Success rate at or above which the scale rises, in (0, 1]."""
    increment: float = 0.05
    """Change of the scale at a step up or down, in (0, 1]."""
    window: int = 256
    """Finished episodes between two decisions."""
    level: float = 0.0
    """The current scale."""
    episodes: int = 0
    """Episodes finished since the last decision."""
    successes: int = 0
    """Successes among them."""

    def __post_init__(self) -> None:
        bad = {
            "target": not 0.0 < self.target <= 1.0,
            "increment": not 0.0 < self.increment <= 1.0,
            "window": self.window < 1,
            "level": not 0.0 <= self.level <= 1.0,
        }
        if any(bad.values()):
            name = next(k for k, v in bad.items() if v)
            raise ValueError(
                f"curriculum {name} = {getattr(self, name)}: the target and increment are in "
                "(0, 1], the window at least 1 episode, the level in [0, 1]"
            )

    def update(self, done: np.ndarray, success: np.ndarray) -> None:
        """Count the episodes that ended this step (done, success: (n,) bool) and decide
        once a window is full. Episodes are counted in env order, so the decision falls at
        the same episode on every run of the same seed."""
        done = np.asarray(done, bool)
        success = np.asarray(success, bool) & done
        for ok in success[done].tolist():
            self.episodes += 1
            self.successes += int(ok)
            if self.episodes < self.window:
                continue
            rate = self.successes / self.episodes
            if rate >= self.target:
                self.level = min(1.0, self.level + self.increment)
            elif rate < 0.5 * self.target:
                self.level = max(0.0, self.level - self.increment)
            self.episodes = self.successes = 0

    def state(self) -> np.ndarray:
        """(3,) float64: level, episodes, successes (for the env's exact resume)."""
        return np.array([self.level, self.episodes, self.successes], dtype=np.float64)

    def load(self, state: np.ndarray) -> None:
        level, episodes, successes = np.asarray(state, dtype=np.float64).tolist()
        self.level, self.episodes, self.successes = level, int(episodes), int(successes)
