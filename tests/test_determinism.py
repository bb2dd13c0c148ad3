"""The same seed gives the same bytes on every machine: CPU-dependent arithmetic (OpenBLAS
kernels, numpy's AVX-512 dispatch) is emulated here, and a golden hash pins the files."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SEEDS = (26, 3)
"""Seeds 26-28: their holes move under another BLAS kernel, and seed 27's peg inertia under
numpy's power without AVX-512, with the generator's arithmetic left to the libraries."""
GOLDEN_HASH = "6e844deacc5cff1d60e48aaac1f1f31d234395fd58ddc93898b63cec9cd601d2"
"""Content hash of seeds 26-28, every format, for the versions in constraints.txt."""
OTHER_CPUS = {
    "BLAS kernel without FMA (Prescott)": {"OPENBLAS_CORETYPE": "Prescott"},
    "an AVX2 machine (Haswell BLAS, numpy without AVX-512)": {
        "OPENBLAS_CORETYPE": "Haswell",
        "NPY_DISABLE_CPU_FEATURES": "AVX512_ICL X86_V4",
    },
}


FAMILY_SEEDS = {"profile": (0, 4), "multi-peg": (0, 6), "profile-bolt": (0, 4)}
"""(first seed, count) of each assembly family: before their layout used the portable
arithmetic, each of these sets came out with other bytes under both emulations."""


def _content_hash(out: Path, env: dict[str, str], family: str | None = None) -> str:
    start, count = SEEDS if family is None else FAMILY_SEEDS[family]
    cmd = [sys.executable, "-m", "cli", "sample", "--n", str(count), "--seed", str(start),
           "--out", str(out), "--workers", "1", "--quiet"]  # fmt: skip
    cmd += [] if family is None else ["--family", family]
    p = subprocess.run(cmd, cwd=ROOT, env={**os.environ, **env}, capture_output=True, text=True)
    if p.returncode != 0 and "NPY_DISABLE_CPU_FEATURES" in p.stderr:
        pytest.skip(f"numpy on this CPU cannot emulate {env}: {p.stderr.strip()[-200:]}")
    assert p.returncode == 0, p.stdout + p.stderr
    return json.loads((out / "dataset.json").read_text())["summary"]["content_hash"]


@pytest.fixture(scope="module")
def native_hash(tmp_path_factory) -> str:
    return _content_hash(tmp_path_factory.mktemp("native") / "d", {})


@pytest.mark.parametrize("cpu", sorted(OTHER_CPUS))
def test_same_bytes_on_another_cpu(native_hash, tmp_path, cpu):
    assert _content_hash(tmp_path / "d", OTHER_CPUS[cpu]) == native_hash


@pytest.mark.parametrize("family", sorted(FAMILY_SEEDS))
def test_assembly_families_same_bytes_on_other_cpus(tmp_path, family):
    """Each assembly family's first modules under both emulations: the same content hash as
    natively (their layout, pieces, principal axes and gains use core.portable)."""
    native = _content_hash(tmp_path / "native", {}, family)
    for name, env in sorted(OTHER_CPUS.items()):
        assert _content_hash(tmp_path / name.split()[0], env, family) == native, name


def _pinned() -> dict[str, str]:
    lines = (ROOT / "constraints.txt").read_text().splitlines()
    pins = [line.split("==") for line in lines if "==" in line and not line.startswith("#")]
    return {name.strip(): version.strip() for name, version in pins}


def test_golden_content_hash(native_hash):
    # a local build tag (torch's "+cpu") is the same release; torch writes no module file
    differ = {
        name: (version, metadata.version(name))
        for name, version in _pinned().items()
        if metadata.version(name).split("+")[0] != version
    }
    if differ:
        pytest.skip(f"the golden hash holds for constraints.txt; installed differ: {differ}")
    assert native_hash == GOLDEN_HASH
