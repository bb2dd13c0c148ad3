"""Faults in a dataset: nothing lost and nothing silently wrong.

Each file a module holds, tampered after generation, is found by `assetgen check` (which
module, which file), and the files the simulator reads are found by loading the dataset for
simulation too (one line: the module, the file, `assetgen check --repair`), unless the
verification is switched off. A lost or corrupt dataset.json is rebuilt byte for byte; a
moved or renamed dataset is recognised by its spec, not its folder's name.

Every test works on its own copy of the session's tiny dataset (six modules).
"""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import pytest

from assetgen.dataset.check import check_dataset, repair
from assetgen.dataset.module_writer import MEASURE_DIGITS as WRITER_DIGITS
from assetgen.dataset.reader import MEASURE_DIGITS, Dataset, content_hash
from assetgen.dataset.spec import DatasetError
from sim.assets.loading import SKIP_VERIFY_ENV, AssetError, load_dataset, verify_module_files

MID = "000002"
"""The module every fault is made in."""


@pytest.fixture
def ds(tiny_dataset: Path, tmp_path: Path) -> Path:
    """A copy of the tiny dataset, in a folder named as its spec (`tiny`)."""
    root = tmp_path / "tiny"
    shutil.copytree(tiny_dataset, root)
    return root


def flip_byte(path: Path, at: int = 100) -> None:
    data = bytearray(path.read_bytes())
    data[at] ^= 0x01
    path.write_bytes(bytes(data))


def scale_peg(path: Path, factor: float = 1.3) -> None:
    """The MJCF with its peg's vertices scaled by `factor` (still valid XML and meshes)."""
    text = path.read_text()
    m = re.search(r'(<mesh name="peg" scale="[^"]*" vertex=")([^"]*)(")', text)
    assert m is not None
    scaled = " ".join(f"{float(v) * factor:.9g}" for v in m.group(2).split())
    path.write_text(text[: m.start(2)] + scaled + text[m.end(2) :])


def edit_frames(path: Path) -> None:
    meta = json.loads(path.read_text())
    meta["frames"]["entrance"]["pos"][2] += 0.01  # the hole's entrance 10 mm higher
    path.write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")


def edit_manifest_params(root: Path, mid: str = MID) -> None:
    lines = (root / "manifest.jsonl").read_text().splitlines()
    out = []
    for line in lines:
        rec = json.loads(line)
        if rec["id"] == mid:
            rec["params"]["clearance"] *= 1.5
            line = json.dumps(rec, sort_keys=True)
        out.append(line + "\n")
    (root / "manifest.jsonl").write_text("".join(out))


def one_line_naming(err: str, root: Path, file: str) -> None:
    assert "\n" not in err, err
    assert f"module {MID}" in err and file in err, err
    assert f"assetgen check {root} --repair" in err, err


# (what is tampered, file the fault names, whether the MuJoCo simulator reads it)
FAULTS = {
    "peg.stl byte": (lambda r, d: flip_byte(d / "peg.stl"), "peg.stl", False),
    "module.stl byte": (lambda r, d: flip_byte(d / "module.stl"), "module.stl", False),
    "3mf byte": (lambda r, d: flip_byte(d / "peg_in_hole.3mf"), "peg_in_hole.3mf", False),
    "usd byte": (lambda r, d: flip_byte(d / "peg_in_hole.usda", 400), "peg_in_hole.usda", False),
    "mjcf peg scaled": (lambda r, d: scale_peg(d / "peg_in_hole.xml"), "peg_in_hole.xml", True),
    "module.json frames": (
        lambda r, d: edit_frames(d / "module.json"),
        "frames.entrance.pos",
        True,
    ),
    "manifest params": (lambda r, d: edit_manifest_params(r), "params.clearance", True),
}


@pytest.mark.parametrize("fault", FAULTS)
def test_a_tampered_file_is_found_by_check_and_by_loading(ds: Path, fault: str) -> None:
    tamper, named, sim_reads = FAULTS[fault]
    tamper(ds, ds / "modules" / MID)
    report = check_dataset(ds, geometry_checks=False)
    assert not report.ok and report.bad == [MID], report
    assert named in report.corrupt[MID], report.corrupt
    if sim_reads:
        with pytest.raises(AssetError) as e:
            load_dataset(ds)
        one_line_naming(str(e.value), ds, named)
    else:
        assert len(load_dataset(ds)) == 6  # a file MuJoCo does not read
    if fault == "usd byte":  # the file the PhysX engine reads: checked there
        with pytest.raises(AssetError) as e:
            verify_module_files([ds / "modules" / MID], ["peg_in_hole.usda"])
        one_line_naming(str(e.value), ds, named)


