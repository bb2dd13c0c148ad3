"""Check before the long work: every command refuses an input it would fail on later (a
number that is not finite or out of bounds, an output path of the wrong kind or in a place
that cannot be written, an unknown format) before it starts, in one line `error: ...` naming
the flag, its value and what to give, exit code 2, and having written nothing.

Organised by command; the commands run in-process (cli.main) on paths that do not exist, so
a test that got past the checks would fail on the dataset instead."""

from __future__ import annotations

import json
import os
import shutil
import time
import tracemalloc
from pathlib import Path

import pytest

import cli
from assetgen.core.preflight import MAX_COUNT, Bound


def refused(capsys, argv: list[str], *words: str) -> str:
    """Run `assetgen ARGV`: exit code 2, one line `error: ...` on stderr holding `words`."""
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def nothing_in(folder: Path) -> None:
    assert not folder.exists() or not any(folder.rglob("*")), sorted(folder.rglob("*"))


# ------------------------------------------------------------------ every numeric flag


def _commands() -> dict[str, tuple[list[str], dict[str, Bound], set[str]]]:
    """Subcommand path -> (the parser's words, its bounds, numeric flags left to others)."""
    from assetgen import bench as assets_bench
    from assetgen.dataset import check_command, sample_command
    from assetgen.physics import arguments as physics
    from assetgen.printing import command as gauge_command
    from evaluation import command as eval_command
    from preview import command as view_command
    from rl import commands as rl_commands
    from sim.bench import command as sim_bench

    return {
        "sample": (["sample"], sample_command.NUMBERS, {"clearance_mm", "print_offset"}),
        "gauge": (["gauge"], gauge_command.NUMBERS, set()),
        "check": (["check"], check_command.NUMBERS, set()),
        "physics": (["physics"], physics.NUMBERS, set()),
        "eval": (["eval"], eval_command.NUMBERS, set()),
        "view": (["view"], view_command.NUMBERS, set()),
        "train": (["train"], rl_commands.TRAIN_NUMBERS, set()),
        "bench assets": (["bench", "assets"], assets_bench.NUMBERS, set()),
        "bench sim": (["bench", "sim"], sim_bench.SIM_NUMBERS, set()),
        "bench load": (["bench", "load"], sim_bench.LOAD_NUMBERS, set()),
        "bench contacts": (["bench", "contacts"], sim_bench.CONTACTS_NUMBERS, set()),
    }


def _subparsers(parser) -> dict[str, object]:
    """Every leaf subcommand of `parser`, by its words joined ("bench sim")."""
    import argparse

    out = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                inner = _subparsers(sub)
                out.update({f"{name} {k}": v for k, v in inner.items()} if inner else {name: sub})
    return out


def test_every_numeric_flag_of_every_command_has_bounds() -> None:
    """A numeric flag added to a command without bounds fails here (clearance_mm is the
    sampler config's, which validates it; print_offset the dataset spec's)."""
    commands = _commands()
    for name, sub in _subparsers(cli.build_parser()).items():
        numeric = {a.dest for a in sub._actions if a.type in (int, float)}
        declared, others = (commands[name][1].keys(), commands[name][2]) if name in commands \
            else (set(), set())  # fmt: skip
        assert numeric == set(declared) | others, name


def _bad_values(bound: Bound, is_float: bool) -> list[str]:
    below = bound.low - 1 if bound.low is not None and not bound.low_open else bound.low
    values = [f"{below:g}" if below is not None else "-1"]
    if is_float:
        values += ["nan", "inf", "-inf"]
    if bound.high is not None:
        values.append(str(int(bound.high) + 1) if not is_float else f"{bound.high * 2 + 1:g}")
    return values


def _numeric_cases():
    cases = []
    parsers = _subparsers(cli.build_parser())
    for name, (_, bounds, _) in _commands().items():
        types = {a.dest: a.type for a in parsers[name]._actions}
        for dest, bound in bounds.items():
            for value in _bad_values(bound, types[dest] is float):
                cases.append(pytest.param(name, dest, value, id=f"{name}-{dest}={value}"))
    return cases


def _argv(name: str, tmp_path: Path) -> list[str]:
    """The command's required words, on a dataset and outputs that do not exist."""
    ds, out = str(tmp_path / "no-dataset"), str(tmp_path / "out")
    return {
        "sample": ["sample", "--n", "1", "--out", out, "--quiet"],
        "gauge": ["gauge", "--out", out],
        "check": ["check", ds],
        "physics": ["physics", ds],
        "eval": ["eval", "--agent", "scripted", "--dataset", ds, "--out", out + ".json"],
        "view": ["view", ds],
        "train": ["train", "--algo", "ppo", "--preset", "debug", "--dataset", ds, "--out", out],
        "bench assets": ["bench", "assets", "--dir", out],
        "bench sim": ["bench", "sim", "--dataset", ds],
        "bench load": ["bench", "load", "--dataset", ds],
        "bench contacts": ["bench", "contacts", ds, "--json", out + ".json"],
    }[name]


