"""USD export: a small synthetic module written, re-opened with pxr and checked."""

from __future__ import annotations

from pathlib import Path

import manifold3d as mf
import numpy as np
import pytest
import trimesh
from pxr import Sdf, Usd, UsdGeom, UsdPhysics, UsdShade, UsdValidation

from assetgen.core.frames import Frame, quat_to_matrix
from assetgen.core.mass_properties import MassProperties
from assetgen.core.mesh import Mesh
from assetgen.formats import usd as usd_export
from assetgen.formats.usd import usda_text, write_usd

MM = 1e-3
CLEARANCE = 1.0 * MM
FLOOR = -25.0 * MM
"""Hole floor height in the module frame (m)."""


def _box(lo: tuple, hi: tuple) -> mf.Manifold:
    """Axis-aligned box from corner `lo` to corner `hi` (m)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    return mf.Manifold.cube(tuple(hi - lo)).translate(tuple(lo))


def _mesh(solid: mf.Manifold) -> Mesh:
    m = solid.to_mesh()
    return Mesh(np.asarray(m.vert_properties, dtype=float)[:, :3], np.asarray(m.tri_verts, int))


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    return quat_to_matrix(q / np.linalg.norm(q))


@pytest.fixture(scope="module")
def module_args() -> dict:
    """A square peg 20 x 20 x 40 mm in a 22 x 22 mm blind hole (1 mm clearance) of a
    150 x 150 x 5 mm plate with a box sleeve below it; pieces are five boxes."""
    peg = _mesh(_box((-10 * MM, -10 * MM, 0), (10 * MM, 10 * MM, 40 * MM)))
    plate = _box((-75 * MM, -75 * MM, -5 * MM), (75 * MM, 75 * MM, 0))
    sleeve = _box((-16 * MM, -16 * MM, FLOOR - 5 * MM), (16 * MM, 16 * MM, 0))
    hole = _box((-11 * MM, -11 * MM, FLOOR), (11 * MM, 11 * MM, 1 * MM))
    module = _mesh((plate + sleeve) - hole)
    pieces = [
        _mesh(_box((-75 * MM, -75 * MM, -5 * MM), (-11 * MM, 75 * MM, 0))),
        _mesh(_box((11 * MM, -75 * MM, -5 * MM), (75 * MM, 75 * MM, 0))),
        _mesh(_box((-11 * MM, 11 * MM, -5 * MM), (11 * MM, 75 * MM, 0))),
        _mesh(_box((-11 * MM, -75 * MM, -5 * MM), (11 * MM, -11 * MM, 0))),
        _mesh(_box((-16 * MM, -16 * MM, FLOOR - 5 * MM), (16 * MM, 16 * MM, FLOOR))),
    ]
    tm = trimesh.Trimesh(peg.vertices, peg.faces, process=False)
    tm.density = 0.2 / tm.volume
    # an inertia of the peg's scale with rotated principal axes, so principalAxes is not
    # the identity and the eigen-decomposition is exercised
    r = _rotation(np.random.default_rng(0))
    inertia = r @ np.diag([2.0, 3.0, 5.0]) @ r.T * np.asarray(tm.moment_inertia).trace() / 10
    yaw = (float(np.cos(0.2)), 0.0, 0.0, float(np.sin(0.2)))  # 0.4 rad about z
    return {
        "peg": peg,
        "module": module,
        "pieces": pieces,
        "entrance": Frame((0.0, 0.0, 0.0), yaw),
        "bottom": Frame((0.0, 0.0, FLOOR), yaw),
        "peg_pose": Frame((0.0, 0.0, FLOOR + CLEARANCE), yaw),
        "peg_mass": 0.2,
        "peg_com": np.asarray(tm.center_mass),
        "peg_inertia": inertia,
        "static_friction": 0.7,
        "dynamic_friction": 0.4,
        "restitution": 0.1,
    }


def _homogeneous(r: np.ndarray, t=(0.0, 0.0, 0.0)) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = r
    m[:3, 3] = t
    return m


@pytest.fixture(scope="module")
def usda(module_args, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("usd") / "peg_in_hole.usda"
    write_usd(path, **module_args)
    return path


def _select(stage: Usd.Stage, variant: str) -> None:
    """Select a collider variant in the session layer, leaving the file as written."""
    stage.SetEditTarget(stage.GetSessionLayer())
    stage.GetPrimAtPath("/module").GetVariantSet("collider").SetVariantSelection(variant)


def _world(stage: Usd.Stage, path: str) -> np.ndarray:
    """(4, 4) column-vector transform of a prim to the stage (Gf is row-vector: transpose)."""
    xf = UsdGeom.Xformable(stage.GetPrimAtPath(path))
    return np.array(xf.ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T


def _raw_schemas(prim: Usd.Prim) -> list[str]:
    """apiSchemas as composed, including names usd-core has no schema for (PhysX's)."""
    return list(prim.GetMetadata("apiSchemas").GetAddedOrExplicitItems())


def test_stage_metadata(usda):
    stage = Usd.Stage.Open(str(usda))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert UsdPhysics.GetStageKilogramsPerUnit(stage) == 1.0
    assert stage.GetDefaultPrim().GetPath() == Sdf.Path("/module")
    assert stage.GetDefaultPrim().GetTypeName() == "Xform"


def test_text_is_canonical_and_deterministic(usda, module_args):
    """Sdf reads the file and writes back the same bytes; the same input gives the same text."""
    text = usda.read_text()
    assert Sdf.Layer.OpenAsAnonymous(str(usda)).ExportToString() == text
    assert usda_text(**module_args) == text


def test_schemas_sdf_variant(usda):
    stage = Usd.Stage.Open(str(usda))
    hole = stage.GetPrimAtPath("/module/hole")
    assert hole.IsA(UsdGeom.Mesh)
    for api in (UsdPhysics.CollisionAPI, UsdPhysics.MeshCollisionAPI, UsdShade.MaterialBindingAPI):
        assert hole.HasAPI(api)
    assert "PhysxSDFMeshCollisionAPI" in _raw_schemas(hole)
    assert UsdPhysics.MeshCollisionAPI(hole).GetApproximationAttr().Get() == "sdf"
    res = hole.GetAttribute("physxSDFMeshCollision:sdfResolution")
    assert res.Get() == usd_export.SDF_RESOLUTION
    # as PhysxSchema declares it: uniform int, a schema attribute (not custom)
    assert res.GetTypeName() == Sdf.ValueTypeNames.Int
    assert res.GetVariability() == Sdf.VariabilityUniform
    assert not res.IsCustom()
    assert UsdPhysics.CollisionAPI(hole).GetCollisionEnabledAttr().Get()
    # the module is static: no rigid body on it or above it
    assert not any(p.HasAPI(UsdPhysics.RigidBodyAPI) for p in (hole, hole.GetParent()))
    assert not stage.GetPrimAtPath("/module/collision_pieces")

    peg = stage.GetPrimAtPath("/module/peg")
    assert peg.IsA(UsdGeom.Xform)
    assert peg.HasAPI(UsdPhysics.RigidBodyAPI) and peg.HasAPI(UsdPhysics.MassAPI)
    mesh = stage.GetPrimAtPath("/module/peg/mesh")
    assert mesh.HasAPI(UsdPhysics.CollisionAPI) and mesh.HasAPI(UsdPhysics.MeshCollisionAPI)
    assert UsdPhysics.MeshCollisionAPI(mesh).GetApproximationAttr().Get() == "convexHull"
    for name in ("entrance", "bottom"):
        assert stage.GetPrimAtPath(f"/module/{name}").IsA(UsdGeom.Xform)


def test_physics_material_bound(usda, module_args):
    stage = Usd.Stage.Open(str(usda))
    material = stage.GetPrimAtPath("/module/physics_material")
    assert material.IsA(UsdShade.Material) and material.HasAPI(UsdPhysics.MaterialAPI)
    api = UsdPhysics.MaterialAPI(material)
    for attr, key in (
        (api.GetStaticFrictionAttr(), "static_friction"),
        (api.GetDynamicFrictionAttr(), "dynamic_friction"),
        (api.GetRestitutionAttr(), "restitution"),
    ):
        assert attr.Get() == pytest.approx(module_args[key], rel=1e-7)
    # every collider of each variant, found by its CollisionAPI, has it for the physics purpose
    n_pieces = len(module_args["pieces"])
    for variant, expected in (("sdf", 2), ("convex_pieces", 1 + n_pieces)):
        _select(stage, variant)
        colliders = [p for p in stage.Traverse() if p.HasAPI(UsdPhysics.CollisionAPI)]
        assert len(colliders) == expected
        for prim in colliders:
            bound, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial("physics")
            assert bound.GetPath() == material.GetPath(), prim.GetPath()


def test_mass_properties(usda, module_args):
    stage = Usd.Stage.Open(str(usda))
    mass = UsdPhysics.MassAPI(stage.GetPrimAtPath("/module/peg"))
    assert mass.GetMassAttr().Get() == pytest.approx(0.2, rel=1e-7)
    com = np.array(mass.GetCenterOfMassAttr().Get())
    np.testing.assert_allclose(com, module_args["peg_com"], atol=1e-8)
    moments = np.array(mass.GetDiagonalInertiaAttr().Get())
    q = mass.GetPrincipalAxesAttr().Get()
    r = quat_to_matrix(np.array([q.GetReal(), *q.GetImaginary()]))
    inertia = module_args["peg_inertia"]
    # float32 storage: agreement to ~1e-7 of the largest moment
    np.testing.assert_allclose(r @ np.diag(moments) @ r.T, inertia, atol=1e-6 * moments.max())


def test_frames_world_transforms(usda, module_args):
    stage = Usd.Stage.Open(str(usda))
    for path, key in (
        ("/module/entrance", "entrance"),
        ("/module/bottom", "bottom"),
        ("/module/peg", "peg_pose"),
        ("/module/peg/mesh", "peg_pose"),  # the peg mesh is in the peg frame
    ):
        np.testing.assert_allclose(
            _world(stage, path), module_args[key].matrix(), atol=1e-9, err_msg=path
        )
    np.testing.assert_allclose(_world(stage, "/module/hole"), np.eye(4), atol=1e-12)


def test_arbitrary_frames_exact(module_args, tmp_path):
    """Random poses come back within 1e-9 (double-precision xformOps)."""
    rng = np.random.default_rng(7)
    frames = {
        k: Frame.from_matrix(_homogeneous(_rotation(rng), rng.uniform(-0.1, 0.1, 3)))
        for k in ("entrance", "bottom", "peg_pose")
    }
    path = tmp_path / "m.usda"
    write_usd(path, **{**module_args, **frames})
    stage = Usd.Stage.Open(str(path))
    for k, f in frames.items():
        name = "peg" if k == "peg_pose" else k
        np.testing.assert_allclose(_world(stage, f"/module/{name}"), f.matrix(), atol=1e-9)


def test_mesh_data(usda, module_args):
    stage = Usd.Stage.Open(str(usda))
    _select(stage, "convex_pieces")
    meshes = [("/module/hole", module_args["module"]), ("/module/peg/mesh", module_args["peg"])]
    meshes += [
        (f"/module/collision_pieces/piece_{i:03d}", p) for i, p in enumerate(module_args["pieces"])
    ]
    for path, m in meshes:
        mesh = UsdGeom.Mesh(stage.GetPrimAtPath(path))
        points = np.array(mesh.GetPointsAttr().Get())
        np.testing.assert_array_equal(points, m.vertices.astype(np.float32), err_msg=path)
        np.testing.assert_array_equal(
            np.array(mesh.GetFaceVertexIndicesAttr().Get()), m.faces.reshape(-1)
        )
        assert list(mesh.GetFaceVertexCountsAttr().Get()) == [3] * len(m.faces)
        extent = np.array(mesh.GetExtentAttr().Get())
        np.testing.assert_array_equal(extent, [points.min(0), points.max(0)])
        assert mesh.GetSubdivisionSchemeAttr().Get() == "none"


def test_variant_switches_colliders(usda, module_args):
    stage = Usd.Stage.Open(str(usda))
    vset = stage.GetPrimAtPath("/module").GetVariantSets().GetVariantSet("collider")
    assert vset.GetVariantNames() == ["convex_pieces", "sdf"]
    assert vset.GetVariantSelection() == "sdf"
    _select(stage, "convex_pieces")
    hole = stage.GetPrimAtPath("/module/hole")
    assert not hole.HasAPI(UsdPhysics.CollisionAPI)
    assert not hole.HasAuthoredMetadata("apiSchemas")  # visual only: no PhysX SDF either
    group = stage.GetPrimAtPath("/module/collision_pieces")
    pieces = list(group.GetChildren())
    assert len(pieces) == len(module_args["pieces"])
    for prim in pieces:
        assert prim.IsA(UsdGeom.Mesh)
        assert prim.HasAPI(UsdPhysics.CollisionAPI) and prim.HasAPI(UsdPhysics.MeshCollisionAPI)
        assert UsdPhysics.MeshCollisionAPI(prim).GetApproximationAttr().Get() == "convexHull"
        assert UsdPhysics.CollisionAPI(prim).GetCollisionEnabledAttr().Get()
        assert UsdGeom.Imageable(prim).ComputePurpose() == UsdGeom.Tokens.guide
        assert not prim.HasAPI(UsdPhysics.RigidBodyAPI)
    # the switch happened in the session layer: the file still selects sdf
    assert Usd.Stage.Open(str(usda)).GetPrimAtPath("/module/hole").HasAPI(UsdPhysics.CollisionAPI)


def _validation_errors(stage: Usd.Stage) -> list[str]:
    """Every registered UsdValidation validator run on the stage; errors and warnings."""
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    assert len(validators) >= 20  # usd-core 26.11 registers 30 (geom, physics, shade, ...)
    errors = UsdValidation.ValidationContext(validators).Validate(stage)
    return [
        f"{e.GetName()}: {e.GetMessage()}"
        for e in errors
        if e.GetType() != UsdValidation.ValidationErrorType.Info
    ]


@pytest.mark.parametrize("variant", ["sdf", "convex_pieces"])
def test_usd_validation_clean(usda, variant):
    stage = Usd.Stage.Open(str(usda))
    _select(stage, variant)
    assert _validation_errors(stage) == []


def test_usd_validation_catches_a_broken_stage(usda):
    """Control: the same validators do report errors, e.g. for a stage without metadata."""
    layer = Sdf.Layer.OpenAsAnonymous(str(usda))
    layer.ClearDefaultPrim()
    layer.pseudoRoot.ClearInfo("upAxis")
    assert len(_validation_errors(Usd.Stage.Open(layer))) >= 2


def test_usdc_matches_usda(usda, module_args, tmp_path):
    path = tmp_path / "m.usdc"
    write_usd(path, **module_args)
    assert path.read_bytes()[:8] == b"PXR-USDC"
    assert Sdf.Layer.OpenAsAnonymous(str(path)).ExportToString() == usda.read_text()


def test_overwrite_replaces_file(module_args, tmp_path):
    path = tmp_path / "m.usda"
    write_usd(path, **module_args)
    write_usd(path, **{**module_args, "static_friction": 0.9})
    stage = Usd.Stage.Open(str(path))
    mat = UsdPhysics.MaterialAPI(stage.GetPrimAtPath("/module/physics_material"))
    assert mat.GetStaticFrictionAttr().Get() == pytest.approx(0.9)
    assert [p.name for p in tmp_path.iterdir()] == ["m.usda"]


def _bad(args: dict, key: str, value) -> dict:
    return {**args, key: value}


def _nan_peg(args):
    v = args["peg"].vertices.copy()
    v[3, 1] = np.nan
    return _bad(args, "peg", Mesh(v, args["peg"].faces))


def _empty_module(args):
    return _bad(args, "module", Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)))


