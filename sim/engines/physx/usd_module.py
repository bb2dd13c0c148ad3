"""A module read from its USD file, as a physics engine other than MuJoCo takes it: the
convex collision pieces (the `convex_pieces` variant of the `collider` variant set), the
peg's collision mesh and mass properties, and the task frames.

The MuJoCo simulator reads `module.json` and the STL files; a second engine reads the USD,
so that an engine run also checks what the USD says. `load_usd_module` cross-checks the
frames and the peg's mass against the `ModuleAsset` of the same module and names the file
and prim of any difference. Needs usd-core (the `physx` or `cad` extra).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.assets.loading import AssetError, ModuleAsset

USD_FILE = "peg_in_hole.usda"
PIECES_VARIANT = ("collider", "convex_pieces")
"""The variant set and variant that hold the convex pieces (the default variant is `sdf`)."""


@dataclass(frozen=True)
class UsdModule:
    """What an engine needs of one module, in SI units (the file says metersPerUnit = 1)."""

    path: Path
    pieces: tuple[np.ndarray, ...]
    """Vertices (k, 3) of each convex piece, in the module frame."""
    peg_vertices: np.ndarray
    """(V, 3) the peg's collision mesh vertices, in the peg frame (convexHull)."""
    peg_mass: float
    peg_com: np.ndarray
    """(3,) the peg's centre of mass in the peg frame."""
    peg_inertia_diag: np.ndarray
    """(3,) principal moments about the centre of mass, kg m^2."""
    peg_principal_axes: np.ndarray
    """(4,) w, x, y, z: the principal axes' orientation in the peg frame."""
    peg_design_pose: np.ndarray
    """(4, 4) the peg frame in the module frame as written (the design pose)."""
    entrance: np.ndarray
    bottom: np.ndarray
    static_friction: float
    dynamic_friction: float
    restitution: float


def _matrix(prim, cache) -> np.ndarray:
    # USD matrices are row-vector (translation in the last row): transpose to column form
    return np.array(cache.GetLocalToWorldTransform(prim), dtype=float).T


def _points(prim, where: str) -> np.ndarray:
    from pxr import UsdGeom

    pts = UsdGeom.Mesh(prim).GetPointsAttr().Get()
    if pts is None or len(pts) < 4:
        raise AssetError(f"{where}: prim {prim.GetPath()} has no points (need a closed mesh)")
    return np.array(pts, dtype=float)


