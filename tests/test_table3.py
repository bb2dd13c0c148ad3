"""`python -m benchmarks.table3`: a Table III lane trains, evaluates twice and files its results,
and a lane stopped part way picks up where it stopped."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

from benchmarks.table3 import lane, main, plan


def _rows(path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_a_lane_files_its_run_and_picks_up_where_it_stopped(tiny_dataset, tmp_path) -> None:
    runs, results = tmp_path / "runs", tmp_path / "results"
    kw = dict(minutes=0.02, threads=1, runs=runs, dataset=str(tiny_dataset),
              test=str(tiny_dataset), results=results, preset="debug", attempts=1)  # fmt: skip
    assert re.search(r"ppo-stack +seed 0: -train", plan(runs, results))
    assert lane("ppo-stack", 0, **kw) == 0
    run, filed = runs / "ppo-stack-s0", results / "runs/table3/ppo-stack-s0"
    assert sorted(p.name for p in filed.iterdir()) == [
        "config.json", "eval_test.json", "eval_test_sampled.json", "metrics.csv"]  # fmt: skip
    det = json.loads((filed / "eval_test.json").read_text())
    sampled = json.loads((filed / "eval_test_sampled.json").read_text())
    assert det["policy"] == "deterministic" and sampled["policy"] == "stochastic"
    assert det["episodes"] == 6 and det["algo"] == "ppo" and det["stack"] == 10
    assert json.loads((filed / "config.json").read_text())["stack"] == 10
    trained = _rows(run / "metrics.csv")
    assert trained and _rows(filed / "metrics.csv") == trained
    assert re.search(r"ppo-stack +seed 0: \+train \+evaluate eval_test.json", plan(runs, results))

    # a session stopped before the sampled evaluation: the lane does that alone, and its
    # finished training (budget spent) adds no iteration
    (run / "eval_test_sampled.json").unlink()
    before = (run / "eval_test.json").read_bytes()
    assert "-evaluate eval_test_sampled.json -file" in plan(runs, results)
    assert main(["ppo-stack", "--seed", "0", "--minutes", "0.02", "--preset", "debug",
                 "--attempts", "1", "--runs", str(runs), "--results", str(results),
                 "--dataset", str(tiny_dataset), "--test", str(tiny_dataset)]) == 0  # fmt: skip
    assert _rows(run / "metrics.csv") == trained
    assert (run / "eval_test.json").read_bytes() == before
    assert (filed / "eval_test_sampled.json").exists()
    assert not list(filed.parent.glob(".*"))  # no temporary folder left


def test_a_candidate_row_trains_with_its_overrides_flags_and_its_own_budget(
    tiny_dataset, tmp_path, monkeypatch
) -> None:
    import benchmarks.table3 as t3

    monkeypatch.setitem(t3.ROWS, "ppo-cand", t3.Row("ppo", overrides=("obs_symlog_scale=1000",),
                                                    flags=("--near-starts", "0.5"),
                                                    minutes=0.02))  # fmt: skip
    runs, results = tmp_path / "runs", tmp_path / "results"
    # the lane's own --minutes (an hour) is not the candidate's: the row's budget wins
    kw = dict(threads=1, runs=runs, dataset=str(tiny_dataset), test=str(tiny_dataset),
              results=results, preset="debug", attempts=1)  # fmt: skip
    assert lane("ppo-cand", 1, minutes=60.0, **kw) == 0
    filed = results / "runs/table3/ppo-cand-s1"
    config = json.loads((filed / "config.json").read_text())
    assert config["overrides"] == {"obs_symlog_scale": 1000.0}
    assert config["config"]["obs_symlog_scale"] == 1000.0
    assert config["env_options"]["near_starts"] == 0.5  # the row's train flags
    assert json.loads((filed / "eval_test.json").read_text())["overrides"] == config["overrides"]
    assert float(_rows(filed / "metrics.csv")[-1]["wall_s"]) < 60  # not the hour


def test_the_random_row_is_its_evaluation_filed_with_the_baselines(tiny_dataset, tmp_path):
    results = tmp_path / "results"
    kw = dict(minutes=1, threads=1, runs=tmp_path / "runs", dataset=str(tiny_dataset),
              test=str(tiny_dataset), results=results, attempts=1)  # fmt: skip
    assert lane("random", 2, **kw) == 0
    doc = json.loads((results / "baselines/random_test_s2.json").read_text())
    assert doc["agent"] == "random" and doc["episodes"] == 6
    assert re.search(r"random +seed 2: \+evaluate", plan(tmp_path / "runs", results))
    assert not (tmp_path / "runs").exists()  # nothing trained


def test_next_takes_the_lanes_in_order_and_leaves_the_held_and_the_filed(tmp_path) -> None:
    import os
    import subprocess
    import sys

    from benchmarks.table3 import _claim, lanes, next_lanes

    runs, results = tmp_path / "runs", tmp_path / "results"
    assert lanes()[:4] == [("random", 0), ("random", 1), ("random", 2), ("ppo", 0)]
    # random 0 is filed already; random 1 is held by a live process; random 2's holder is gone
    (results / "baselines").mkdir(parents=True)
    (results / "baselines/random_test_s0.json").write_text("{}")
    runs.mkdir()
    (runs / ".random-s1.claim").write_text(str(os.getppid()))
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()  # fmt: skip
    (runs / ".random-s2.claim").write_text(gone)
    ran = []

    def fake_lane(row: str, seed: int) -> int:
        assert (runs / f".{row}-s{seed}.claim").read_text() == str(os.getpid())  # held
        ran.append((row, seed))
        return 0

    assert next_lanes(runs, results, fake_lane, limit=2) == 2
    assert ran == [("random", 2), ("ppo", 0)]
    assert not (runs / ".random-s2.claim").exists() and not (runs / ".ppo-s0.claim").exists()
    assert (runs / ".random-s1.claim").exists()  # the live holder keeps its lane
    assert _claim(runs, "random", 1) is None
    # --plan: who runs a lane, and an evaluation begun (its snapshot) beside one to do
    import numpy as np

    from evaluation.snapshots import EvalSnapshots
    from rl import checkpoint as ckpt

    ckpt.save(runs / "ppo-s1" / "checkpoint.safetensors", {},
              {"counters": {"env_steps": 1_230_000, "wall_s": 1800.0}})  # fmt: skip
    snap = EvalSnapshots(runs / "ppo-s1" / "eval_test.json.partial.safetensors", {})
    snap.save({"returns": np.zeros(640), "seconds": 600.0})
    (runs / ".ppo-s1.claim").write_text(str(os.getppid()))
    (line,) = [
        x for x in plan(runs, results).splitlines() if x.startswith("ppo ") and "seed 1" in x
    ]
    assert "~train ~evaluate eval_test.json -evaluate eval_test_sampled.json -file" in line
    assert f"(running: pid {os.getppid()})" in line
    assert line.endswith("[trained 1.23 M env steps, 30 min; eval_test.json: 640 episodes, 10 min]")
    (runs / "ppo-s1" / "checkpoint.safetensors").write_bytes(b"torn")  # unreadable: no figures
    (line,) = [
        x for x in plan(runs, results).splitlines() if x.startswith("ppo ") and "seed 1" in x
    ]
    assert "trained" not in line and "640 episodes" in line
    rnd = [x for x in plan(runs, results).splitlines() if x.startswith("random ")]
    assert ["running" in x for x in rnd] == [False, True, False]  # held by a live process: 1


def test_next_leaves_the_seeds_of_a_superseded_candidate_and_plan_says_so(tmp_path) -> None:
    from benchmarks.table3 import ROWS, lanes

    old = [row for row, r in ROWS.items() if r.superseded_by]
    assert old, "no superseded candidate to check"
    for row in old:
        assert ROWS[row].superseded_by in ROWS  # it names a row that exists
        assert all(r != row for r, _ in lanes())
    assert [s for r, s in lanes() if r == "ppo"] == [0, 1, 2]  # the paper's rows stay
    lines = plan(tmp_path / "runs", tmp_path / "results").splitlines()
    marked = [line for line in lines if "not in --next" in line]
    assert marked and all(line.split()[0] in old for line in marked)
    assert len(marked) == 3 * len(old)  # nothing filed here: every seed of them is left


def test_a_filed_lane_is_done_on_a_fresh_clone_without_its_run_folder(tmp_path) -> None:
    from benchmarks.table3 import EVALS, RUN_FILES, next_lanes, stages

    runs, results = tmp_path / "runs", tmp_path / "results"  # runs/: not there at all
    filed = results / "runs/table3/ppo-s0"
    filed.mkdir(parents=True)
    for name in (*RUN_FILES, *EVALS):
        (filed / name).write_text("{}")
    assert [m for _, m in stages("ppo", 0, runs, results)] == ["+"] * 4
    assert re.search(r"ppo +seed 0: \+train \+evaluate eval_test.json \+evaluate "
                     r"eval_test_sampled.json \+file", plan(runs, results))  # fmt: skip
    (filed / "eval_test_sampled.json").unlink()  # filed in part: the lane is still to do
    assert [m for _, m in stages("ppo", 0, runs, results)] == ["-"] * 4
    ran = []
    next_lanes(runs, results, lambda row, seed: ran.append((row, seed)) or 0, limit=1)
    assert ran == [("random", 0)]
    for seed in (0, 1, 2):
        (results / f"baselines/random_test_s{seed}.json").parent.mkdir(exist_ok=True)
        (results / f"baselines/random_test_s{seed}.json").write_text("{}")
    (filed / "eval_test_sampled.json").write_text("{}")
    next_lanes(runs, results, lambda row, seed: ran.append((row, seed)) or 0, limit=1)
    assert ran[-1] == ("ppo", 1)  # the filed seed 0 is not trained again


def test_lanes_take_turns_to_evaluate_and_lanes_must_be_positive(tmp_path) -> None:
    import subprocess
    import sys
    import time

    import pytest

    from benchmarks.table3 import ROOT, evaluation_turn

    runs = tmp_path / "runs"
    other = (
        "from pathlib import Path; from benchmarks.table3 import evaluation_turn\n"
        f"with evaluation_turn(Path({str(runs)!r})): print('evaluating', flush=True)"
    )
    with evaluation_turn(runs):
        beside = subprocess.Popen([sys.executable, "-c", other], cwd=ROOT, text=True,
                                  stdout=subprocess.PIPE)  # fmt: skip
        assert beside.stdout.readline().strip() == "waiting for the other lane's evaluation"
        time.sleep(0.5)
        assert beside.poll() is None  # still waiting while this turn is held
    out, _ = beside.communicate(timeout=30)
    assert out.strip() == "evaluating" and beside.returncode == 0
    with evaluation_turn(runs):  # free again once both are done
        pass
    with pytest.raises(SystemExit) as bad:
        main(["--next", "--lanes", "0", "--runs", str(runs)])
    assert bad.value.code == 2


def test_a_lane_builds_a_missing_split_from_its_spec_and_only_then(tmp_path, monkeypatch):
    import cli
    from assetgen.dataset import spec as specs

    specs_dir = tmp_path / "datasets"
    specs_dir.mkdir()
    (specs_dir / "tiny.json").write_text(json.dumps({"name": "tiny", "seed_start": 0, "count": 2}))
    monkeypatch.setattr(specs, "SPECS_DIR", specs_dir)
    calls = []

    def fake_assetgen(argv: list[str]) -> int:  # the stages' files, none of their work
        calls.append(argv)
        out = Path(argv[argv.index("--out") + 1]) if "--out" in argv else None
        if argv[0] == "sample":
            (specs_dir / "tiny").mkdir()
            (specs_dir / "tiny" / "dataset.json").write_text("{}")
        elif argv[0] == "train":
            out.mkdir(parents=True, exist_ok=True)
            for name in ("config.json", "metrics.csv", "checkpoint.safetensors"):
                (out / name).write_text("{}")
        else:
            out.write_text("{}")
        return 0

    monkeypatch.setattr(cli, "main", fake_assetgen)
    kw = dict(minutes=1, threads=1, runs=tmp_path / "runs", dataset="tiny", test="tiny",
              results=tmp_path / "results")  # fmt: skip
    assert lane("ppo", 0, **kw) == 0
    assert [c[0] for c in calls] == ["sample", "train", "eval", "eval"]
    assert calls[0] == ["sample", "--dataset", "tiny", "--quiet"]  # once for both splits
    calls.clear()
    assert lane("ppo", 1, **kw) == 0
    assert [c[0] for c in calls] == ["train", "eval", "eval"]  # built: not again