def _piece_out_of_range(args):
    p = args["pieces"][1]
    faces = p.faces.copy()
    faces[0, 0] = len(p.vertices)
    pieces = list(args["pieces"])
    pieces[1] = Mesh(p.vertices, faces)
    return _bad(args, "pieces", pieces)


BAD_INPUTS = {
    "nan vertex": (_nan_peg, r"peg\.vertices.*non-finite.*row 3"),
    "empty mesh": (_empty_module, r"module\.vertices.*non-empty"),
    "face out of range": (_piece_out_of_range, r"pieces\[1\]\.faces.*\[0, 7\]"),
    "no pieces": (lambda a: _bad(a, "pieces", []), r"pieces is empty"),
    "zero mass": (lambda a: _bad(a, "peg_mass", 0.0), r"peg_mass = 0\.0.*> 0"),
    "negative mass": (lambda a: _bad(a, "peg_mass", -0.2), r"peg_mass = -0\.2"),
    "nan com": (lambda a: _bad(a, "peg_com", np.array([0, np.nan, 0])), r"peg_com"),
    "indefinite inertia": (
        lambda a: _bad(a, "peg_inertia", np.diag([1e-5, 1e-5, -1e-5])),
        r"peg_inertia.*principal moments",
    ),
    "asymmetric inertia": (
        lambda a: _bad(a, "peg_inertia", np.array([[1, 1, 0], [0, 1, 0], [0, 0, 1]]) * 1e-5),
        r"peg_inertia is not symmetric",
    ),
    "zero quaternion": (
        lambda a: _bad(a, "bottom", Frame((0, 0, 0), (0, 0, 0, 0))),
        r"bottom\.quat",
    ),
    "restitution > 1": (lambda a: _bad(a, "restitution", 1.5), r"restitution = 1\.5"),
    "negative friction": (lambda a: _bad(a, "static_friction", -0.1), r"static_friction"),
}


