"""A chamfer on the peg's tip: the hole and its exact clearance stay the unchamfered peg's, the
side faces start where module.json says, Table I without it is untouched."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from assetgen.core.stl import parse_stl_mm
from assetgen.dataset.module_writer import generate_module, write_module
from assetgen.formats.registry import EXPORTERS
from assetgen.geometry.solids import ChamferError, build_module, chamfer_inset, peg_planes
from assetgen.params.module_params import ModuleParams, ParamError
from assetgen.params.sampler import SamplerConfig, sample_params
from sim.bench.stress.cases import _cross_section

CHAMFERED = SamplerConfig(peg_chamfer=(0.001, 0.002), peg_chamfer_angle=(0.5, 0.9))


def test_table_one_is_untouched():
    """Without a chamfer, params and sampler configs keep their JSON form and every seed its
    parameters; with one, a seed's other parameters are those it had without."""
    p = sample_params(SamplerConfig(), 5)
    assert "peg_chamfer" not in p.to_json() and "peg_chamfer" not in SamplerConfig().to_json()
    assert ModuleParams.from_json(p.to_json()) == p
    q = sample_params(CHAMFERED, 5)
    assert q.peg_chamfer > 0 and replace(q, peg_chamfer=0.0, peg_chamfer_angle=math.pi / 4) == p
    assert ModuleParams.from_json(q.to_json()) == q
    assert SamplerConfig.from_json(CHAMFERED.to_json()) == CHAMFERED


def _fitting_seed() -> ModuleParams:
    for seed in range(50):
        p = sample_params(CHAMFERED, seed)
        try:
            chamfer_inset(p)
            return p
        except ChamferError:
            continue
    raise AssertionError("no seed takes the chamfer")


def test_the_hole_is_the_unchamfered_pegs_and_the_sides_start_at_the_chamfer(tmp_path):
    p = _fitting_seed()
    plain = replace(p, peg_chamfer=0.0)
    a = write_module(p, 7, tmp_path / "a", tuple(EXPORTERS))
    b = write_module(plain, 7, tmp_path / "b", tuple(EXPORTERS))
    folder_a, folder_b = tmp_path / "a" / "000007", tmp_path / "b" / "000007"
    # the plate, its hole and the measured clearance are the unchamfered peg's
    assert (folder_a / "module.stl").read_bytes() == (folder_b / "module.stl").read_bytes()
    assert a["checks"]["clearance_m"] == pytest.approx(p.clearance, abs=1e-6)
    assert a["checks"]["insertion_min_distance_m"] == pytest.approx(p.clearance, abs=1e-6)
    assert a["checks"]["peg_chamfer"] == {
        "sides_start_m": pytest.approx(p.peg_chamfer),
        "bottom_inset_m": pytest.approx(p.peg_chamfer * math.tan(p.peg_chamfer_angle)),
    }
    assert "peg_chamfer" not in b["checks"]
    assert json.loads((folder_a / "module.json").read_text())["params"]["peg_chamfer"] > 0
    # measured on the written peg: every vertex from the chamfer's top up lies on the peg's
    # side planes; the bottom face's edges lie the inset inside them
    peg = parse_stl_mm((folder_a / "peg.stl").read_bytes())
    planes = peg_planes(p)[:-1]
    height = peg.vertices @ planes[:, :3].T - planes[:, 3]
    z = peg.vertices[:, 2]
    assert np.abs(height[z > p.peg_chamfer - 1e-7].max(axis=1)).max() < 1e-7
    inset = a["checks"]["peg_chamfer"]["bottom_inset_m"]
    base = peg.vertices[z < 1e-9]
    assert len(base) == p.n_vertices
    # each bottom corner sits on two sides' planes moved in by the inset (their normals
    # lean with the taper; the inset is measured in the bottom plane)
    flat = planes[:, :2] / np.linalg.norm(planes[:, :2], axis=1, keepdims=True)
    d0 = planes[:, 3] / np.linalg.norm(planes[:, :2], axis=1)
    gap = d0 - base[:, :2] @ flat.T
    assert np.allclose(np.sort(gap, axis=1)[:, :2], inset, atol=1e-7)
    # the stress benchmark reads the unchamfered peg's sides off the chamfered peg
    # (float32 files: a plane can come twice, a few nm apart)
    ours, theirs = (
        np.column_stack(_cross_section(m)[:2])
        for m in (peg, parse_stl_mm((folder_b / "peg.stl").read_bytes()))
    )
    apart = np.abs(ours[:, None, :] - theirs[None, :, :]).max(axis=2)
    assert apart.min(axis=1).max() < 1e-6 and apart.min(axis=0).max() < 1e-6


def test_a_chamfer_too_long_is_refused_and_a_sampled_one_drawn_again(tmp_path):
    p = replace(sample_params(SamplerConfig(), 3), peg_chamfer=0.008, peg_chamfer_angle=1.0)
    with pytest.raises(ChamferError, match=r"peg_chamfer = 8\.000 mm at 57\.2958 deg moves"):
        build_module(p)
    with pytest.raises(ParamError, match=r"peg_chamfer_angle = 1.2 rad is outside"):
        replace(p, peg_chamfer=0.001, peg_chamfer_angle=1.2).validate()
    wide = SamplerConfig(peg_chamfer=(0.003, 0.004), peg_chamfer_angle=(1.0, 1.0))
    drawn = [generate_module(s, wide, tmp_path, ()) for s in range(6)]
    assert any(r.get("draw") for r in drawn)  # small pegs drawn again, none failed


def test_the_sample_command_takes_a_chamfer_in_mm(tmp_path, capsys):
    from cli import main

    out = tmp_path / "c"
    assert main(["sample", "--n", "2", "--out", str(out), "--peg-chamfer", "1",
                 "--peg-chamfer-deg", "30", "--formats", "mjcf", "--quiet"]) == 0  # fmt: skip
    spec = json.loads((out / "dataset.json").read_text())["spec"]["config"]
    assert spec["peg_chamfer"] == [0.001, 0.001]
    assert spec["peg_chamfer_angle"] == [pytest.approx(math.radians(30))] * 2
    for args, message in (
        (["--peg-chamfer", "x"], "--peg-chamfer x: give a length in mm"),
        (["--peg-chamfer", "2,1"], "--peg-chamfer 2,1: give a length in mm"),
        (["--peg-chamfer", "1", "--family", "profile"], "the profile family has no peg chamfer"),
        (["--peg-chamfer", "1", "--peg-chamfer-deg", "80"], "5 to 60 deg"),
    ):
        capsys.readouterr()
        assert main(["sample", "--n", "1", "--out", str(tmp_path / "x"), *args]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1
        assert not (tmp_path / "x").exists()
