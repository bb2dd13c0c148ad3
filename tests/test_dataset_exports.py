"""Every exported module of a generated dataset: USD validates, MJCF loads and inserts."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pxr import Usd, UsdGeom, UsdPhysics

from assetgen.core.frames import Frame
from assetgen.dataset.reader import Dataset

from .test_usd_export import _select, _validation_errors


def _modules(root):
    ds = Dataset(root)
    return [(mid, ds.paths(mid), ds.module_json(mid)) for mid in ds.ids]


def test_every_usd_opens_and_validates(tiny_dataset):
    for mid, paths, meta in _modules(tiny_dataset):
        stage = Usd.Stage.Open(str(paths["usd"]))
        assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z, mid
        assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
        assert UsdPhysics.GetStageKilogramsPerUnit(stage) == 1.0
        assert stage.GetDefaultPrim().GetPath() == "/module"
        peg = stage.GetPrimAtPath("/module/peg")
        assert peg.HasAPI(UsdPhysics.RigidBodyAPI) and peg.HasAPI(UsdPhysics.MassAPI)
        assert UsdPhysics.MassAPI(peg).GetMassAttr().Get() == pytest.approx(0.2)
        for name in ("entrance", "bottom"):
            xf = UsdGeom.Xformable(stage.GetPrimAtPath(f"/module/{name}"))
            m = np.array(xf.ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
            want = Frame.from_json(meta["frames"][name]).matrix()
            assert np.allclose(m, want, atol=1e-9), (mid, name)
        for variant in ("sdf", "convex_pieces"):
            _select(stage, variant)
            assert _validation_errors(stage) == [], (mid, variant)
        pieces = stage.GetPrimAtPath("/module/collision_pieces")
        n = meta["collision"]["pieces"]
        assert pieces and len(pieces.GetChildren()) == n


SIX_FILES = {
    "module.json",
    "peg.stl",
    "module.stl",
    "peg_in_hole.3mf",
    "peg_in_hole.xml",
    "peg_in_hole.usda",
}


def test_a_module_is_six_files_with_hashes(tiny_dataset):
    for _, paths, meta in _modules(tiny_dataset):
        folder = paths["module_json"].parent
        assert {p.name for p in folder.iterdir()} == SIX_FILES
        assert all(p.is_file() for p in folder.iterdir())
        assert set(meta["files"]) == SIX_FILES - {"module.json"}
        assert all(len(h) == 64 for h in meta["files"].values())
        assert json.loads(paths["module_json"].read_text())["files"] == meta["files"]


def test_the_mjcf_loads_alone_from_an_empty_folder(tiny_dataset, tmp_path):
    """Copied alone anywhere, the MJCF loads (inline meshes) and its meshes are the
    simulator's: the ones it reads are the same arrays as peg.stl's read-back."""
    import shutil

    import mujoco

    from assetgen.core.stl import read_stl_mm
    from sim.assets.loading import load_module

    _, paths, meta = _modules(tiny_dataset)[0]
    alone = tmp_path / "empty"
    alone.mkdir()
    shutil.copy(paths["mjcf"], alone / "copied.xml")
    model = mujoco.MjModel.from_xml_path(str(alone / "copied.xml"))
    assert model.nmesh == model.ngeom == meta["collision"]["pieces"] + 1
    asset = load_module(paths["module_json"].parent)
    peg = read_stl_mm(paths["peg_stl"])
    assert np.array_equal(asset.peg.vertices, peg.vertices)
    assert np.array_equal(asset.peg.faces, peg.faces)


def test_every_mjcf_loads_and_the_peg_drops_onto_the_floor(tiny_dataset):
    import mujoco

    from assetgen.physics.mjcf_checks import drop_test, side_push_test

    for mid, paths, meta in _modules(tiny_dataset):
        model = mujoco.MjModel.from_xml_path(str(paths["mjcf"]))
        assert model.ngeom == meta["collision"]["pieces"] + 1, mid
        drop = drop_test(paths["mjcf"], duration=5.0)
        assert drop["reached_floor"], mid
        assert drop["rest_distance"] < 0.2e-3, (mid, drop)
        assert drop["max_penetration"] < 0.1e-3, (mid, drop)
        push = side_push_test(paths["mjcf"])
        assert not push["passed_through"], (mid, push)


@pytest.fixture(scope="module")
def physics_checks(tiny_dataset) -> dict[str, dict]:
    from assetgen.physics.report import check_module

    return {mid: check_module(paths["mjcf"]) for mid, paths, _ in _modules(tiny_dataset)}


@pytest.mark.parametrize("index", [0, 1, 2, 3, 4, 5])
def test_every_mjcf_holds_the_peg_against_faces_and_corners(physics_checks, index) -> None:
    """Held down the axis (weight + 3 N), a peg pushed with 5 N towards each side
    face of the hole rests within the clearance + 0.1 mm along the push (the free travel
    towards a face from the seated pose is at most the clearance), < 0.1 mm deep; pushed
    towards each corner and 8 even directions it never goes through a wall and rests
    < 0.1 mm deep, and every push comes to rest (the 5 ms physics of version 1 left nearly
    every module with a push bouncing in a limit cycle: docs/physics.md). (Its move beyond
    the free travel is reported by physics_report, not bounded: wedged into a corner of
    half-angle b, a wall penetration p shows as p / sin b along the push.)"""
    mid = sorted(physics_checks)[index]
    r = physics_checks[mid]
    assert r["passed_through"] == 0, (mid, r)
    assert r["unsettled"] == 0, (mid, r)
    assert r["drop_rest_error"] < 0.2e-3 and r["drop_penetration"] < 0.1e-3, (mid, r)
    assert r["seated_free_over_clearance"] < 5e-6, (mid, r)  # geometry; float32 STL
    assert r["face_move_over_clearance"] < 0.1e-3, (mid, r)
    assert r["face_move_over_free"] < 0.1e-3, (mid, r)
    assert r["face_penetration_at_rest"] < 0.1e-3, (mid, r)
    assert r["penetration_at_rest"] < 0.1e-3, (mid, r)


def test_physics_report_in_parallel_gives_the_same_figures(tiny_dataset, tmp_path):
    from assetgen.physics.report import report

    outs = []
    for workers in (1, 2):
        out = tmp_path / f"physics_{workers}.json"
        report(tiny_dataset, limit=2, json_out=out, workers=workers)
        doc = json.loads(out.read_text())
        for figures in doc["modules"].values():
            figures.pop("seconds")
        outs.append(doc)
    assert outs[0] == outs[1] and len(outs[0]["modules"]) == 2
    assert outs[0]["complete"] is True


def test_physics_report_stopped_part_way_keeps_the_modules_it_checked(
    tiny_dataset, tmp_path, monkeypatch
):
    from assetgen.physics import report as physics_report

    figures = {k: 0.0 for k in physics_report.LIMITS} | {"passed_through": 0.0, "unsettled": 0.0}
    seen = []

    def check(path):
        seen.append(path)
        if len(seen) == 3:
            raise KeyboardInterrupt  # the user stops it at the third module
        return figures

    monkeypatch.setattr(physics_report, "check_module", check)
    monkeypatch.setattr(physics_report, "SAVE_EVERY", 2)
    out = tmp_path / "physics.json"
    with pytest.raises(KeyboardInterrupt):
        physics_report.report(tiny_dataset, limit=4, json_out=out, workers=1)
    doc = json.loads(out.read_text())
    assert doc["complete"] is False and sorted(doc["modules"]) == ["000000", "000001"]