@pytest.mark.parametrize(("name", "dest", "value"), _numeric_cases())
def test_numeric_flag_out_of_bounds_is_refused_first(capsys, tmp_path, name, dest, value):
    """Every numeric flag of train, eval, sample, bench, check, physics and view: not a
    finite number, or out of its bounds, is refused before the dataset is read and before
    anything is written."""
    option = "--" + dest.replace("_", "-")
    line = refused(capsys, [*_argv(name, tmp_path), f"{option}={value}"], f"{option} ")
    assert "give" in line or "ask for" in line or "seeds are" in line or "stack at" in line
    nothing_in(tmp_path)


def test_bounds_read_as_advice() -> None:
    whole = Bound(low=1, high=MAX_COUNT).describe(True)
    assert whole == f"give a whole number from 1 to {MAX_COUNT}"
    assert Bound(low=0.0, low_open=True).describe(False) == "give a finite number greater than 0"
    assert not Bound(low=0.0).accepts(float("nan")) and Bound(low=0.0).accepts(0.0)


# ------------------------------------------------------------------ sample


class TestSample:
    def test_unknown_format_is_refused_before_dataset_json(self, capsys, tmp_path):
        out = tmp_path / "d"
        argv = ["sample", "--n", "2", "--out", str(out), "--formats", "obj", "--quiet"]
        line = refused(capsys, argv, "unknown export format", "'obj'", "--formats")
        assert "valid: ['collision', 'mjcf', 'usd']" in line
        nothing_in(tmp_path)  # so the corrected command is not refused as another spec

    def test_unknown_format_of_an_assembly_family_too(self, capsys, tmp_path):
        argv = ["sample", "--n", "1", "--out", str(tmp_path / "d"), "--family", "profile-bolt"]
        refused(capsys, [*argv, "--formats", "mjcf,"], "unknown export format")
        nothing_in(tmp_path)

    @pytest.mark.parametrize(
        ("flags", "words"),
        [
            (["--n", "0"], ["--n 0", "ask for at least 1 module"]),
            (["--n", "-5"], ["--n -5"]),
            (["--n", "2", "--seed", "-1"], ["--seed -1", "non-negative"]),
            (["--n", "2", "--workers", "0"], ["--workers 0", "at least 1 process"]),
            (["--n", "2", "--clearance-mm", "nan"], ["clearance = nan is not a finite number"]),
        ],
    )
    def test_bad_numbers(self, capsys, tmp_path, flags, words):
        refused(capsys, ["sample", "--out", str(tmp_path / "d"), "--quiet", *flags], *words)
        nothing_in(tmp_path)

    def test_out_under_a_file(self, capsys, tmp_path):
        (tmp_path / "file").write_text("x")
        refused(capsys, ["sample", "--n", "1", "--out", str(tmp_path / "file" / "d")],
                "cannot write the dataset", "is a file", "--out")  # fmt: skip
        assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]

    def test_spec_fields_are_typed(self):
        from assetgen.dataset.spec import DatasetError, DatasetSpec

        with pytest.raises(DatasetError, match="list of format names"):
            DatasetSpec("x", 0, 1, formats="mjcf").validate()  # type: ignore[arg-type]
        with pytest.raises(DatasetError, match="whole numbers"):
            DatasetSpec("x", 0, True).validate()  # type: ignore[arg-type]

    def test_huge_n_streams_its_plan(self, tmp_path, monkeypatch):
        """sample --n 1e9 builds no table of every module: the first seeds reach the workers
        at once, in little memory (the whole run is not made: the workers are replaced)."""
        from assetgen.dataset import generate as gen
        from assetgen.dataset.spec import DatasetSpec
        from assetgen.params.sampler import SamplerConfig

        class Taken(Exception):
            pass

        seen: dict = {}

        def first_three(root, spec, seeds, workers, progress, cluster=None, *, total):
            it = iter(seeds)
            seen["seeds"], seen["total"] = [next(it) for _ in range(3)], total
            raise Taken

        import assetgen.dataset.module_writer  # noqa: F401 (its imports are not the plan's)

        monkeypatch.setattr(gen, "_run", first_three)
        spec = DatasetSpec("huge", 7, 10**9, SamplerConfig(), ("mjcf",))
        tracemalloc.start()
        t0 = time.perf_counter()
        with pytest.raises(Taken):
            gen.generate(tmp_path / "huge", spec, workers=1, progress=False)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert seen == {"seeds": [7, 8, 9], "total": 10**9}
        assert peak < 20e6 and time.perf_counter() - t0 < 10  # not a table of 1e9 ids


