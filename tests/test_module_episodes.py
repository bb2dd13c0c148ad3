"""benchmarks/module_episodes.py: each env's first episode alone counts, and a jam is an
episode the step limit cut short (or that ended unsuccessfully on the last step)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

import sim.env
from benchmarks.module_episodes import ModuleEpisodes


class ScriptedEnds:
    """Five envs, five control steps. Env 0 succeeds at step 1 and then fails (its restart
    must not count), env 1 fails at step 2, env 2 succeeds on the last step, env 3 never
    ends (the limit), env 4 ends unsuccessfully on the last step (the limit as well)."""

    num_envs = 5
    cfg = SimpleNamespace(max_steps=5)

    def __init__(self) -> None:
        self.t = 0

    def reset(self, seed: int) -> np.ndarray:
        return np.zeros((5, 1))

    def step(self, action: np.ndarray):
        ends = {1: ([0], [True]), 2: ([1], [False]), 3: ([0], [False]), 4: ([2, 4], [True, False])}
        done = np.zeros(5, bool)
        success = np.zeros(5, bool)
        for i, ok in zip(*ends.get(self.t, ([], [])), strict=True):
            done[i], success[i] = True, ok
        self.t += 1
        return np.zeros((5, 1)), np.zeros(5), done, np.zeros(5, bool), {"success": success}


def test_first_episodes_and_jams(monkeypatch) -> None:
    monkeypatch.setattr(sim.env, "make_eval_env", lambda *a, **k: ScriptedEnds())
    resets: list[np.ndarray] = []
    episodes = ModuleEpisodes(lambda o: np.zeros((5, 6)), "unused", 5, reset=resets.append)
    steps = [t for t, _ in episodes]
    assert steps == [0, 1, 2, 3, 4]
    assert episodes.success.tolist() == [True, False, True, False, False]
    assert episodes.end_step[:3].tolist() == [1.0, 2.0, 4.0] and np.isnan(episodes.end_step[3])
    assert episodes.jammed().tolist() == [False, False, False, True, True]
    assert resets[0].all() and len(resets) == 6  # the start, then after every step
