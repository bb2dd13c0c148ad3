"""USD export of an assembly for Isaac Sim (PhysX): one self-contained stage, every part.

Stage: Z up, metersPerUnit = 1, kilogramsPerUnit = 1, defaultPrim `/assembly`.

```
/assembly                Xform, kind component
    base                 Xform (static): surface (visual Mesh) and pieces/ (convex colliders)
    <part> ...           Xform at the part's design pose: RigidBodyAPI + MassAPI (mass, centre
                         of mass, principal moments and axes); its frame is the part frame
        surface          Mesh, the part's closed surface (visual)
        pieces/piece_000 Mesh, convex collider (convexHull: exact, each piece is convex)
    steps/entrance_<part>, steps/bottom_<part>   Xforms: each step's frames
    physics_material     Material + PhysicsMaterialAPI, bound (purpose physics) to every collider
```
A part that is not convex collides as its exact convex pieces (PhysX's own convex
decomposition would approximate it). Authored through the USD API (usd-core): an assembly
has a few hundred prims, a few tens of milliseconds.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdPhysics, UsdShade, Vt

from assetgen.core.frames import Frame
from assetgen.core.mass_properties import MassProperties
from assetgen.core.mesh import Mesh
from assetgen.families.parts import Assembly
from assetgen.formats.usd import MATERIAL

ROOT = "/assembly"
_COLORS = {"base": (0.6, 0.6, 0.62)}
_PART_COLOR = (0.85, 0.45, 0.15)


def _place(prim: UsdGeom.Xformable, frame: Frame) -> None:
    w, x, y, z = (float(c) for c in frame.quat)
    prim.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*map(float, frame.pos)))
    prim.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Quatd(w, x, y, z))


def _mesh(stage: Usd.Stage, path: str, mesh: Mesh, color=None) -> UsdGeom.Mesh:
    m = UsdGeom.Mesh.Define(stage, path)
    points = np.asarray(mesh.vertices, np.float32) + np.float32(0.0)
    m.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    m.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(mesh.faces)))
    m.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(mesh.faces.astype(np.int32).ravel()))
    m.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.stack([points.min(0), points.max(0)])))
    m.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    if color is not None:
        m.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*color)]))
    return m


def assembly_usda(
    assembly: Assembly,
    surfaces: Mapping[str, Mesh],
    pieces: Mapping[str, Sequence[Mesh]],
    mass: Mapping[str, tuple[float, np.ndarray, np.ndarray]],
    friction: tuple[float, float, float] = MATERIAL,
) -> str:
    """The stage as .usda text.

    surfaces : each part's closed surface, part frame (m).
    pieces   : each part's convex pieces, part frame (m).
    mass     : per moving part (kg, COM (3,) m, inertia (3, 3) kg m^2 about the COM).
    friction : (static, dynamic, restitution) of the one physics material (the MJCF's).
    """
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, ROOT)
    stage.SetDefaultPrim(root.GetPrim())
    Usd.ModelAPI(root.GetPrim()).SetKind("component")
    material = UsdShade.Material.Define(stage, f"{ROOT}/physics_material")
    mat = UsdPhysics.MaterialAPI.Apply(material.GetPrim())
    mat.CreateStaticFrictionAttr(friction[0])
    mat.CreateDynamicFrictionAttr(friction[1])
    mat.CreateRestitutionAttr(friction[2])
    for part in (assembly.base, *assembly.parts):
        path = f"{ROOT}/{part.name}"
        xf = UsdGeom.Xform.Define(stage, path)
        _place(xf, Frame.from_matrix(part.pose))
        color = _COLORS.get(part.name, _PART_COLOR)
        _mesh(stage, f"{path}/surface", surfaces[part.name], color)
        UsdGeom.Xform.Define(stage, f"{path}/pieces")
        for i, piece in enumerate(pieces[part.name]):
            m = _mesh(stage, f"{path}/pieces/piece_{i:03d}", piece)
            m.CreatePurposeAttr(UsdGeom.Tokens.guide)
            UsdPhysics.CollisionAPI.Apply(m.GetPrim())
            UsdPhysics.MeshCollisionAPI.Apply(m.GetPrim()).CreateApproximationAttr("convexHull")
            UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).Bind(
                material, UsdShade.Tokens.weakerThanDescendants, "physics"
            )
        if part.name in mass:
            UsdPhysics.RigidBodyAPI.Apply(xf.GetPrim())
            kg, com, inertia = mass[part.name]
            props = MassProperties.checked(kg, com, inertia, part.name)
            moments, axes = props.principal(portable=True)
            api = UsdPhysics.MassAPI.Apply(xf.GetPrim())
            api.CreateMassAttr(float(kg))
            api.CreateCenterOfMassAttr(Gf.Vec3f(*map(float, com)))
            api.CreateDiagonalInertiaAttr(Gf.Vec3f(*map(float, moments)))
            api.CreatePrincipalAxesAttr(Gf.Quatf(*map(float, axes)))
    UsdGeom.Xform.Define(stage, f"{ROOT}/steps")
    for step in assembly.steps:
        for kind, frame in (("entrance", step.entrance), ("bottom", step.bottom)):
            _place(UsdGeom.Xform.Define(stage, f"{ROOT}/steps/{kind}_{step.part}"), frame)
    # Sdf stamps no time or path into the text: the same assembly gives the same bytes
    return stage.GetRootLayer().ExportToString()
