"""Chamfers on the peg's tip and around the hole's entrance: the exact clearance holds below
them, the checks say where they start, the collision pieces still make up the module, and
Table I without them is untouched."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from assetgen.checks.module_checks import CheckError
from assetgen.collision import exact
from assetgen.collision.pieces import collision_pieces
from assetgen.core.stl import parse_stl_mm
from assetgen.dataset.module_writer import generate_module, write_module
from assetgen.formats.registry import EXPORTERS
from assetgen.geometry.solids import (
    HOLE_CAP_Z,
    ChamferError,
    build_module,
    chamfer_inset,
    insertion_travel,
    peg_planes,
)
from assetgen.params.module_params import ModuleParams, ParamError
from assetgen.params.sampler import SamplerConfig, sample_params
from sim.bench.stress.cases import _cross_section

CHAMFERED = SamplerConfig(peg_chamfer=(0.001, 0.002), peg_chamfer_angle=(0.5, 0.9))


def test_table_one_is_untouched():
    """Without a chamfer, params and sampler configs keep their JSON form and every seed its
    parameters; with one, a seed's other parameters are those it had without."""
    p = sample_params(SamplerConfig(), 5)
    for key in ("peg_chamfer", "hole_chamfer"):
        assert key not in p.to_json() and key not in SamplerConfig().to_json()
    both = replace(CHAMFERED, hole_chamfer=(0.001, 0.002))
    r = sample_params(both, 5)
    assert replace(r, hole_chamfer=0.0, hole_chamfer_angle=math.pi / 4) == sample_params(
        CHAMFERED, 5
    )
    assert ModuleParams.from_json(r.to_json()) == r
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


HOLE = SamplerConfig(hole_chamfer=(0.001, 0.004), hole_chamfer_angle=(0.4, 0.7))


def _resid(points: np.ndarray, planes: np.ndarray) -> np.ndarray:
    return (points @ planes[:, :3].T - planes[:, 3]).max(axis=1)


def test_the_entrance_chamfer_opens_above_its_depth_and_the_clearance_holds_below(tmp_path):
    p = sample_params(HOLE, 4)
    r = write_module(p, 4, tmp_path, tuple(EXPORTERS))
    assert r["checks"]["clearance_m"] == pytest.approx(p.clearance, abs=1e-6)
    assert r["checks"]["insertion_min_distance_m"] == pytest.approx(p.clearance, abs=1e-6)
    width = p.hole_chamfer * math.tan(p.hole_chamfer_angle)
    assert r["checks"]["hole_chamfer"] == {
        "depth_m": pytest.approx(p.hole_chamfer),
        "width_m": pytest.approx(width),
    }
    # on the written plate: no vertex inside the chamfered hole, and each side's widened
    # entrance edge is there, `width` out from the side's plane on the surface (s units)
    g = build_module(p)
    module = parse_stl_mm((tmp_path / "000004" / "module.stl").read_bytes())
    v = module.vertices
    s = v @ g.hole_planes[:-1, :3].T - g.hole_planes[:-1, 3]
    opening = np.maximum(0.0, math.tan(p.hole_chamfer_angle) * (v[:, 2:3] + p.hole_chamfer))
    inside = (s - opening).max(axis=1) < -1e-7
    below = v @ g.hole_planes[-1, :3] - g.hole_planes[-1, 3] < -1e-7
    assert not (inside & below).any()
    on_surface = np.abs(v[:, 2]) < 1e-9
    for i in range(len(g.hole_planes) - 1):
        assert np.isclose(s[on_surface, i], width, atol=1e-7).sum() >= 2
    # the same module without the chamfer keeps the exact faces everywhere
    plain = write_module(replace(p, hole_chamfer=0.0), 4, tmp_path / "plain", ())
    assert "hole_chamfer" not in plain["checks"]


