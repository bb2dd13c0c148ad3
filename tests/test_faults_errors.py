"""Faults a user causes, command by command: each ends in ONE line `error: ...` on stderr that
names the value and what to do (exit code 2; 130 for Ctrl-C), never a traceback, and nothing
finished is lost. Run in-process through cli.main (Ctrl-C and permission errors simulated
with monkeypatch, so the tests also run as root), one real Ctrl-C in a subprocess."""

from __future__ import annotations

import ast
import errno
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import cli

ROOT = Path(__file__).resolve().parent.parent


def run(capsys, *argv: str) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of `assetgen ARGV`, in this process."""
    capsys.readouterr()
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(err: str) -> str:
    """The single `error:` line that is all of stderr."""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("error: "), err
    assert "Traceback" not in err
    return lines[0]


def manifest_ids(root: Path) -> list[str]:
    return sorted(json.loads(line)["id"] for line in (root / "manifest.jsonl").open())


@pytest.fixture(scope="module")
def trained_run(tiny_dataset, tmp_path_factory) -> Path:
    """A tiny PPO run on the tiny dataset (two iterations' worth of steps)."""
    run_dir = tmp_path_factory.mktemp("faults") / "run"
    code = cli.main(["train", "--algo", "ppo", "--preset", "debug", "--dataset",
                     str(tiny_dataset), "--envs", "2", "--steps", "200", "--out", str(run_dir),
                     "--no-progress"])  # fmt: skip
    assert code == 0
    return run_dir


# ------------------------------------------------------------------------------ sample


def test_sample_ctrl_c_keeps_the_finished_modules_and_the_same_command_resumes(
    tmp_path, monkeypatch, capsys
):
    from assetgen.dataset import generate

    worker, calls = generate._worker, []

    def cut(job):
        calls.append(job)
        if len(calls) == 3:
            raise KeyboardInterrupt  # Ctrl-C while the third module is made
        return worker(job)

    monkeypatch.setattr(generate, "_worker", cut)
    out = tmp_path / "ds"
    argv = ("sample", "--n", "3", "--out", str(out), "--workers", "1", "--quiet")
    code, _, err = run(capsys, *argv)
    line = one_error_line(err)
    assert code == 130
    assert "interrupted" in line and str(out) in line and "run the same command again" in line
    assert manifest_ids(out) == ["000000", "000001"]  # the finished modules are kept
    monkeypatch.setattr(generate, "_worker", worker)
    code, table, err = run(capsys, *argv)
    assert code == 0, err
    assert "cached" in table and manifest_ids(out) == ["000000", "000001", "000002"]


def test_sample_real_ctrl_c_of_a_worker_pool_is_one_line(tmp_path):
    """SIGINT to the whole process group, as a terminal's Ctrl-C sends it: the pool's workers
    print nothing, the command one line, and the modules written so far stay listed."""
    out = tmp_path / "ds"
    p = subprocess.Popen(
        [sys.executable, "-m", "cli", "sample", "--n", "200", "--out", str(out),
         "--workers", "2", "--quiet"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    manifest = out / "manifest.jsonl"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and p.poll() is None:
        if manifest.exists() and len(manifest.read_text().splitlines()) >= 2:
            break
        time.sleep(0.05)
    assert p.poll() is None, p.communicate()
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    assert "modules finished in" in one_error_line(err)
    assert len(manifest_ids(out)) >= 2


# ------------------------------------------------------------------------------- check


@pytest.mark.parametrize(
    ("code", "says"),
    [(errno.EACCES, "permission denied"), (errno.EROFS, "read-only")],
)
def test_check_repair_on_a_dataset_it_cannot_write(
    tiny_dataset, tmp_path, monkeypatch, capsys, code, says
):
    """`chmod -R a-w` or a read-only mount (root ignores the first: simulated)."""
    ds = tmp_path / "ds"
    shutil.copytree(tiny_dataset, ds)
    (ds / "modules" / "000001" / "module.json").unlink()
    before = (ds / "manifest.jsonl").read_text()
    write_text = Path.write_text

    def refuse(self, *a, **kw):
        if ds in self.parents:
            raise OSError(code, os.strerror(code), str(self))
        return write_text(self, *a, **kw)

    monkeypatch.setattr(Path, "write_text", refuse)
    rc, _, err = run(capsys, "check", str(ds), "--repair", "--hashes-only", "--quiet")
    line = one_error_line(err)
    assert rc == 2 and says in line and str(ds) in line
    assert "folder" in line or "remount" in line  # what to do
    assert (ds / "manifest.jsonl").read_text() == before  # nothing lost
    kept = sorted(d.name for d in (ds / "modules").iterdir())
    assert {"000000", "000002", "000003", "000004", "000005"} <= set(kept)  # the sound ones


# ------------------------------------------------------------------------------- train


def test_train_out_naming_an_existing_file(tiny_dataset, tmp_path, capsys):
    file = tmp_path / "notes.txt"
    file.write_text("mine")
    code, _, err = run(capsys, "train", "--algo", "ppo", "--preset", "debug", "--dataset",
                       str(tiny_dataset), "--steps", "64", "--out", str(file),
                       "--no-progress")  # fmt: skip
    line = one_error_line(err)
    assert code == 2 and "--out" in line and str(file) in line and "folder" in line
    assert file.read_text() == "mine"


class CutAt:
    """An env that raises KeyboardInterrupt (Ctrl-C) at its `at`-th step."""

    def __init__(self, env, at: int) -> None:
        self.env, self.at, self.n = env, at, 0

    def __getattr__(self, name):
        return getattr(self.env, name)

    def step(self, actions):
        self.n += 1
        if self.n == self.at:
            raise KeyboardInterrupt
        return self.env.step(actions)


@pytest.mark.parametrize("at", [1, 40])
def test_train_ctrl_c_keeps_the_last_checkpoint_and_says_resume(
    tiny_dataset, tmp_path, monkeypatch, capsys, at
):
    make = cli._train_env
    monkeypatch.setattr(cli, "_train_env", lambda *a, **kw: CutAt(make(*a, **kw), at))
    out = tmp_path / "run"
    argv = ["train", "--algo", "ppo", "--preset", "debug", "--dataset", str(tiny_dataset),
            "--envs", "2", "--steps", "192", "--out", str(out), "--no-progress",
            "--checkpoint-minutes", "0.0001"]  # fmt: skip
    code, _, err = run(capsys, *argv)
    line = one_error_line(err)
    assert code == 130 and "interrupted" in line, line
    if at == 1:  # before the first checkpoint
        assert "no checkpoint had been written yet" in line
        return
    assert str(out) in line and "--resume" in line
    assert (out / "checkpoint.safetensors").is_file()
    monkeypatch.setattr(cli, "_train_env", make)
    code, _, err = run(capsys, *argv, "--resume")
    assert code == 0, err


def test_train_ctrl_c_while_the_env_is_built(
    trained_run, tiny_dataset, tmp_path, monkeypatch, capsys
):
    """Before the training loop (the runner's own line): the handler looks for the run's
    checkpoint."""

    def cut(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_train_env", cut)
    run_dir = tmp_path / "run"
    shutil.copytree(trained_run, run_dir)
    argv = ["train", "--algo", "ppo", "--preset", "debug", "--dataset", str(tiny_dataset),
            "--envs", "2", "--no-progress"]  # fmt: skip
    code, _, err = run(capsys, *argv, "--out", str(run_dir), "--resume")
    line = one_error_line(err)
    assert code == 130 and f"the last checkpoint in {run_dir} is kept" in line
    assert "--resume" in line and (run_dir / "checkpoint.safetensors").is_file()
    code, _, err = run(capsys, *argv, "--out", str(tmp_path / "new"))
    assert code == 130 and "no checkpoint had been written yet" in one_error_line(err)


# -------------------------------------------------------------------------------- eval


def test_eval_ctrl_c_without_out_says_nothing_was_written(
    tiny_dataset, tmp_path, monkeypatch, capsys
):
    from evaluation import protocol

    def cut(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(protocol, "evaluate", cut)
    code, _, err = run(capsys, "eval", "--agent", "scripted", "--dataset", str(tiny_dataset))
    assert code == 130 and "nothing was written" in one_error_line(err)


def test_eval_ctrl_c_keeps_the_checkpoints_snapshot_and_the_same_command_resumes(
    trained_run, tiny_dataset, tmp_path, monkeypatch, capsys
):
    from evaluation import command, protocol
    from evaluation.snapshots import snapshot_path

    evaluate = protocol.evaluate

    def cut(policy, *a, **kw):
        calls = []

        def policy_then_ctrl_c(obs):
            calls.append(1)
            if len(calls) == 30:
                raise KeyboardInterrupt
            return policy(obs)

        return evaluate(policy_then_ctrl_c, *a, **kw)

    monkeypatch.setattr(command, "SNAPSHOT_EVERY_S", 0.0)  # a snapshot every step
    monkeypatch.setattr(protocol, "evaluate", cut)
    out = tmp_path / "eval.json"
    argv = ("eval", "--checkpoint", str(trained_run), "--dataset", str(tiny_dataset),
            "--attempts", "1", "--out", str(out), "--json")  # fmt: skip
    code, _, err = run(capsys, *argv)
    line = one_error_line(err)
    snapshot = snapshot_path(out)
    assert code == 130 and str(snapshot) in line and "run the same command again" in line
    assert snapshot.is_file() and not out.exists()
    monkeypatch.setattr(protocol, "evaluate", evaluate)
    code, _, err = run(capsys, *argv)
    assert code == 0, err
    assert json.loads(out.read_text())["episodes"] == 6 and not snapshot.exists()


def _rewrite_checkpoint(run_dir: Path, **run) -> None:
    from rl import checkpoint as ckpt

    path = run_dir / ckpt.FILE_NAME
    tensors, doc = ckpt.load(path)
    doc["run"] |= run
    ckpt.save(path, tensors, doc)


def test_eval_checkpoint_whose_algorithm_does_not_match_its_config(
    trained_run, tiny_dataset, tmp_path, capsys
):
    bad = tmp_path / "run"
    shutil.copytree(trained_run, bad)
    _rewrite_checkpoint(bad, algo="sac")  # PPO's config and weights
    code, _, err = run(capsys, "eval", "--checkpoint", str(bad), "--dataset", str(tiny_dataset))
    line = one_error_line(err)
    assert code == 2 and str(bad) in line and "'sac'" in line and "does not match" in line
    assert "train again" in line


def test_eval_checkpoint_whose_weights_do_not_fit_its_algorithm(
    trained_run, tiny_dataset, tmp_path, capsys
):
    from dataclasses import asdict

    from rl.configs import SACConfig

    bad = tmp_path / "run"
    shutil.copytree(trained_run, bad)
    _rewrite_checkpoint(bad, algo="sac", config=asdict(SACConfig()))  # PPO's weights
    code, _, err = run(capsys, "eval", "--checkpoint", str(bad), "--dataset", str(tiny_dataset))
    line = one_error_line(err)
    assert code == 2 and str(bad) in line and "do not fit a 'sac' agent" in line


# ------------------------------------------------------------------------------- bench


def test_bench_assets_n_0(tmp_path, capsys):
    code, _, err = run(capsys, "bench", "assets", "--n", "0", "--dir", str(tmp_path))
    line = one_error_line(err)
    assert code == 2 and "--n 0" in line and "at least 1" in line
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------- the handler, for every command


@pytest.fixture
def raising(monkeypatch):
    """Make `assetgen info X` raise the exception given to the returned function."""
    from assetgen.dataset import info_command

    def set_to(e: BaseException) -> None:
        def main(args):
            raise e

        monkeypatch.setattr(info_command, "main", main)

    return set_to


def test_project_errors_print_their_message(raising, capsys):
    from assetgen.dataset.spec import DatasetError
    from assetgen.geometry.solids import FootprintError
    from rl.checkpoint import CheckpointError
    from rl.report_load import NotAnEvalFileError

    for e in (DatasetError("d: do this"), FootprintError("f: do that"),
              CheckpointError("c: retrain"), NotAnEvalFileError("r: skip it")):  # fmt: skip
        raising(e)
        code, _, err = run(capsys, "info", "x")
        assert code == 2 and one_error_line(err) == f"error: {e}"


@pytest.mark.parametrize(
    ("e", "says"),
    [
        (
            PermissionError(errno.EACCES, "Permission denied", "{d}/new"),
            "cannot create {d}/new: permission denied",
        ),
        (
            OSError(errno.ENOSPC, "No space left on device", "{d}/f"),
            "no space left on the device to write {d}/f",
        ),
        (
            OSError(errno.ENOSPC, "No space left on device"),
            "no space left on the device: free some space",
        ),
        (
            IsADirectoryError(errno.EISDIR, "Is a directory", "{d}"),
            "{d} is a folder where a file is needed",
        ),
        (NotADirectoryError(errno.ENOTDIR, "Not a directory", "{d}/file/x"), "{d}/file is a file"),
        (FileNotFoundError(errno.ENOENT, "No such file", "{d}/gone"), "{d}/gone does not exist"),
        (FileExistsError(errno.EEXIST, "File exists", "{d}/file"), "is a file where a folder"),
    ],
)
def test_os_errors_name_the_path_and_what_to_do(raising, capsys, tmp_path, e, says):
    (tmp_path / "file").write_text("")
    d = str(tmp_path)
    e.filename = None if e.filename is None else e.filename.format(d=d)
    raising(e)
    code, _, err = run(capsys, "info", d)
    assert code == 2 and says.format(d=d) in one_error_line(err)


def test_keyboard_interrupt_elsewhere_is_one_line_and_130(raising, capsys):
    raising(KeyboardInterrupt())
    code, _, err = run(capsys, "info", "x")
    assert code == 130 and one_error_line(err) == "error: interrupted (Ctrl-C): nothing to resume"


def test_a_bug_says_so_in_one_line_then_shows_its_traceback(raising, capsys):
    raising(TypeError("oops"))
    with pytest.raises(TypeError, match="oops"):
        cli.main(["info", "x"])
    line = one_error_line(capsys.readouterr().err)
    assert "unexpected TypeError" in line and "bug" in line and "report" in line


def test_debug_reraises_what_would_be_one_line(raising, capsys):
    raising(PermissionError(errno.EACCES, "Permission denied", "/x"))
    with pytest.raises(PermissionError):
        cli.main(["--debug", "info", "x"])
    assert capsys.readouterr().err == ""


def test_a_missing_optional_library_still_names_its_extra(raising, capsys):
    raising(ModuleNotFoundError("No module named 'viser'", name="viser"))
    code, _, err = run(capsys, "info", "x")
    assert code == 2 and "[view] extra" in one_error_line(err)


def _error_classes() -> set[str]:
    """Every exception class the project's packages define, by class path."""
    found = set()
    for pkg in ("assetgen", "sim", "rl", "evaluation", "preview"):
        for path in (ROOT / pkg).rglob("*.py"):
            module = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.ClassDef) and node.name.endswith(("Error", "Failure")):
                    found.add(f"{module}.{node.name}")
    return found


INTERNAL_ERRORS = {
    "assetgen.checks.module_checks.CheckError",  # becomes a ModuleFailure of its seed
    "rl.nets.NonFiniteLossError",  # the runner stops on it and keeps the last checkpoint
}
"""Project exceptions that do not reach the command line as they are."""


def test_every_project_error_is_handled_or_known_internal():
    """A new exception class is either one line for the user (cli.PROJECT_ERRORS, or a
    subclass of one) or named here as internal."""
    import importlib

    unclassified = []
    for name in sorted(_error_classes()):
        module, _, cls_name = name.rpartition(".")
        cls = getattr(importlib.import_module(module), cls_name)
        assert issubclass(cls, Exception), name
        handled = cli.project_error(cls.__new__(cls))
        if not handled and name not in INTERNAL_ERRORS:
            unclassified.append(name)
    assert unclassified == []
    assert cli.PROJECT_ERRORS <= _error_classes()
