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


def row(table: str, label: str) -> str:
    """The value cell of the row labelled `label` in a two-column table printed by rich."""
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip().strip("│┃|").split("│")]
        if len(cells) >= 2 and cells[0] == label:
            return cells[-1]
    raise AssertionError(f"no row {label!r} in:\n{table}")


def test_sample_prints_summary(tmp_path):
    p = run(
        "sample", "--n", "3", "--seed", "5", "--out", str(tmp_path / "d"), "--quiet", check=True
    )
    assert (row(p.stdout, "generated"), row(p.stdout, "failed")) == ("3", "0")
    low, high = (float(row(p.stdout, f"clearance {m}").split()[0]) for m in ("min", "max"))
    assert 0.999 <= low <= high <= 1.001  # mm: the exact 1 mm clearance, as measured
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


def test_check_info_bench(tiny_dataset, tmp_path):
    p = run("check", str(tiny_dataset), check=True)
    for label in ("missing", "corrupt", "stale"):
        assert row(p.stdout, label) == "0", label
    assert row(p.stdout, "manifest") == "ok"
    p = run("info", str(tiny_dataset), check=True)
    assert "circumradius" in p.stdout and "measured clearance" in p.stdout
    scratch = tmp_path / "made" / "here"  # --dir is made if missing
    p = run("bench", "assets", "--n", "4", "--workers", "1", "--json", "--dir", str(scratch),
            check=True)  # fmt: skip
    assert scratch.is_dir() and not list(scratch.iterdir())  # and left empty
    (tmp_path / "file").write_text("x")
    bad = run("bench", "assets", "--n", "1", "--dir", str(tmp_path / "file" / "sub"))
    assert bad.returncode == 2 and "cannot make the folder" in bad.stderr
    assert "Traceback" not in bad.stderr
    figures = json.loads(p.stdout.strip().splitlines()[-1])
    assert figures["modules"] == 4 and figures["failed"] == 0 and figures["modules_per_s"] > 0
    steps = figures["step_ms"]  # per-module time of each export step
    for name in ("build", "stl+checks", "3mf", "collision: re-check", "mjcf", "usd"):
        assert steps[name] > 0, name
    assert "collision: re-check" in p.stdout  # the step table is printed too


def test_unknown_dataset_name():
    p = run("info", "no_such_dataset")
    assert p.returncode != 0 and "no dataset spec named" in p.stderr


def test_missing_dataset_is_one_line_error_for_every_command(tmp_path):
    """info, train, eval and view refuse a folder that does not exist in the same words, on
    one line, exit code 2, before any work (no traceback, no run folder, no server)."""
    missing = str(tmp_path / "nonexistent")
    info = run("info", missing)
    assert info.returncode == 2 and "is not a dataset (no dataset.json)" in info.stderr
    train = run("train", "--algo", "ppo", "--preset", "debug", "--dataset", missing,
                "--out", str(tmp_path / "run"), "--no-progress")  # fmt: skip
    ev = run("eval", "--agent", "scripted", "--dataset", missing)
    for p in (train, ev):
        assert p.returncode == 2, p.stdout + p.stderr
        assert p.stderr == info.stderr, (p.stderr, info.stderr)
        assert len(p.stderr.strip().splitlines()) == 1 and "Traceback" not in p.stderr
    assert not (tmp_path / "run").exists()
    view = subprocess.run(
        [sys.executable, "-m", "cli", "view", missing, "--port", "0"],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert view.returncode == 2 and "does not exist" in view.stderr
    assert "http" not in view.stdout + view.stderr  # no server was started


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
    assert saved["success_rate"] == 1.0  # the expert inserts every peg (10240 of 10240 on test)
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
    random = json.loads(p.stdout.strip().splitlines()[-1])
    assert random["episodes"] == 6 and random["success_rate"] == 0.0
    assert "modules" not in random  # the protocol plays every module
    p = run("eval", "--agent", "random", "--dataset", str(tiny_dataset), "--attempts", "2",
            "--modules", "2", "--json", check=True)  # fmt: skip
    subset = json.loads(p.stdout.strip().splitlines()[-1])
    assert subset["modules"] == 2 and subset["episodes"] == 4
    assert sorted(subset["per_module"]) == sorted(random["per_module"])[:2]
    bad = run("eval", "--agent", "random", "--dataset", str(tiny_dataset), "--modules", "0")
    assert bad.returncode == 2 and "--modules 0" in bad.stderr
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
    out = p.stdout + p.stderr  # the library's num_envs, in the command line's words
    assert p.returncode != 0 and "--envs 3 is less than the dataset's 6 modules" in out


def test_eval_missing_dataset(tmp_path):
    p = run("eval", "--agent", "scripted", "--dataset", str(tmp_path / "nope"))
    assert p.returncode != 0 and "is not a dataset" in p.stderr


def test_commands_start_without_importing_torch():
    """Building the parsers (every command does) must import neither torch (~1.4 s) nor the
    simulator (MuJoCo and its GL bindings, ~0.3 s; `assetgen sample` is timed whole): only
    the engine registry, the scripted experts (numpy only) and the parsers' own modules,
    which import no engine; `train` takes its choices from the algorithm registry and the
    presets, which import no torch."""
    pytest.importorskip("torch")
    code = (
        "import sys, cli; p = cli.build_parser(); "
        "light = ('sim', 'sim.engines', 'sim.engines.registry', 'sim.bench', "
        "'sim.bench.command', 'sim.task', 'sim.task.expert', 'sim.robots', 'sim.robots.registry', "
        "'sim.robots.scene_command'); "
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('torch', 'sim', 'mujoco', "
        "'numba') and m not in light); "
        "assert not bad, f'imported {bad}'; "
        "p.parse_args(['train', '--algo', 'sac', '--dataset', 'x', '--out', 'y'])"
    )
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


def test_bench_load(tiny_dataset):
    p = run("bench", "load", "--dataset", str(tiny_dataset), "--n", "2", "--json", check=True)
    figures = json.loads(p.stdout.strip().splitlines()[-1])
    assert figures["modules"] == 2
    assert figures["mjcf_ms"] > 0 and figures["packed_ms"] > 0 and figures["mjspec_ms"] > 0
    assert not list(Path(tiny_dataset).glob(".bench-load-*"))  # its scratch files are gone
    # the engine's construction, a module at a time (--sim mujoco by default)
    assert figures["mujoco_modules"] == 2 and figures["mujoco_build_ms_per_module"] > 0
    assert figures["mujoco_build_min_for_100k_modules"] == pytest.approx(
        figures["mujoco_build_ms_per_module"] * 1e5 / 6e4
    )
