"""Result files name paths as a clone can read them: relative to the working directory (the
repository root, where its commands run) when the path lies inside it
(assetgen/core/recorded_path.py), and no filed result in the repository names a folder of the
machine it was measured on."""

from __future__ import annotations

import re
from pathlib import Path

from assetgen.core.recorded_path import recorded_path
from tests.test_layout import repository_files

ROOT = Path(__file__).resolve().parents[1]


def test_inside_is_relative_outside_is_absolute(tmp_path: Path) -> None:
    repo = tmp_path / "repo"  # the rule is about names: nothing need exist
    assert recorded_path(repo / "datasets" / "test", repo) == "datasets/test"
    assert recorded_path(repo / "runs" / ".." / "datasets", repo) == "datasets"
    assert recorded_path(repo, repo) == "."
    assert recorded_path(tmp_path / "elsewhere", repo) == str(tmp_path / "elsewhere")
    # a sibling whose name starts like the root's is outside it
    assert recorded_path(tmp_path / "repo2" / "x", repo) == str(tmp_path / "repo2" / "x")


def test_working_directory_is_the_default(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert recorded_path(tmp_path / "runs" / "a") == "runs/a"
    assert recorded_path("runs/a") == "runs/a"  # a relative name stays as given
    assert recorded_path("test") == "test"  # so does a dataset spec's name


def test_no_filed_result_names_a_machine_path() -> None:
    """Every JSON file the repository tracks (evaluations, benchmarks, shipped checkpoints):
    a string value that is an absolute path names a folder of the machine that wrote it."""
    absolute = re.compile(rb'"(\w+)": "(/[^"]*)"')
    found = []
    for f in repository_files(ROOT):
        if f.suffix == ".json":
            found += [
                f"{f.relative_to(ROOT)}: {m[1].decode()} = {m[2].decode()}"
                for m in absolute.finditer(f.read_bytes())
            ]
    assert not found, "absolute paths filed:\n" + "\n".join(found[:20])
