"""An assembly written to a folder: its files, the MJCF alone in MuJoCo, the 3MF's layout,
the same bytes twice, and nothing left behind by a module that fails its checks."""

from __future__ import annotations

import itertools
import json
import re
import shutil
import zipfile
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from assetgen.dataset.assembly_writer import MJCF_FILE, THREEMF_FILE, USD_FILE, write_assembly
from assetgen.dataset.module_writer import ModuleFailure
from assetgen.families.profile_bolt import ProfileBoltSampler, build_profile_bolt


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    root = tmp_path_factory.mktemp("assemblies")
    params = replace(ProfileBoltSampler().sample(1), slots=False)
    record = write_assembly("profile-bolt", params, build_profile_bolt(params), 1, root)
    return root / "000001", record, params


def test_the_folder_holds_every_part_and_the_steps(written) -> None:
    folder, _, _ = written
    names = sorted(p.name for p in folder.iterdir())
    assert names == sorted(
        ["module.json", "base.stl", "profile.stl", "bolt.stl", THREEMF_FILE, MJCF_FILE, USD_FILE]
    )
    meta = json.loads((folder / "module.json").read_text())
    assert meta["family"] == "profile-bolt"
    assert [s["part"] for s in meta["steps"]] == ["profile", "bolt"]
    assert [s["clearance"] for s in meta["steps"]] == [0.25e-3, 0.5e-3]
    for s, c in zip(meta["checks"]["steps"], (0.25e-3, 0.5e-3), strict=True):
        assert abs(s["clearance_m"] - c) < 1e-6 and s["insertion_min_distance_m"] > c - 1e-6
    assert sorted(meta["files"]) == sorted(n for n in names if n != "module.json")


def test_the_mjcf_loads_alone_with_a_free_body_per_moving_part(written, tmp_path) -> None:
    folder, _, _ = written
    shutil.copy(folder / MJCF_FILE, tmp_path / MJCF_FILE)
    model = mujoco.MjModel.from_xml_path(str(tmp_path / MJCF_FILE))
    assert model.njnt == 2 and model.nu == 12
    for part in ("profile", "bolt"):
        assert model.jnt_type[model.joint(f"{part}_free").id] == mujoco.mjtJoint.mjJNT_FREE
        assert model.site(f"entrance_{part}") and model.site(f"bottom_{part}")
    # in their design poses nothing touches: every gap is a clearance
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.ncon == 0
    # pushed down, the profile rests on the socket floor after its clearance, no further
    for _ in range(200):
        data.xfrc_applied[model.body("profile").id, 2] = -5.0
        mujoco.mj_step(model, data)
    drop = model.body("profile").pos[2] - data.xpos[model.body("profile").id][2]
    assert 0.2e-3 < drop < 0.35e-3


def test_the_usd_holds_a_rigid_body_per_moving_part(written) -> None:
    """The stage reads back (Sdf writes the same text), each moving part is a rigid body
    with its mass at its design pose, and every piece is a convex-hull collider."""
    from pxr import Sdf, Usd, UsdGeom, UsdPhysics

    folder, record, _ = written
    text = (folder / USD_FILE).read_text()
    layer = Sdf.Layer.CreateAnonymous(".usda")
    assert layer.ImportFromString(text) and layer.ExportToString() == text
    stage = Usd.Stage.Open(layer)
    assert UsdGeom.GetStageUpAxis(stage) == "Z" and UsdGeom.GetStageMetersPerUnit(stage) == 1
    for part in ("profile", "bolt"):
        prim = stage.GetPrimAtPath(f"/assembly/{part}")
        assert prim.HasAPI(UsdPhysics.RigidBodyAPI)
        assert UsdPhysics.MassAPI(prim).GetMassAttr().Get() == pytest.approx(0.2)
        pose = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(0)
        step = next(s for s in record["steps"] if s["part"] == part)
        assert np.allclose(np.array(pose)[3, :3], step["design_pose"]["pos"], atol=1e-12)
    assert not stage.GetPrimAtPath("/assembly/base").HasAPI(UsdPhysics.RigidBodyAPI)
    for name, info in record["parts"].items():
        pieces = stage.GetPrimAtPath(f"/assembly/{name}/pieces").GetChildren()
        assert len(pieces) == info["pieces"]
        assert all(
            UsdPhysics.MeshCollisionAPI(p).GetApproximationAttr().Get() == "convexHull"
            for p in pieces
        )


