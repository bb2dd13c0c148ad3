"""benchmarks/ccd_recheck.py: a report's failing modules checked again with libccd."""

from __future__ import annotations

import json
from pathlib import Path

from assetgen.dataset.reader import Dataset
from assetgen.physics.report import check_module, failures
from benchmarks import ccd_recheck


def test_a_failed_module_is_checked_again_with_libccd(
    tiny_dataset: Path, tmp_path: Path, monkeypatch
) -> None:
    """The modules a report lists as failed are checked again with libccd, and only they.
    (Since generator 0.7.0 no module of the tiny dataset meets MuJoCo's multiccd glitch,
    which the recheck was written for, so the report here says module 000001 failed.)"""
    native = check_module(Dataset(tiny_dataset).paths("000001")["mjcf"])
    assert not failures(native)  # each face of the hole is one piece's: no glitch
    native["seconds"] = 1.0
    report = {"modules": {"000001": native, "000002": native},
              "failed": {"000001": ["passed_through"]}}  # fmt: skip
    src = tmp_path / "report.json"
    src.write_text(json.dumps(report))
    seen = []

    def spy(path):
        seen.append('nativeccd="disable"' in Path(path).read_text())
        return check_module(path)

    monkeypatch.setattr(ccd_recheck, "check_module", spy)
    rows = ccd_recheck.recheck(src, tiny_dataset, tmp_path / "out.json")
    assert seen == [True]  # one module, its MJCF with libccd
    assert rows.keys() == {"000001"}
    assert rows["000001"]["libccd_failed"] == [], rows["000001"]["libccd_failed"]
    assert rows["000001"]["nativeccd_failed"] == ["passed_through"]
    assert rows["000001"]["libccd"]["penetration_transient"] < 1e-3
    assert json.loads((tmp_path / "out.json").read_text()).keys() == {"000001"}
