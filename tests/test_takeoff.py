"""benchmarks.takeoff: when a run's training success first reaches the threshold, and
whether it stalled, counted in env steps, from run folders as the runner writes them."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from benchmarks.takeoff import env_labels, main, stall_rates, takeoff
from rl.report_load import load_run
from tests.test_rl_report import fake_run as report_run

NAN = math.nan


def fake_run(path: Path, algo, stack, seed, steps, rates, episodes=None, warmup=0) -> Path:
    """rl.report's fake run with the runner's episodes column (default: 100 more finished
    episodes every row) and SAC's warm-up in its config."""
    report_run(path, algo, stack, seed, steps, rates)
    episodes = episodes or [100 * (i + 1) for i in range(len(steps))]
    rows = list(csv.DictReader(open(path / "metrics.csv")))
    with open(path / "metrics.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for row, n in zip(rows, episodes, strict=True):
            w.writerow(row | {"episodes": n})
    meta = json.loads((path / "config.json").read_text())
    meta["config"] = {"warmup_steps": warmup}
    (path / "config.json").write_text(json.dumps(meta))
    return path


def test_take_off_is_the_first_row_at_the_threshold_within_the_stall_steps(tmp_path: Path) -> None:
    steps = [100_000, 200_000, 300_000, 400_000]
    early = load_run(fake_run(tmp_path / "a", "sac", 1, 0, steps, [NAN, 0.05, 0.10, 0.02]))
    late = load_run(fake_run(tmp_path / "b", "sac", 1, 1, steps, [0.0, 0.0, 0.0, 0.5]))
    never = load_run(fake_run(tmp_path / "c", "sac", 1, 2, steps, [0.0, 0.09, 0.0, 0.0]))
    short = load_run(fake_run(tmp_path / "d", "sac", 1, 3, steps[:2], [0.0, 0.0]))

    a = takeoff(early, 0.10, 300_000)
    assert (a.verdict, a.steps, a.minutes) == ("took off", 300_000, pytest.approx(3000 / 60))
    # taking off after the stall steps is still a stall, and its late success is reported
    b = takeoff(late, 0.10, 300_000)
    assert (b.verdict, b.steps, b.last_success) == ("stalled", None, 0.5)
    assert takeoff(never, 0.10, 300_000).verdict == "stalled"
    # a run cut before the stall steps decided nothing
    assert takeoff(short, 0.10, 300_000).verdict == "unfinished"

    rows = [takeoff(r, 0.10, 300_000) for r in (early, late, never, short)]
    assert stall_rates(rows) == {"SAC": (2, 3)}


def test_lucky_windows_of_the_warm_up_are_not_a_take_off(tmp_path: Path) -> None:
    steps = [10_000, 20_000, 30_000, 40_000, 50_000, 60_000]
    # a half-full window of random episodes, then a full one still holding warm-up
    # episodes (warm-up: 20 k env steps, 150 episodes by then), then the policy's own
    run = fake_run(tmp_path / "a", "sac", 1, 0, steps, [0.4, 0.2, 0.15, 0.05, 0.12, 0.2],
                   episodes=[50, 150, 200, 249, 250, 300], warmup=20_000)  # fmt: skip
    t = takeoff(load_run(run), 0.10, 60_000)
    assert (t.verdict, t.steps) == ("took off", 50_000)


def test_runs_differing_in_env_options_are_counted_apart(tmp_path: Path, capsys) -> None:
    steps = [500_000, 1_000_000]
    paths = []
    for i, (opts, rates) in enumerate(
        [({"near_starts": 0.25}, [0.2, 0.3]), ({}, [0.0, 0.0]), ({}, [0.0, 0.4])]
    ):
        path = fake_run(tmp_path / f"r{i}", "sac", 1, i, steps, rates)
        meta = json.loads((path / "config.json").read_text())
        meta["env_options"] = {"curriculum_steps": 1_000_000} | opts
        (path / "config.json").write_text(json.dumps(meta))
        paths.append(str(path))
    # the option every run shares names no group
    assert env_labels(paths) == ["near_starts=0.25", "", ""]
    out = tmp_path / "takeoff.json"
    main([*paths, "--json", str(out)])
    doc = json.loads(out.read_text())
    assert doc["stall_rates"] == {
        "SAC near_starts=0.25": {"stalled": 0, "runs": 1},
        "SAC": {"stalled": 1, "runs": 2},
    }
    assert "stall rate 1 of 2: SAC" in capsys.readouterr().out


def test_bad_threshold_is_one_line(tmp_path: Path, capsys) -> None:
    path = fake_run(tmp_path / "a", "sac", 1, 0, [1], [0.0])
    with pytest.raises(SystemExit):
        main([str(path), "--threshold", "0"])
    assert "--threshold 0.0: give a training success in (0, 1]" in capsys.readouterr().err
