"""A full disk, for real: a small tmpfs fills while `sample` writes into it. The run stops in
one line that says so, every module it finished is kept whole, and once there is room the
same command finishes the dataset with the bytes of an uninterrupted run. Needs root and
tmpfs (skipped elsewhere)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

import cli
from tests.test_faults_errors import one_error_line


@pytest.fixture
def small_disk(tmp_path: Path):
    """A 1 MiB tmpfs at tmp_path/small, grown with `grow(mib)`; unmounted afterwards."""
    mount = tmp_path / "small"
    mount.mkdir()
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a tmpfs needs root")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mount)],
                          capture_output=True)  # fmt: skip
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")

    def grow(mib: int) -> None:
        subprocess.run(["mount", "-o", f"remount,size={mib}m", str(mount)], check=True)

    try:
        yield mount, grow
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)


def _hash(root: Path) -> str:
    return json.loads((root / "dataset.json").read_text())["summary"]["content_hash"]


def test_sample_on_a_full_disk_keeps_what_it_finished_and_resumes(small_disk, tmp_path, capsys):
    mount, grow = small_disk
    out = mount / "ds"
    argv = ["sample", "--n", "24", "--seed", "0", "--workers", "1", "--out", str(out)]
    capsys.readouterr()
    code = cli.main(argv)
    err = capsys.readouterr().err
    assert code == 2
    line = one_error_line(err)
    assert "no space left on device" in line.lower(), line
    assert "finished modules are kept" in line and "run the same command again" in line, line
    # what is there is whole: every module folder in place holds its files, as recorded
    modules = sorted(p for p in (out / "modules").iterdir() if p.is_dir())
    assert 0 < len(modules) < 24
    for m in modules:
        assert (m / "module.json").is_file() and (m / "peg_in_hole.xml").is_file(), m
    grow(64)
    assert cli.main(argv) == 0
    reference = tmp_path / "reference"
    assert cli.main([*argv[:-1], str(reference)]) == 0
    assert _hash(out) == _hash(reference)