@pytest.mark.parametrize("case", list(BAD_INPUTS))
def test_bad_input_raises_and_writes_nothing(module_args, tmp_path, case):
    make, message = BAD_INPUTS[case]
    with pytest.raises(ValueError, match=message):
        write_usd(tmp_path / "m.usda", **make(module_args))
    assert list(tmp_path.iterdir()) == []


def test_bad_paths(module_args, tmp_path):
    with pytest.raises(ValueError, match=r"does not exist; create it first"):
        write_usd(tmp_path / "missing" / "m.usda", **module_args)
    with pytest.raises(ValueError, match=r"suffix '\.txt'"):
        write_usd(tmp_path / "m.txt", **module_args)
    assert list(tmp_path.iterdir()) == []


def test_failed_write_leaves_nothing(module_args, tmp_path, monkeypatch):
    """A failure at the last step leaves no partial or temporary file, and an existing file
    stays as it was."""
    path = tmp_path / "m.usda"

    def fail(*_args, **_kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(usd_export.os, "replace", fail)
    with pytest.raises(OSError, match="disk full"):
        write_usd(path, **module_args)
    assert list(tmp_path.iterdir()) == []

    monkeypatch.undo()
    write_usd(path, **module_args)
    before = path.read_bytes()
    monkeypatch.setattr(usd_export.os, "replace", fail)
    for p in (path, tmp_path / "m.usdc"):
        with pytest.raises(OSError, match="disk full"):
            write_usd(p, **{**module_args, "restitution": 0.5})
    assert [p.name for p in tmp_path.iterdir()] == ["m.usda"]
    assert path.read_bytes() == before


def test_principal_axes_handle_reflections():
    """eigh returns a left-handed basis for diag(3, 2, 1) (moments sorted ascending: axes
    z, y, x); principalAxes must still be a proper rotation that reproduces the tensor."""
    r = _rotation(np.random.default_rng(3))
    for inertia in (np.diag([3.0, 2.0, 1.0]), r @ np.diag([1.0, 2.0, 3.0]) @ r.T):
        moments, q = MassProperties.checked(1.0, np.zeros(3), inertia).principal()
        rot = quat_to_matrix(q)
        np.testing.assert_allclose(rot @ np.diag(moments) @ rot.T, inertia, atol=1e-12)
        np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(rot) == pytest.approx(1.0)