@pytest.mark.parametrize("seed", [0, 2, 9])
def test_the_pieces_still_fill_the_module_around_a_chamfered_entrance(seed):
    """Points of the module near the entrance, 2 um off its faces, each inside a piece."""
    g = build_module(sample_params(HOLE, seed))
    p = g.params
    _, systems = exact.exact_decomposition(g)
    rng = np.random.default_rng(seed)
    r = p.circumradius + 0.012
    pts = np.array(g.entrance.pos) + rng.uniform([-r, -r, -0.012], [r, r, 0.0], (40000, 3))
    t, half = p.plate_thickness, p.plate_size / 2
    plate = np.maximum(np.abs(pts[:, :2]).max(axis=1) - half,
                       np.maximum(pts[:, 2], -t - pts[:, 2]))  # fmt: skip
    solid = np.minimum(plate, _resid(pts, g.sleeve_planes))
    cap = np.array([[0.0, 0.0, 1.0, HOLE_CAP_Z]])
    hole = _resid(pts, np.vstack([g.hole_planes, cap]))
    bevel = _resid(pts, np.vstack([g.hole_chamfer_planes, cap, [[0, 0, -1.0, p.hole_chamfer]]]))
    q = pts[(solid < -2e-6) & (np.minimum(hole, bevel) > 2e-6)]
    assert len(q) > 5000
    best = np.min([_resid(q, s) for s in systems], axis=0)
    assert (best <= 1e-9).all()
    # and a piece dropped leaves points uncovered: the test sees a gap
    assert (np.min([_resid(q, s) for s in systems[1:]], axis=0) > 1e-9).any()


def test_pieces_that_ignore_the_chamfer_are_refused(monkeypatch):
    g = build_module(sample_params(HOLE, 2))
    collision_pieces(g, insertion_travel(g))  # as built: accepted
    monkeypatch.setattr(exact, "_beyond_chamfer", lambda cells, chamfer: cells)
    with pytest.raises(CheckError, match="outside the module"):
        collision_pieces(g, insertion_travel(g))


