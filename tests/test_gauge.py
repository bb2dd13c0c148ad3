"""`assetgen gauge`: a printable clearance gauge whose files pass the module checks, each peg
exactly its clearance from the plate as written, labelled; bad input refused in one line,
nothing left behind."""

from __future__ import annotations

import json

import pytest

from assetgen.params.module_params import ParamError
from assetgen.printing.gauge import GaugeParams, build_gauge, label
from tests.test_cli import run as cli


def test_the_labels_read_as_the_clearances() -> None:
    assert [label(c) for c in GaugeParams().clearances] == [
        "0.1", "0.2", "0.3", "0.4", "0.5", "0.6", "0.7", "0.8", "0.9", "1.0"
    ]  # fmt: skip
    assert label(0.25e-3) == "0.25"
    gauge = build_gauge(GaugeParams())
    assert [s.clearance for s in gauge.steps] == pytest.approx(GaugeParams().clearances)
    assert len(gauge.parts) == 10 and len(gauge.base.holes) == 10


def test_the_written_gauge_carries_exactly_its_clearances(tmp_path) -> None:
    out = tmp_path / "gauge"
    p = cli("gauge", "--out", str(out), "--clearances-mm", "0.1,0.25,1")
    assert p.returncode == 0, p.stderr
    record = json.loads((out / "module.json").read_text())
    assert record["family"] == "gauge"
    files = {"module.json", "base.stl", "peg_01.stl", "peg_02.stl", "peg_03.stl",
             "assembly.3mf", "assembly.xml", "assembly.usda"}  # fmt: skip
    assert {f.name for f in out.iterdir()} == files
    measured = [s["clearance_m"] for s in record["checks"]["steps"]]
    assert measured == pytest.approx([1e-4, 2.5e-4, 1e-3], abs=1e-6)  # on the STL as written
    for name, t in record["checks"]["parts"].items():
        assert t["watertight"] and t["bodies"] == 1, name
    assert "0.25" in p.stdout and list(tmp_path.iterdir()) == [out]  # no staging folder left


@pytest.mark.parametrize(
    ("flags", "said"),
    [
        (("--clearances-mm", "0.1,3"), "clearance 3 mm is outside (0, 2] mm"),
        (("--clearances-mm", "0.1,x"), "'x' is not a number"),
        (("--diameter-mm", "-1"), "diameter"),
    ],
)
def test_bad_input_is_refused_in_one_line_and_nothing_is_written(tmp_path, flags, said) -> None:
    p = cli("gauge", "--out", str(tmp_path / "g"), *flags)
    err = p.stderr.strip().splitlines()
    assert p.returncode != 0 and len(err) == 1 and said in err[0], p.stderr
    assert not (tmp_path / "g").exists() and list(tmp_path.iterdir()) == []


def test_a_folder_with_files_is_not_overwritten(tmp_path) -> None:
    (tmp_path / "keep.txt").write_text("mine")
    p = cli("gauge", "--out", str(tmp_path), "--clearances-mm", "0.5")
    assert p.returncode != 0 and "not an empty folder" in p.stderr
    assert (tmp_path / "keep.txt").read_text() == "mine"


def test_pegs_that_would_not_stand_out_are_refused() -> None:
    with pytest.raises(ParamError, match="peg_height"):
        GaugeParams(peg_height=0.005).validate()
