"""`python -m benchmarks.screening`: a candidate's train-split screening, filed as a page row."""

from __future__ import annotations

import json

import pytest

from benchmarks.screening import main, screen
from cli import main as assetgen
from rl.checkpoint import read_counters
from rl.report_load import load_run
from rl.report_summary import summarise
from rl.report_tables import markdown_table


def test_a_candidate_is_screened_once_and_filed_under_its_name(
    tiny_dataset, tmp_path, capsys
) -> None:
    run, results = tmp_path / "run", tmp_path / "results"
    assert assetgen(["train", "--algo", "ppo", "--preset", "debug", "--dataset",
                     str(tiny_dataset), "--envs", "2", "--steps", "256", "--no-progress",
                     "--threads", "1", "--out", str(run)]) == 0  # fmt: skip
    filed = screen(run, "ppo-debug", results=results, dataset=str(tiny_dataset))
    assert filed == results / "runs/screening/ppo-debug"
    assert sorted(p.name for p in filed.iterdir()) == [
        "config.json", "eval_train.json", "eval_train_sampled.json", "jams_train.json",
        "metrics.csv"]  # fmt: skip
    det = json.loads((filed / "eval_train.json").read_text())
    assert det["attempts"] == 2 and det["episodes"] == 12 and det["policy"] == "deterministic"
    assert json.loads((filed / "eval_train_sampled.json").read_text())["policy"] == "stochastic"
    assert json.loads((filed / "jams_train.json").read_text())["modules"] == 6
    first = read_counters(run)["env_steps"]
    assert first >= 256 and det["trained_env_steps"] == first  # which weights were screened
    # screened again: nothing is evaluated twice
    before = (run / "screen_train_det.json").read_bytes()
    stamp = (run / "jams_train.json").stat().st_mtime_ns
    screen(run, "ppo-debug", results=results, dataset=str(tiny_dataset))
    assert (run / "screen_train_det.json").read_bytes() == before
    assert (run / "jams_train.json").stat().st_mtime_ns == stamp
    # resumed for more steps: the earlier screening is stale, so all of it is redone
    assert assetgen(["train", "--algo", "ppo", "--preset", "debug", "--dataset",
                     str(tiny_dataset), "--envs", "2", "--steps", "512", "--no-progress",
                     "--threads", "1", "--out", str(run), "--resume"]) == 0  # fmt: skip
    screen(run, "ppo-debug", results=results, dataset=str(tiny_dataset))
    later = read_counters(run)["env_steps"]
    assert later > first
    # resumed once more with its budget spent: it says so, rather than "success nan%"
    capsys.readouterr()
    assert assetgen(["train", "--algo", "ppo", "--preset", "debug", "--dataset",
                     str(tiny_dataset), "--envs", "2", "--steps", "512", "--no-progress",
                     "--threads", "1", "--out", str(run), "--resume"]) == 0  # fmt: skip
    said = capsys.readouterr().err  # the run's log goes to stderr
    assert "no iteration left in its budget" in said and "nan" not in said
    assert read_counters(run)["env_steps"] == later
    for name in ("eval_train.json", "eval_train_sampled.json", "jams_train.json"):
        assert json.loads((filed / name).read_text())["trained_env_steps"] == later, name
    # on the page the candidate is its own row, named by its folder
    table = markdown_table(summarise([load_run(filed, filed.name)], []), paper=False)
    assert f"| ppo-debug | 1 | {later} |" in table and "| ppo-debug (sampled) | 1 |" in table
    assert "test set" not in table  # only the split it was screened on
    assert "paper train set" not in table and "Orsula" not in table


def test_bad_input_is_named(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit, match=r"no checkpoint\.safetensors"):
        screen(tmp_path, "x", results=tmp_path / "results")
    with pytest.raises(SystemExit):
        main([str(tmp_path), "--as", "a/b"])
    assert "--as 'a/b': give a plain folder name" in capsys.readouterr().err