def test_an_entrance_chamfer_too_wide_or_deep_is_refused(tmp_path, capsys):
    from cli import main

    p = sample_params(SamplerConfig(), 3)
    with pytest.raises(ParamError, match=r"hole_chamfer = 4 mm at 60 deg widens the entrance"):
        replace(p, hole_chamfer=0.004, hole_chamfer_angle=math.radians(60)).validate()
    with pytest.raises(ParamError, match=r"hole_chamfer = 0.006 m is outside .* within the plate"):
        replace(p, hole_chamfer=0.006).validate()
    with pytest.raises(ParamError, match="unbuildable module: hole_chamfer"):
        SamplerConfig(hole_chamfer=(0.001, 0.005)).validate()
    out = tmp_path / "h"
    assert main(["sample", "--n", "2", "--out", str(out), "--hole-chamfer", "1,2",
                 "--formats", "mjcf", "--print-offset", "0.2", "--quiet"]) == 0  # fmt: skip
    config = json.loads((out / "dataset.json").read_text())["spec"]["config"]
    assert config["hole_chamfer"] == [0.001, 0.002]
    capsys.readouterr()
    # the stress benchmark aims at the unchamfered entrance's edges: refused, in one line
    assert main(["bench", "contacts", str(out), "--limit", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "its holes' entrances are chamfered" in err and len(err.splitlines()) == 1
    assert main(["sample", "--n", "1", "--out", str(tmp_path / "x"), "--hole-chamfer", "5"]) == 2
    err = capsys.readouterr().err.strip()
    assert "widens the entrance" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "x").exists()


def test_multi_peg_tips_chamfered_over_the_unchamfered_holes(tmp_path):
    """The carrier's pegs get the chamfer, the plate keeps its bytes (each hole is its
    unchamfered peg's) and the clearance its measure; the other parameters of a seed stay."""
    from assetgen.dataset.families import family
    from assetgen.families.multi_peg import MultiPegParams, MultiPegSampler

    fam = family("multi-peg")
    plain = MultiPegSampler()
    chamfered = replace(plain, peg_chamfer=(0.0008, 0.0012), peg_chamfer_angle=(0.6, 0.7))
    assert "peg_chamfer" not in plain.to_json() and "peg_chamfer" not in plain.sample(1).to_json()
    p = chamfered.sample(1)
    assert replace(p, peg_chamfer=0.0, peg_chamfer_angle=math.pi / 4) == plain.sample(1)
    assert MultiPegParams.from_json(p.to_json()) == p
    a = fam.write(1, chamfered, tmp_path / "a", ("mjcf",), None, 0.0)
    fam.write(1, plain, tmp_path / "b", ("mjcf",), None, 0.0)
    folder_a, folder_b = tmp_path / "a" / "000001", tmp_path / "b" / "000001"
    assert (folder_a / "base.stl").read_bytes() == (folder_b / "base.stl").read_bytes()
    assert a["checks"]["steps"][0]["clearance_m"] == pytest.approx(p.clearance, abs=1e-6)
    # the tips: the carrier's lowest vertices lie the inset inside their peg's sides
    carrier = parse_stl_mm((folder_a / "carrier.stl").read_bytes())
    tips = carrier.vertices[carrier.vertices[:, 2] < carrier.vertices[:, 2].min() + 1e-9]
    assert len(tips) == sum(n for _, _, n, _, _ in p.pegs)
    x, y, n, r, _ = p.pegs[0]
    inradius = r * math.cos(math.pi / n)
    reference = tips[np.hypot(tips[:, 0] - x, tips[:, 1] - y) < r]
    assert len(reference) == n
    assert np.allclose(np.hypot(reference[:, 0] - x, reference[:, 1] - y) * math.cos(math.pi / n),
                       inradius - p.chamfer_inset, atol=1e-7)  # fmt: skip
    with pytest.raises(ParamError, match="the smallest peg takes"):
        replace(plain, peg_chamfer=(0.001, 0.004)).validate()


def test_multi_peg_entrance_chamfers_open_every_hole(tmp_path):
    """Every hole's entrance opens as Table I's does; the pegs keep their bytes and the
    clearance its measure; a range two neighbouring holes could not take is refused."""
    from assetgen.dataset.families import family
    from assetgen.families.multi_peg import MultiPegSampler, build_multi_peg

    fam = family("multi-peg")
    plain = MultiPegSampler()
    chamfered = replace(plain, hole_chamfer=(0.001, 0.0015), hole_chamfer_angle=(0.7, 0.7))
    p = chamfered.sample(2)
    assert replace(p, hole_chamfer=0.0, hole_chamfer_angle=math.pi / 4) == plain.sample(2)
    a = fam.write(2, chamfered, tmp_path / "a", ("mjcf",), None, 0.0)
    fam.write(2, plain, tmp_path / "b", ("mjcf",), None, 0.0)
    folder_a, folder_b = tmp_path / "a" / "000002", tmp_path / "b" / "000002"
    assert (folder_a / "carrier.stl").read_bytes() == (folder_b / "carrier.stl").read_bytes()
    assert a["checks"]["steps"][0]["clearance_m"] == pytest.approx(p.clearance, abs=1e-6)
    # on the written plate's surface, each side of each hole has its widened edge, g L out
    base = parse_stl_mm((folder_a / "base.stl").read_bytes())
    top = base.vertices[np.abs(base.vertices[:, 2]) < 1e-9]
    holes = build_multi_peg(replace(p, hole_chamfer=0.0)).base.holes
    opening = math.tan(p.hole_chamfer_angle) * p.hole_chamfer
    step = json.loads((folder_a / "module.json").read_text())["steps"][0]
    axis = _axis(np.array(step["bottom"]["quat"]))
    for hole in holes:
        sides = hole[np.abs(hole[:, :3] @ axis) < 1e-9]  # the faces along the axis
        s = top @ sides[:, :3].T - sides[:, 3]
        near = (s < opening + 1e-6).all(axis=1)  # the surface's points on this hole's rim
        assert (np.isclose(s[near], opening, atol=1e-7).sum(axis=0) >= 2).all()
    with pytest.raises(ParamError, match="two holes 4 mm apart take at most"):
        replace(plain, hole_chamfer=(0.001, 0.003)).validate()


def _axis(quat: np.ndarray) -> np.ndarray:
    """The z axis of a (w, x, y, z) rotation."""
    w, x, y, z = quat
    return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])