@pytest.mark.parametrize("fault", ["mjcf peg scaled", "manifest params"])
def test_repair_restores_the_generated_bytes(ds: Path, tiny_dataset: Path, fault: str) -> None:
    manifest = (ds / "manifest.jsonl").read_bytes()
    FAULTS[fault][0](ds, ds / "modules" / MID)
    s = repair(ds, check_dataset(ds, geometry_checks=False), workers=1, progress=False)
    assert s.generated == 1 and not s.failures
    assert check_dataset(ds, geometry_checks=False).ok
    assert (ds / "manifest.jsonl").read_bytes() == manifest
    for f in (tiny_dataset / "modules" / MID).iterdir():
        assert (ds / "modules" / MID / f.name).read_bytes() == f.read_bytes(), f.name
    assert len(load_dataset(ds)) == 6


def test_the_skip_switch(ds: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    scale_peg(ds / "modules" / MID / "peg_in_hole.xml")
    assert len(load_dataset(ds, verify=False)) == 6
    monkeypatch.setenv(SKIP_VERIFY_ENV, "1")
    assert len(load_dataset(ds)) == 6
    verify_module_files([ds / "modules" / MID], ["peg_in_hole.xml"])
    monkeypatch.setenv(SKIP_VERIFY_ENV, "0")
    with pytest.raises(AssetError, match=r"peg_in_hole\.xml does not match"):
        load_dataset(ds)


def test_verified_once_per_process_while_the_manifest_stands(ds: Path) -> None:
    assert len(load_dataset(ds)) == 6
    scale_peg(ds / "modules" / MID / "peg_in_hole.xml")
    assert len(load_dataset(ds)) == 6  # verified already: not hashed again
    manifest = ds / "manifest.jsonl"
    st = manifest.stat()
    os.utime(manifest, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
    with pytest.raises(AssetError, match=r"peg_in_hole\.xml does not match"):
        load_dataset(ds)


@pytest.mark.parametrize("how", ["lost", "corrupt"])
def test_dataset_json_is_rebuilt_byte_identical(ds: Path, how: str) -> None:
    original = (ds / "dataset.json").read_bytes()
    if how == "lost":
        (ds / "dataset.json").unlink()
        with pytest.raises(DatasetError, match=f"lost.*assetgen check {ds} --repair"):
            Dataset(ds)
    else:
        (ds / "dataset.json").write_text('{"generator_version": ')  # not valid JSON
        with pytest.raises(DatasetError, match=f"corrupt.*assetgen check {ds} --repair"):
            Dataset(ds)
    report = check_dataset(ds, geometry_checks=False)
    assert not report.ok and report.spec_error and how in report.spec_error
    assert not report.bad
    s = repair(ds, report, workers=1, progress=False)
    assert s.generated == 0
    assert (ds / "dataset.json").read_bytes() == original


def test_a_spec_that_cannot_be_recovered_says_so(ds: Path) -> None:
    (ds / "dataset.json").unlink()
    edit_manifest_params(ds, "000000")  # no config samples these parameters
    with pytest.raises(DatasetError) as e:
        check_dataset(ds, geometry_checks=False)
    msg = str(e.value)
    assert "\n" not in msg and "no spec matches" in msg and "restore dataset.json" in msg


def test_a_moved_and_renamed_dataset_is_recognised_by_its_spec(
    ds: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    original = (ds / "dataset.json").read_bytes()
    moved = tmp_path / "elsewhere" / "renamed"
    moved.parent.mkdir()
    ds.rename(moved)
    assert check_dataset(moved, geometry_checks=False).ok
    assert len(load_dataset(moved)) == 6
    flip_byte(moved / "modules" / MID / "peg.stl")
    report = check_dataset(moved, geometry_checks=False)
    assert report.bad == [MID]
    assert repair(moved, report, workers=1, progress=False).generated == 1
    assert (moved / "dataset.json").read_bytes() == original
    # its dataset.json lost too: the spec is found by content among the named specs
    specs = tmp_path / "specs"
    specs.mkdir()
    spec = json.loads(original)["spec"]
    (specs / "tiny.json").write_text(json.dumps(spec))
    monkeypatch.setattr("assetgen.dataset.check.SPECS_DIR", specs)
    (moved / "dataset.json").unlink()
    report = check_dataset(moved, geometry_checks=False)
    assert report.spec is not None and report.spec.name == "tiny"
    repair(moved, report, workers=1, progress=False)
    assert (moved / "dataset.json").read_bytes() == original


def test_check_with_geometry_still_passes_an_intact_copy(ds: Path) -> None:
    assert check_dataset(ds).ok
    assert (
        content_hash(Dataset(ds).records)
        == json.loads((ds / "dataset.json").read_text())["summary"]["content_hash"]
    )


def test_the_reader_rounds_as_the_writer() -> None:
    assert MEASURE_DIGITS == WRITER_DIGITS
