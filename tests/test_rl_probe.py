"""The frozen-policy probe of training runs (evaluation/probe.py): when it runs, what it logs, that
it measures the frozen policy, that a recurrent agent's acting state survives it, and that
runs with a probe still resume exactly."""

from __future__ import annotations

import csv

import numpy as np
import pytest
import torch

from evaluation.probe import make_probe
from rl.checkpoint import CheckpointError
from rl.dreamer.agent import Dreamer
from rl.run_state import load_agent
from tests.test_dreamer import SETUP as DREAMER_SETUP
from tests.test_dreamer import TINY
from tests.test_rl_runner import SAC_SETUP, Interrupt, _train, _weights
from tests.toy_env import StatefulToyEnv, ToyEnv

torch.set_num_threads(1)


def test_probe_rows_and_frozen_policy(tmp_path) -> None:
    probe = make_probe(ToyEnv(3), attempts=2)
    res = _train("sac", ToyEnv(4), SAC_SETUP, tmp_path / "run", steps=256, probe=probe,
                 probe_steps=64)  # fmt: skip
    assert res["status"] == "done"
    rows = list(csv.DictReader(open(tmp_path / "run" / "metrics.csv")))
    probed = [int(r["iteration"]) for r in rows if r["probe_success_rate"] != ""]
    assert probed == [2, 4, 6, 8]  # 64 env steps = 2 iterations of 4 envs x 8 steps
    for r in rows:
        if r["probe_success_rate"] != "":
            assert 0.0 <= float(r["probe_success_rate"]) <= 1.0
            assert 0.0 <= float(r["probe_truncation_rate"]) <= 1.0
    # the same frozen policy on the same episodes gives the same figures
    agent, _ = load_agent(tmp_path / "run")
    a, b = make_probe(ToyEnv(3), 2)(agent), make_probe(ToyEnv(3), 2)(agent)
    assert a.keys() == b.keys() and all(np.isclose(a[k], b[k], equal_nan=True) for k in a)
    with pytest.raises(ValueError, match="probe_steps"):
        _train("sac", ToyEnv(4), SAC_SETUP, tmp_path / "r2", steps=64, probe=probe, probe_steps=0)
    with pytest.raises(ValueError, match="attempts"):
        make_probe(ToyEnv(3), attempts=0)


class Homing:
    """Heads for the goal when deterministic, wanders when sampled."""

    def policy(self, obs, deterministic=True):
        if not deterministic:
            return np.random.default_rng(0).uniform(-1, 1, (len(obs), 2))
        d = obs[:, 2:]
        return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)


def test_probe_runs_the_deterministic_policy() -> None:
    res = make_probe(ToyEnv(4, max_steps=60), attempts=3)(Homing())
    assert res["probe_success_rate"] == 1.0 and res["probe_truncation_rate"] == 0.0
    assert 0 < res["probe_time_to_success_median"] < 60 * 0.02


def test_probe_keeps_a_recurrent_agents_acting_state() -> None:
    torch.manual_seed(0)
    agent = Dreamer(4, 2, 3, TINY)
    env = ToyEnv(3)
    obs = env.reset(seed=0)
    for _ in range(3):
        agent.act(obs)
        obs, *_ = env.step(np.zeros((3, 2)))
    before = agent.acting_state()
    make_probe(ToyEnv(5), attempts=1)(agent)  # 5 envs: the policy re-initialises its state
    after = agent.acting_state()
    assert set(before) == set(after) == {"deter", "stoch", "prev_action", "first"}
    for k in before:
        assert np.array_equal(before[k], after[k]), k
    assert not before["first"].any() and before["deter"].shape[0] == 3


def test_run_with_probe_resumes_exactly(tmp_path) -> None:
    kw = {"probe": make_probe(ToyEnv(2), 1), "probe_steps": 32}
    full = _train("dreamer", StatefulToyEnv(4), DREAMER_SETUP, tmp_path / "full", steps=96, **kw)
    assert full["status"] == "done"
    cut = _train("dreamer", Interrupt(StatefulToyEnv(4), 20), DREAMER_SETUP, tmp_path / "cut",
                 steps=96, **kw)  # fmt: skip
    assert cut["status"] == "interrupted"
    with pytest.raises(CheckpointError, match="probe_steps"):
        _train("dreamer", StatefulToyEnv(4), DREAMER_SETUP, tmp_path / "cut", steps=96,
               resume=True)  # fmt: skip
    _train("dreamer", StatefulToyEnv(4), DREAMER_SETUP, tmp_path / "cut", steps=96, resume=True,
           **kw)  # fmt: skip
    a, b = _weights(tmp_path / "full"), _weights(tmp_path / "cut")
    assert all(torch.equal(a[k], b[k]) for k in a)
    rows = [list(csv.DictReader(open(tmp_path / d / "metrics.csv"))) for d in ("full", "cut")]
    assert [r["probe_success_rate"] for r in rows[0]] == [r["probe_success_rate"] for r in rows[1]]