# ------------------------------------------------------------------ check


class TestCheck:
    def test_repair_of_a_spec_with_unknown_formats_is_one_line(self, capsys, tmp_path):
        """A dataset.json that an earlier version wrote with an unknown format: --repair says
        so instead of crashing, and deletes nothing."""
        from assetgen import GENERATOR_VERSION
        from assetgen.dataset.spec import DatasetSpec

        root = tmp_path / "d"
        (root / "modules" / "000000").mkdir(parents=True)
        spec = DatasetSpec("d", 0, 1, formats=("obj",)).to_json()
        info = {"generator_version": GENERATOR_VERSION, "spec": spec, "summary": None}
        (root / "dataset.json").write_text(json.dumps(info))
        (root / "manifest.jsonl").write_text("")
        assert cli.main(["check", str(root), "--repair", "--quiet"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "unknown export format(s) ['obj']" in err[0], err
        assert (root / "modules" / "000000").is_dir()
        assert json.loads((root / "dataset.json").read_text())["spec"] == spec


# ------------------------------------------------------------------ eval


@pytest.fixture(scope="module")
def one_module(tmp_path_factory) -> Path:
    """One test-set module with its MJCF (a few seconds)."""
    from assetgen.dataset.generate import generate
    from assetgen.dataset.spec import DatasetSpec
    from assetgen.params.sampler import SamplerConfig

    root = tmp_path_factory.mktemp("preflight") / "ds"
    spec = DatasetSpec("ds", 2048, 1, SamplerConfig(), ("collision", "mjcf"))
    assert not generate(root, spec, workers=1, progress=False).failures
    return root


class TestEval:
    def args(self, tmp_path: Path, *more: str) -> list[str]:
        return ["eval", "--agent", "scripted", "--dataset", str(tmp_path / "no-dataset"), *more]

    def test_out_is_a_folder(self, capsys, tmp_path):
        folder = tmp_path / "results"
        folder.mkdir()
        refused(capsys, self.args(tmp_path, "--out", str(folder)),
                f"--out {folder}: is a folder", "results.json")  # fmt: skip
        assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]  # no results.tmp
        nothing_in(folder)

    def test_out_under_a_file(self, capsys, tmp_path):
        (tmp_path / "file").write_text("x")
        out = tmp_path / "file" / "eval.json"
        refused(capsys, self.args(tmp_path, "--out", str(out)), f"--out {out}", "is a file")
        assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]

    def test_out_in_a_folder_that_cannot_be_written(self, capsys, tmp_path):
        locked = tmp_path / "locked"
        locked.mkdir()
        locked.chmod(0o500)
        try:
            if os.access(locked, os.W_OK):
                pytest.skip("running as a user that can write anywhere")
            out = locked / "new" / "eval.json"
            refused(capsys, self.args(tmp_path, "--out", str(out)), "--out", "cannot write")
            nothing_in(locked)
        finally:
            locked.chmod(0o700)

    def test_out_in_a_new_folder_passes_the_check(self, capsys, tmp_path):
        """A folder to be made is fine: the error is then the missing dataset's."""
        out = tmp_path / "new" / "sub" / "eval.json"
        refused(capsys, self.args(tmp_path, "--out", str(out)), "is not a dataset")
        nothing_in(tmp_path)

    def test_record_is_a_file(self, capsys, tmp_path):
        (tmp_path / "file").write_text("x")
        refused(capsys, self.args(tmp_path, "--record", str(tmp_path / "file")),
                "--record", "is a file")  # fmt: skip

    @pytest.mark.parametrize("value", ["nan", "inf", "-1"])
    def test_noise_scale(self, capsys, tmp_path, value):
        refused(capsys, self.args(tmp_path, "--noise-scale", value, "--out",
                                  str(tmp_path / "e.json")), f"--noise-scale {value}")  # fmt: skip
        nothing_in(tmp_path)

    def test_keep_dataset_physics_reaches_the_built_in_agents(self, capsys, tmp_path, one_module):
        """A dataset written for other physics is refused, naming --keep-dataset-physics; with
        it, a built-in agent plays it on the physics its files carry."""
        old = tmp_path / "old"
        shutil.copytree(one_module, old)
        info = json.loads((old / "dataset.json").read_text())
        del info["physics"]  # as generator 0.5.0 wrote it: physics version 1
        (old / "dataset.json").write_text(json.dumps(info))
        argv = ["eval", "--agent", "scripted", "--dataset", str(old), "--attempts", "1", "--json"]
        refused(capsys, argv, "physics version 1", "--keep-dataset-physics")
        assert cli.main([*argv, "--keep-dataset-physics"]) == 0
        res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert res["physics_version"] == 1 and res["timestep"] == 0.005 and res["episodes"] == 1


