"""`sample --print-offset MM`: the printed files' (STL, 3MF) hole faces move out by exactly the
offset, measured on the written STL; nothing else in them moves, the simulation files keep
their bytes, `assetgen check` knows, and an offset past the clearance is refused."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from assetgen.core.stl import read_stl_mm
from assetgen.dataset.check import check_dataset
from assetgen.dataset.generate import generate
from assetgen.dataset.spec import DatasetError, DatasetSpec
from assetgen.families.profile import ProfileSampler
from assetgen.geometry.polytope import offset_planes
from assetgen.geometry.solids import build_module
from assetgen.params.sampler import SamplerConfig, sample_params
from tests.test_cli import run as cli

OFFSET = 2e-4
SIM_FILES = ("peg.stl", "peg_in_hole.xml", "peg_in_hole.usda")


def _two(tmp_path, spec: DatasetSpec):
    plain = generate(tmp_path / "plain", spec, workers=1, progress=False)
    printed = generate(tmp_path / "printed", replace(spec, print_offset=OFFSET), workers=1,
                       progress=False)  # fmt: skip
    assert not plain.failures and not printed.failures
    return tmp_path / "plain" / "modules", tmp_path / "printed" / "modules"


def _on_planes(v: np.ndarray, planes: np.ndarray, tol: float = 2e-7) -> np.ndarray:
    return (np.abs(v @ planes[:, :3].T - planes[:, 3]) < tol).any(axis=1)


def test_only_the_hole_faces_move_and_by_exactly_the_offset(tmp_path) -> None:
    spec = DatasetSpec("p", 0, 2, SamplerConfig(), formats=("mjcf", "usd"))
    plain, printed = _two(tmp_path, spec)
    for seed in (0, 1):
        a, b = plain / f"{seed:06d}", printed / f"{seed:06d}"
        for f in SIM_FILES:  # the simulation's files are byte for byte the same
            assert (a / f).read_bytes() == (b / f).read_bytes(), f
        meta = json.loads((b / "module.json").read_text())
        assert meta["printed"]["print_offset_m"] == OFFSET
        # measured with python-fcl on the written STL: the clearance plus the offset
        assert meta["printed"]["clearance_m"] == pytest.approx(1e-3 + OFFSET, abs=1e-6)
        assert meta["checks"]["clearance_m"] == pytest.approx(1e-3, abs=1e-6)
        # every vertex of the printed module off its moved hole planes is a vertex of the
        # plain module off the hole planes, and the other way round
        geom = build_module(sample_params(SamplerConfig(), seed))
        va, vb = read_stl_mm(a / "module.stl").vertices, read_stl_mm(b / "module.stl").vertices
        rest_a = va[~_on_planes(va, geom.hole_planes)]
        rest_b = vb[~_on_planes(vb, offset_planes(geom.hole_planes, OFFSET))]
        key = lambda v: {tuple(np.round(x, 9)) for x in v}  # noqa: E731
        assert key(rest_a) == key(rest_b) and len(rest_a) > 8
        moved = vb[_on_planes(vb, offset_planes(geom.hole_planes, OFFSET))]
        assert len(moved) > 0 and not _on_planes(moved, geom.hole_planes).any()
    assert check_dataset(tmp_path / "printed").ok


def test_an_assembly_prints_its_holes_wider_and_simulates_them_exact(tmp_path) -> None:
    spec = DatasetSpec("a", 0, 1, ProfileSampler(shapes=("cross",)), family="profile")
    plain, printed = _two(tmp_path, spec)
    a, b = plain / "000000", printed / "000000"
    for f in ("peg.stl", "assembly.xml", "assembly.usda"):  # the peg has no hole
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
    assert (a / "base.stl").read_bytes() != (b / "base.stl").read_bytes()
    meta = json.loads((b / "module.json").read_text())
    (step,) = meta["printed"]["steps"]
    assert step["clearance_m"] == pytest.approx(1e-3 + OFFSET, abs=1e-6)  # on the written STL
    assert meta["checks"]["steps"][0]["clearance_m"] == pytest.approx(1e-3, abs=1e-6)
    assert check_dataset(tmp_path / "printed").ok


def test_an_offset_past_the_clearance_is_refused_and_nothing_written(tmp_path) -> None:
    out = tmp_path / "d"
    p = cli("sample", "--n", "1", "--out", str(out), "--print-offset", "1.5")
    err = p.stderr.strip().splitlines()
    assert p.returncode != 0 and len(err) == 1 and "printed peg would not fit" in err[0], p.stderr
    assert "1 mm" in err[0] and not out.exists()
    with pytest.raises(DatasetError, match="print offset -1 mm"):
        DatasetSpec("x", 0, 1, print_offset=-1e-3).validate()


def test_the_offset_is_part_of_the_spec() -> None:
    spec = DatasetSpec("x", 0, 1, print_offset=OFFSET)
    d = spec.to_json()
    assert d["print_offset_m"] == OFFSET and DatasetSpec.from_json(d) == spec
    assert "print_offset_m" not in DatasetSpec("x", 0, 1).to_json()  # earlier specs unchanged
