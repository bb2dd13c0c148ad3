"""Modules replayed by their failures (TaskConfig.module_replay).

A rotating env hands each finished episode's module to the back of a queue and takes the
front one, so every module takes its turn equally. The modules are not equally hard: a peg
of three or four corners fits its hole only within a few degrees of yaw, and a tilted hole
asks for the tilt too (`python -m benchmarks.by_param`). Prioritized Level Replay (Jiang,
Grefenstette and Rocktäschel, ICML 2021) trains on procedurally generated levels by drawing
the next level by a score of how much is still to learn on it, mixed with plain turns so
that no level is forgotten. Here the score is a module's recent failure rate: an
exponential average over its finished episodes, 1 for a module not played yet. A `share`
of the picks draws from the queue weighted by that score; the others take the queue's
front, the plain turn.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class ModuleReplay:
    """Failure scores of a dataset's modules and the rule that picks the next one."""

    modules: int
    """Modules in the dataset."""
    share: float
    """Fraction of picks weighted by the failure scores, in (0, 1]; the rest are turns."""
    rate: float = 0.3
    """Weight of a module's newest episode in its failure score, in (0, 1]."""
    floor: float = 0.02
    """Added to every score, so a module that no longer fails is still drawn now and then."""
    failure: np.ndarray = field(init=False)
    """(modules,) recent failure rate of each module (1 before its first episode)."""
    episodes: np.ndarray = field(init=False)
    """(modules,) finished episodes of each module."""

    def __post_init__(self) -> None:
        bad = {
            "modules": self.modules < 1,
            "share": not 0.0 < self.share <= 1.0,
            "rate": not 0.0 < self.rate <= 1.0,
            "floor": not self.floor > 0.0,
        }
        if any(bad.values()):
            name = next(k for k, v in bad.items() if v)
            raise ValueError(
                f"module replay {name} = {getattr(self, name)}: the share and rate are in "
                "(0, 1], the floor above 0, and there is at least 1 module"
            )
        self.failure = np.ones(self.modules)
        self.episodes = np.zeros(self.modules, dtype=np.int64)

    def update(self, module: np.ndarray, done: np.ndarray, success: np.ndarray) -> None:
        """Score the episodes that ended this step: module (n,) the envs' module indices,
        done and success (n,) bool. In env order, so a seed replays identically."""
        done = np.asarray(done, bool)
        for k, ok in zip(np.asarray(module)[done].tolist(), np.asarray(success)[done].tolist(),
                         strict=True):  # fmt: skip
            self.failure[k] += self.rate * (float(not ok) - self.failure[k])
            self.episodes[k] += 1

    def pick(self, rng: np.random.Generator, queue: list[int]) -> int:
        """Position in `queue` (module indices waiting) of the module to play next."""
        if rng.random() >= self.share:
            return 0  # a plain turn: the front of the queue
        w = self.failure[queue] + self.floor
        return int(rng.choice(len(queue), p=w / w.sum()))

    def state(self) -> np.ndarray:
        """(2, modules) float64: failure scores and episode counts (the env's exact resume)."""
        return np.stack([self.failure, self.episodes.astype(np.float64)])

    def load(self, state: np.ndarray) -> None:
        state = np.asarray(state, dtype=np.float64)
        if state.shape != (2, self.modules):
            raise ValueError(
                f"module replay state of shape {state.shape}, this env has {self.modules} "
                "modules: build the env with the same dataset"
            )
        self.failure = state[0].copy()
        self.episodes = state[1].astype(np.int64)