def test_the_3mf_lays_every_part_on_the_bed_apart(written) -> None:
    folder, _, _ = written
    with zipfile.ZipFile(folder / THREEMF_FILE) as z:
        model = z.read("3D/3dmodel.model").decode()
    objects = re.findall(r'<object id="(\d+)" name="(\w+)".*?</object>', model)
    assert [n for _, n in objects] == ["base", "profile", "bolt"]
    boxes = []
    for oid, _ in objects:
        body = re.search(rf'<object id="{oid}".*?</object>', model).group(0)
        v = np.array(re.findall(r'x="([-\d.]+)" y="([-\d.]+)" z="([-\d.]+)"', body), float)
        t = re.search(rf'<item objectid="{oid}" transform="([^"]+)"', model).group(1)
        m = np.array(t.split(), float).reshape(4, 3)
        placed = v @ m[:3] + m[3]
        assert placed[:, 2].min() == pytest.approx(0.0, abs=1e-3)  # resting on the bed
        boxes.append((placed[:, 0].min(), placed[:, 0].max()))
    for (_, hi), (lo, _) in itertools.pairwise(boxes):
        assert lo >= hi + 9.99  # 10 mm apart along x


def test_the_same_assembly_twice_is_the_same_bytes(written, tmp_path) -> None:
    folder, _, params = written
    write_assembly("profile-bolt", params, build_profile_bolt(params), 1, tmp_path)
    for f in folder.iterdir():
        assert (tmp_path / "000001" / f.name).read_bytes() == f.read_bytes(), f.name


def test_a_failing_assembly_leaves_nothing(tmp_path) -> None:
    params = ProfileBoltSampler().sample(2)
    asm = build_profile_bolt(params)
    wrong = replace(asm, steps=(replace(asm.steps[0], clearance=0.3e-3), asm.steps[1]))
    with pytest.raises(ModuleFailure, match=r"step 1 \(profile\)"):
        write_assembly("profile-bolt", params, wrong, 2, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_a_profile_bolt_dataset_through_the_pipeline(tmp_path) -> None:
    """`assetgen sample --family profile-bolt`: the spec names its family, the modules are
    assemblies, a re-run is cached with the same hash, and Table I specs keep their form."""
    from assetgen.dataset.generate import generate
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import DatasetError, DatasetSpec
    from assetgen.families.profile_bolt import ProfileBoltSampler

    spec = DatasetSpec("pb", 10, 2, ProfileBoltSampler(), family="profile-bolt")
    first = generate(tmp_path / "pb", spec, workers=1, progress=False)
    assert first.generated == 2 and not first.failures
    assert first.clearance_min_m == pytest.approx(0.25e-3, abs=1e-6)
    assert first.clearance_max_m == pytest.approx(0.5e-3, abs=1e-6)
    again = generate(tmp_path / "pb", spec, workers=1, progress=False)
    assert again.cached == 2 and again.content_hash == first.content_hash
    ds = Dataset(tmp_path / "pb")
    assert ds.spec.family == "profile-bolt" and ds.module_json("000010")["family"] == "profile-bolt"
    assert "family" not in DatasetSpec("t", 0, 1).to_json()
    # `assetgen check` re-runs the step checks on the files, and finds a damaged one
    from assetgen.dataset.check import check_dataset

    assert check_dataset(tmp_path / "pb").ok
    stl = tmp_path / "pb" / "modules" / "000011" / "profile.stl"
    data = bytearray(stl.read_bytes())
    data[200] ^= 0xFF
    stl.write_bytes(bytes(data))
    assert check_dataset(tmp_path / "pb").corrupt == {
        "000011": "profile.stl does not match its hash"
    }
    with pytest.raises(DatasetError, match=r"unknown family 'nope'; valid families"):
        DatasetSpec.from_json({"name": "x", "seed_start": 0, "count": 1, "family": "nope"})
    with pytest.raises(DatasetError, match=r"family 'profile-bolt' samples with a Profile"):
        DatasetSpec("x", 0, 1, family="profile-bolt").validate()