def load_usd_module(path: str | Path, asset: ModuleAsset | None = None) -> UsdModule:
    """Read a module's USD (its folder or the file). With `asset` (the same module's
    ModuleAsset), check that the USD's frames and peg mass agree with it (1e-6 m, 1e-6 kg:
    float32 in the file). AssetError naming the file and prim for a file an engine cannot
    use."""
    try:
        from pxr import Usd, UsdGeom, UsdPhysics
    except ModuleNotFoundError as e:
        raise ModuleNotFoundError(
            f"reading USD needs usd-core ({e}): pip install -e '.[physx]'", name=e.name
        ) from e
    path = Path(path)
    if path.is_dir():
        path = path / USD_FILE
    if not path.is_file():
        raise AssetError(f"{path}: no such USD file (the module needs the 'usd' format)")
    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise AssetError(f"{path}: USD could not open it")
    where = str(path)
    if UsdGeom.GetStageMetersPerUnit(stage) != 1.0:
        raise AssetError(f"{where}: metersPerUnit is {UsdGeom.GetStageMetersPerUnit(stage)}, "
                         "expected 1 (SI units)")  # fmt: skip
    root = stage.GetDefaultPrim()
    vset = root.GetVariantSets().GetVariantSet(PIECES_VARIANT[0])
    if PIECES_VARIANT[1] not in vset.GetVariantNames():
        raise AssetError(f"{where}: prim {root.GetPath()} has no '{PIECES_VARIANT[1]}' variant "
                         f"in its '{PIECES_VARIANT[0]}' variant set")  # fmt: skip
    vset.SetVariantSelection(PIECES_VARIANT[1])
    cache = UsdGeom.XformCache()
    module_inv = np.linalg.inv(_matrix(root, cache))

    holder = root.GetChild("collision_pieces")
    pieces = []
    for prim in holder.GetChildren() if holder else []:
        if not prim.HasAPI(UsdPhysics.CollisionAPI):
            continue
        approx = UsdPhysics.MeshCollisionAPI(prim).GetApproximationAttr().Get()
        if approx != "convexHull":
            raise AssetError(f"{where}: prim {prim.GetPath()} has approximation {approx!r}, "
                             "expected 'convexHull'")  # fmt: skip
        m = module_inv @ _matrix(prim, cache)
        v = _points(prim, where)
        pieces.append(v @ m[:3, :3].T + m[:3, 3])
    if not pieces:
        raise AssetError(f"{where}: no collision pieces under {root.GetPath()}/collision_pieces")

    peg = root.GetChild("peg")
    if not peg or not peg.HasAPI(UsdPhysics.MassAPI):
        raise AssetError(f"{where}: prim {root.GetPath()}/peg is missing or has no MassAPI")
    mass_api = UsdPhysics.MassAPI(peg)
    mass = float(mass_api.GetMassAttr().Get())
    com = np.array(mass_api.GetCenterOfMassAttr().Get(), dtype=float)
    diag = np.array(mass_api.GetDiagonalInertiaAttr().Get(), dtype=float)
    q = mass_api.GetPrincipalAxesAttr().Get()
    axes = np.array([q.GetReal(), *q.GetImaginary()], dtype=float)
    if not mass > 0 or not np.all(diag > 0):
        raise AssetError(f"{where}: prim {peg.GetPath()} has mass {mass} and principal "
                         f"moments {diag.tolist()}; both must be positive")  # fmt: skip
    design = module_inv @ _matrix(peg, cache)
    mesh = peg.GetChild("mesh")
    if not mesh:
        raise AssetError(f"{where}: prim {peg.GetPath()}/mesh is missing")
    m = np.linalg.inv(_matrix(peg, cache)) @ _matrix(mesh, cache)
    peg_vertices = _points(mesh, where) @ m[:3, :3].T + m[:3, 3]

    frames = {}
    for name in ("entrance", "bottom"):
        prim = root.GetChild(name)
        if not prim:
            raise AssetError(f"{where}: prim {root.GetPath()}/{name} is missing")
        frames[name] = module_inv @ _matrix(prim, cache)
    mat = root.GetChild("physics_material")
    mat_api = UsdPhysics.MaterialAPI(mat) if mat else None
    if mat_api is None or not mat.HasAPI(UsdPhysics.MaterialAPI):
        raise AssetError(f"{where}: prim {root.GetPath()}/physics_material has no MaterialAPI")
    usd = UsdModule(
        path=path,
        pieces=tuple(pieces),
        peg_vertices=peg_vertices,
        peg_mass=mass,
        peg_com=com,
        peg_inertia_diag=diag,
        peg_principal_axes=axes / np.linalg.norm(axes),
        peg_design_pose=design,
        entrance=frames["entrance"],
        bottom=frames["bottom"],
        static_friction=float(mat_api.GetStaticFrictionAttr().Get()),
        dynamic_friction=float(mat_api.GetDynamicFrictionAttr().Get()),
        restitution=float(mat_api.GetRestitutionAttr().Get()),
    )
    if asset is not None:
        _check_against(usd, asset)
    return usd


def _check_against(usd: UsdModule, asset: ModuleAsset) -> None:
    """AssetError unless the USD says what module.json says (float32 in the file)."""
    for name, got, want in (
        ("entrance", usd.entrance, asset.entrance),
        ("bottom", usd.bottom, asset.bottom),
    ):
        if not np.allclose(got, want, atol=1e-6):
            raise AssetError(f"{usd.path}: {name} differs from module.json by "
                             f"{np.abs(got - want).max():.3g} (re-export the module)")  # fmt: skip
    if abs(usd.peg_mass - asset.peg_mass) > 1e-6 or not np.allclose(
        usd.peg_com, asset.peg_com, atol=1e-6
    ):
        raise AssetError(f"{usd.path}: the peg's mass or centre of mass differs from "
                         "module.json (re-export the module)")  # fmt: skip
