"""`python -m benchmarks.dreamer_footprint`: sizes from the preset, timings measured, bad
counts refused."""

from __future__ import annotations

import json

import pytest

from benchmarks.dreamer_footprint import footprint, main
from rl.presets import get_setup
from sim.task import rules as T


def test_the_replay_size_is_the_presets_capacity_in_float32_rows():
    r = footprint("debug", envs=8, grad_steps=1, policy_steps=1)
    cfg = get_setup("debug", "dreamer").config
    # a row: obs and previous action in float32, the reward in float32, two flags
    row = 4 * (T.OBS_DIM + T.ACT_DIM + 1) + 2
    assert r["replay_steps"] == cfg.replay_capacity
    assert r["replay_mb"] == pytest.approx(row * cfg.replay_capacity / 1e6)
    assert r["rss_replay_full_mb"] >= r["rss_agent_mb"] > 0
    assert r["grad_step_s"] > 0 and r["policy_step_ms"] > 0 and r["policy_envs"] == 8


def test_main_prints_a_json_line_and_refuses_zero_counts(capsys):
    assert (
        main(["--preset", "debug", "--envs", "4", "--grad-steps", "1", "--policy-steps", "1"]) == 0
    )
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert json.loads(last)["preset"] == "debug"
    with pytest.raises(SystemExit):
        main(["--envs", "0"])
    assert "--envs = 0" in capsys.readouterr().err
    assert main(["--preset", "nope"]) == 2