def test_a_failed_atomic_write_leaves_no_tmp(tmp_path):
    """eval --out, view --html and every JSON the project writes: a write that fails at its
    rename (a folder in the way) leaves nothing beside it."""
    from assetgen.core.atomic_file import write_json

    (tmp_path / "x.json").mkdir()
    with pytest.raises(IsADirectoryError):
        write_json(tmp_path / "x.json", {"a": 1})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.json"]


# ------------------------------------------------------------------ view


class TestView:
    def test_html_is_a_folder(self, capsys, tmp_path):
        folder = tmp_path / "page"
        folder.mkdir()
        refused(capsys, ["view", str(tmp_path / "no-dataset"), "--html", str(folder)],
                f"--html {folder}: is a folder", "snapshot.html")  # fmt: skip
        assert sorted(p.name for p in tmp_path.iterdir()) == ["page"]

    def test_html_under_a_file(self, capsys, tmp_path):
        (tmp_path / "file").write_text("x")
        page = tmp_path / "file" / "page.html"
        refused(capsys, ["view", str(tmp_path / "no-dataset"), "--html", str(page)],
                "--html", "is a file")  # fmt: skip


# ------------------------------------------------------------------ train


class TestTrain:
    def args(self, tmp_path: Path, out: Path, *more: str) -> list[str]:
        ds = str(tmp_path / "no-dataset")
        return ["train", "--algo", "ppo", "--preset", "debug", "--dataset", ds,
                "--out", str(out), "--no-progress", *more]  # fmt: skip

    @pytest.mark.parametrize("value", ["nan", "inf", "-inf", "-1", "0"])
    def test_minutes(self, capsys, tmp_path, value):
        refused(capsys, self.args(tmp_path, tmp_path / "run", f"--minutes={value}"),
                f"--minutes {float(value)}", "positive, finite")  # fmt: skip
        nothing_in(tmp_path)

    def test_out_is_a_file(self, capsys, tmp_path):
        (tmp_path / "run").write_text("x")
        refused(capsys, self.args(tmp_path, tmp_path / "run"), "--out", "is a file")
        assert (tmp_path / "run").read_text() == "x"

    def test_out_holds_a_run_without_resume(self, capsys, tmp_path):
        from rl.checkpoint import FILE_NAME
        from rl.commands import CHECKPOINT_FILE

        assert CHECKPOINT_FILE == FILE_NAME
        run = tmp_path / "run"
        run.mkdir()
        (run / FILE_NAME).write_bytes(b"")
        refused(capsys, self.args(tmp_path, run), "already holds a run", "--resume")
        assert sorted(p.name for p in run.iterdir()) == [FILE_NAME]

    def test_resume_without_a_run(self, capsys, tmp_path):
        refused(capsys, self.args(tmp_path, tmp_path / "run", "--resume"),
                "--resume: no checkpoint at", "drop --resume")  # fmt: skip
        nothing_in(tmp_path)

    def test_seed_numpy_cannot_take(self, capsys, tmp_path):
        refused(capsys, self.args(tmp_path, tmp_path / "run", "--seed", str(2**32)),
                f"--seed {2**32}", "from 0 to 4294967295")  # fmt: skip
        nothing_in(tmp_path)


# ------------------------------------------------------------------ report


def test_report_out_is_a_file(capsys, tmp_path):
    (tmp_path / "r").write_text("x")
    refused(capsys, ["report", "--out", str(tmp_path / "r")], "--out", "is a file")


# ------------------------------------------------------------------ bench


class TestBench:
    def test_assets_n_0_makes_no_scratch_folder(self, capsys, tmp_path):
        refused(capsys, ["bench", "assets", "--n", "0", "--dir", str(tmp_path / "s")],
                "--n 0", "at least 1 module")  # fmt: skip
        nothing_in(tmp_path)

    def test_sim_envs_0_is_not_the_default(self, capsys, tmp_path):
        """--envs 0 ran the default 1024 envs: now refused."""
        refused(capsys, ["bench", "sim", "--envs", "0", "--dataset", str(tmp_path / "x")],
                "--envs 0", "at least 1 environment")  # fmt: skip

    def test_contacts_json_is_a_folder(self, capsys, tmp_path):
        refused(capsys, ["bench", "contacts", str(tmp_path / "x"), "--json", str(tmp_path)],
                "--json", "is a folder")  # fmt: skip
        nothing_in(tmp_path)
