"""CLI smoke runs on tiny datasets, and the errors users see for bad input."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def run(*args: str, check: bool = False) -> subprocess.CompletedProcess:
    p = subprocess.run(
        [sys.executable, "-m", "cli", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "COLUMNS": "120"},
    )
    if check:
        assert p.returncode == 0, p.stdout + p.stderr
    return p


def test_sample_prints_summary(tmp_path):
    p = run(
        "sample", "--n", "3", "--seed", "5", "--out", str(tmp_path / "d"), "--quiet", check=True
    )
    assert "generated" in p.stdout and "clearance min" in p.stdout and "failed" in p.stdout
    assert sorted(d.name for d in (tmp_path / "d" / "modules").iterdir()) == [
        "000005",
        "000006",
        "000007",
    ]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--n", "0"], "ask for at least 1 module"),
        (["--n", "2", "--clearance-mm", "0"], "clearance = 0 m must be positive"),
        (["--n", "2", "--clearance-mm", "nan"], "clearance = nan is not a finite number"),
        (["--n", "2", "--formats", "obj"], "unknown export format"),
    ],
)
def test_sample_bad_input(tmp_path, args, message):
    out = tmp_path / "d"
    p = run("sample", "--out", str(out), "--quiet", *args)
    assert p.returncode != 0
    assert message in (p.stdout + p.stderr).replace("\n", " ")
    assert not (out / "modules").exists() or not any((out / "modules").iterdir())


def test_unwritable_output_folder(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        if os.access(locked, os.W_OK):  # root ignores permissions: nothing to test
            pytest.skip("running as a user that can write anywhere")
        p = run("sample", "--n", "1", "--out", str(locked / "d"), "--quiet")
        assert p.returncode != 0 and "cannot write" in p.stderr
    finally:
        locked.chmod(0o700)


def test_output_path_is_a_file(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    p = run("sample", "--n", "1", "--out", str(f / "d"), "--quiet")
    assert p.returncode != 0 and "cannot write the dataset" in p.stderr
    assert f.read_text() == "x"


def test_check_info_bench(tiny_dataset):
    p = run("check", str(tiny_dataset), check=True)
    assert "missing" in p.stdout
    p = run("info", str(tiny_dataset), check=True)
    assert "circumradius" in p.stdout and "measured clearance" in p.stdout
    p = run("bench", "assets", "--n", "4", "--workers", "1", "--json", check=True)
    figures = json.loads(p.stdout.strip().splitlines()[-1])
    assert figures["modules"] == 4 and figures["failed"] == 0 and figures["modules_per_s"] > 0
    steps = figures["step_ms"]  # per-module time of each export step
    for name in ("build", "stl+checks", "3mf", "collision: re-check", "mjcf", "usd"):
        assert steps[name] > 0, name
    assert "collision: re-check" in p.stdout  # the step table is printed too


def test_unknown_dataset_name():
    p = run("info", "no_such_dataset")
    assert p.returncode != 0 and "no dataset spec named" in p.stderr


def test_eval_and_bench_sim(tiny_dataset, tmp_path):
    out = tmp_path / "eval.json"
    p = run(
        "eval",
        "--agent",
        "scripted",
        "--dataset",
        str(tiny_dataset),
        "--attempts",
        "1",
        "--out",
        str(out),
        check=True,
    )
    assert "success rate" in p.stdout
    saved = json.loads(out.read_text())
    assert saved["agent"] == "scripted" and saved["episodes"] == 6
    assert 0.0 <= saved["success_rate"] <= 1.0
    p = run(
        "eval",
        "--agent",
        "random",
        "--dataset",
        str(tiny_dataset),
        "--attempts",
        "1",
        "--json",
        check=True,
    )
    assert json.loads(p.stdout.strip().splitlines()[-1])["episodes"] == 6
    p = run(
        "bench",
        "sim",
        "--envs",
        "12",
        "--steps",
        "10",
        "--dataset",
        str(tiny_dataset),
        "--json",
        check=True,
    )
    figures = json.loads(p.stdout.strip().splitlines()[-1])
    assert figures["env_steps_per_s"] > 0 and figures["rollout_steps_per_s"] > 0


def test_train_then_evaluate_the_checkpoint_on_every_module(tiny_dataset, tmp_path):
    run_dir = tmp_path / "run"
    run("train", "--algo", "sac", "--preset", "debug", "--dataset", str(tiny_dataset),
        "--envs", "2", "--steps", "400", "--out", str(run_dir), "--no-progress",
        check=True)  # fmt: skip
    args = ("eval", "--checkpoint", str(run_dir), "--dataset", str(tiny_dataset))
    p = run(*args, "--attempts", "2", "--json", check=True)
    res = json.loads(p.stdout.strip().splitlines()[-1])
    # one env per module: 6 modules x 2 attempts, whatever the training batch (2 envs)
    assert res["episodes"] == 12 and len(res["per_env_success_rate"]) == 6
    p = run(*args, "--envs", "3")
    assert p.returncode != 0 and "less than the dataset's 6 modules" in p.stdout + p.stderr


def test_eval_missing_dataset(tmp_path):
    p = run("eval", "--agent", "scripted", "--dataset", str(tmp_path / "nope"))
    assert p.returncode != 0 and "is not a dataset" in p.stderr


def test_commands_start_without_importing_torch():
    """Building the parsers (every command does) must not import torch (~1.4 s): `train`
    takes its choices from rl.names, which must stay in step with what they name."""
    pytest.importorskip("torch")
    code = (
        "import sys, cli; p = cli.build_parser(); "
        "assert 'torch' not in sys.modules, 'torch imported'; "
        "p.parse_args(['train', '--algo', 'sac', '--dataset', 'x', '--out', 'y'])"
    )
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    from rl.names import ALGO_NAMES, PRESET_NAMES
    from rl.presets import PRESETS
    from rl.runner import ALGOS

    assert sorted(ALGO_NAMES) == sorted(ALGOS)
    assert sorted(PRESET_NAMES) == sorted(PRESETS)
