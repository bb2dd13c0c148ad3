"""Datasets: determinism, kill-and-resume, corruption detection, spec refusal, loader API."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest

from assetgen.dataset.check import check_dataset, repair
from assetgen.dataset.generate import generate
from assetgen.dataset.reader import Dataset
from assetgen.dataset.spec import DatasetError, DatasetSpec, resolve
from assetgen.formats.registry import available_formats
from assetgen.params.sampler import SamplerConfig

from .conftest import TINY_SEEDS

ROOT = Path(__file__).resolve().parent.parent


def _spec(n=6, seed=0, name="t"):
    return DatasetSpec(name, seed, n, SamplerConfig(), available_formats())


def _files(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and p.name != "dataset.json"
    }


def test_two_runs_are_byte_identical(tmp_path, tiny_dataset):
    s = generate(tmp_path / "b", _spec(TINY_SEEDS), workers=2, progress=False)
    a_info = json.loads((tiny_dataset / "dataset.json").read_text())
    assert s.content_hash == a_info["summary"]["content_hash"]
    assert _files(tmp_path / "b") == _files(tiny_dataset)


def test_kill_and_resume_equals_uninterrupted(tmp_path, tiny_dataset):
    out = tmp_path / "killed"
    n = TINY_SEEDS
    cmd = [
        sys.executable,
        "-m",
        "cli",
        "sample",
        "--n",
        str(n),
        "--out",
        str(out),
        "--workers",
        "1",
        "--quiet",
    ]
    proc = subprocess.Popen(cmd, cwd=ROOT, start_new_session=True)
    deadline = time.time() + 120
    while time.time() < deadline:
        done = [d for d in (out / "modules").glob("[0-9]*")] if (out / "modules").exists() else []
        if len(done) >= 2:
            break
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    partial = len(list((out / "modules").glob("[0-9]*")))
    assert 0 < partial < n, "the run should have been killed mid-way"
    s = generate(out, _spec(n, name="killed"), workers=1, progress=False)
    assert s.cached >= 2 and not s.failures
    assert not list((out / "modules").glob(".tmp-*"))
    info = json.loads((tiny_dataset / "dataset.json").read_text())
    assert s.content_hash == info["summary"]["content_hash"]


def test_cached_rerun_generates_nothing(tiny_dataset):
    t0 = time.perf_counter()
    s = generate(tiny_dataset, _spec(TINY_SEEDS, name="tiny"), progress=False)
    assert s.generated == 0 and s.cached == TINY_SEEDS
    assert time.perf_counter() - t0 < 5.0


def test_mismatched_spec_is_refused(tiny_dataset):
    other = replace(_spec(TINY_SEEDS, name="tiny"), config=replace(SamplerConfig(), taper=(0, 0.1)))
    with pytest.raises(DatasetError, match=r"different spec.*--overwrite"):
        generate(tiny_dataset, other, progress=False)


def test_foreign_folder_is_refused(tmp_path):
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "notes.txt").write_text("mine")
    with pytest.raises(DatasetError, match=r"not empty and holds no dataset\.json"):
        generate(tmp_path / "x", _spec(2), progress=False)
    assert (tmp_path / "x" / "notes.txt").read_text() == "mine"


def test_check_finds_and_repairs_corruption(tmp_path):
    root = tmp_path / "c"
    s0 = generate(root, _spec(4), workers=1, progress=False)
    assert check_dataset(root).ok
    ds = Dataset(root)
    victim = ds.paths(ds.ids[1])["module_stl"]
    data = bytearray(victim.read_bytes())
    data[200] ^= 0xFF
    victim.write_bytes(bytes(data))
    import shutil

    shutil.rmtree(ds.module_dir(ds.ids[2]))
    report = check_dataset(root)
    assert not report.ok
    assert report.missing == [ds.ids[2]]
    assert ds.ids[1] in report.corrupt and "module.stl" in report.corrupt[ds.ids[1]]
    s = repair(root, report, workers=1, progress=False)
    assert s.generated == 2
    assert check_dataset(root).ok
    assert s.content_hash == s0.content_hash


def test_corrupt_manifest_line_is_reported_and_repaired(tmp_path):
    root = tmp_path / "m"
    s0 = generate(root, _spec(3), workers=1, progress=False)
    with (root / "manifest.jsonl").open("a") as f:
        f.write("{not json\n")
    with pytest.raises(DatasetError, match=r"manifest.jsonl:4 is not a valid manifest line"):
        Dataset(root)
    report = check_dataset(root)
    assert report.manifest_error and not report.ok
    s = repair(root, report, workers=1, progress=False)
    assert s.generated == 0 and s.content_hash == s0.content_hash
    assert len(Dataset(root)) == 3


def test_loader_api(tiny_dataset):
    ds = Dataset(tiny_dataset)
    assert len(ds) == TINY_SEEDS and ds.ids == [f"{i:06d}" for i in range(TINY_SEEDS)]
    meta = ds.module_json(ds.ids[0])
    assert {"params", "clearance", "frames", "checks"} <= set(meta)
    for k in ("entrance", "bottom"):
        assert len(meta["frames"][k]["pos"]) == 3 and len(meta["frames"][k]["quat"]) == 4
    paths = ds.paths(ds.ids[0])
    assert paths["peg_stl"].exists() and paths["module_stl"].exists() and paths["3mf"].exists()
    with pytest.raises(DatasetError, match="not in"):
        ds.module_dir("999999")


def test_resolve_names_and_paths(tmp_path):
    _, spec = resolve("train")
    assert spec is not None and spec.count == 1024 and spec.seed_start == 0
    _, test_spec = resolve("test")
    assert test_spec.seed_start == 2048 and test_spec.count == 1024
    with pytest.raises(DatasetError, match="no dataset spec named"):
        resolve("nonexistent_name")
    with pytest.raises(DatasetError, match="is not a dataset"):
        Dataset(tmp_path)


def test_bad_spec_file():
    with pytest.raises(DatasetError, match="unknown key"):
        DatasetSpec.from_json({"name": "x", "seed_start": 0, "count": 1, "colour": 1})
    with pytest.raises(DatasetError, match="at least 1 module"):
        DatasetSpec.from_json({"name": "x", "seed_start": 0, "count": 0})


def test_full_disk_mid_run_keeps_finished_modules_and_resumes(tmp_path, tiny_dataset, monkeypatch):
    """ENOSPC while writing the 4th module: a clear error, the 3 finished modules kept, no
    half-written folder left; the next run completes to the uninterrupted content hash."""
    import errno

    from assetgen.dataset import module_writer

    real = module_writer.write_json
    calls = []

    def filling_disk(path, data):
        calls.append(path)
        if len(calls) == 4:
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        real(path, data)

    monkeypatch.setattr(module_writer, "write_json", filling_disk)
    out = tmp_path / "full"
    with pytest.raises(DatasetError, match=r"stopped after 3 of 6 modules.*No space left"):
        generate(out, _spec(TINY_SEEDS, name="full"), workers=1, progress=False)
    assert len(list((out / "modules").glob("[0-9]*"))) == 3
    assert not list((out / "modules").glob(".tmp-*"))
    assert len((out / "manifest.jsonl").read_text().splitlines()) == 3
    monkeypatch.setattr(module_writer, "write_json", real)
    s = generate(out, _spec(TINY_SEEDS, name="full"), workers=1, progress=False)
    assert s.cached == 3 and s.generated == 3 and not s.failures
    info = json.loads((tiny_dataset / "dataset.json").read_text())
    assert s.content_hash == info["summary"]["content_hash"]


def test_a_seed_refused_by_the_footprint_rule_is_drawn_again(tmp_path):
    """Seed 1000071's first draw leans its sleeve out of the plate (one of 72 in the
    100,000-module run): the writer takes the seed's second draw, records it, and the module
    passes every check; a seed whose first draw builds keeps it (no `draw` key)."""
    from assetgen.dataset.module_writer import generate_module
    from assetgen.geometry.solids import FootprintError, build_module
    from assetgen.params.sampler import sample_params

    cfg = SamplerConfig()
    with pytest.raises(FootprintError):
        build_module(sample_params(cfg, 1000071))
    record = generate_module(1000071, cfg, tmp_path)
    assert record["draw"] == 1
    assert record["params"] == sample_params(cfg, 1000071, 1).to_json()
    assert record["checks"]["clearance_m"] == pytest.approx(1e-3, abs=1e-6)
    assert "draw" not in generate_module(1000072, cfg, tmp_path)
    assert sample_params(cfg, 5, 0) == sample_params(cfg, 5) != sample_params(cfg, 5, 1)
