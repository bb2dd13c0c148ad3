"""USD export of one module for NVIDIA Isaac Sim (PhysX): a single self-contained stage.

Stage: Z up, metersPerUnit = 1, kilogramsPerUnit = 1, defaultPrim `/module`.

```
/module                  Xform, kind component; variant set `collider`: sdf (default), convex_pieces
    hole                 Mesh, module frame: the module (visual; a static collider in `sdf`)
    peg                  Xform at peg_pose: RigidBodyAPI + MassAPI; its frame is the peg frame
        mesh             Mesh, peg frame: collider, convexHull (exact: the peg is convex)
    entrance             Xform: where the hole axis meets the mounting surface
    bottom               Xform: centre of the hole floor, a seated peg's frame
    physics_material     Material + PhysicsMaterialAPI, bound (purpose physics) to every collider
  variant sdf:
    hole                 + CollisionAPI, MeshCollisionAPI approximation "sdf",
                           PhysxSDFMeshCollisionAPI with its sdfResolution
  variant convex_pieces:
    collision_pieces     Xform
        piece_000 ...    Mesh, module frame, purpose guide: static collider, convexHull
```
In `convex_pieces` the hole mesh carries no collision API at all (rather than a disabled one),
so PhysX neither cooks its SDF nor keeps a dead shape.

PhysX-only schemas are not in usd-core, so they are spelled the way Isaac Sim writes them:
"PhysxSDFMeshCollisionAPI" in the prim's `apiSchemas` list, and the attribute
`uniform int physxSDFMeshCollision:sdfResolution` with the type and variability PhysxSchema
declares. Isaac Sim, which has PhysxSchema, reads them as the applied schema; usd-core keeps
them as they are (unknown schema names are kept in the list, just not reported as applied).

Speed: the stage is written as .usda text from a template, with every number array formatted
by USD itself (str() of a numpy-backed Vt array: the same shortest round-trip digits Sdf
writes), all meshes in one batch: authoring spec by spec through the Sdf API was many times
slower for a module of many pieces. The text is canonical: Sdf reads it back
and writes the same bytes (the tests check this), so it is the file Sdf would write itself.
"""

from __future__ import annotations

import os
import secrets
from functools import lru_cache
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Vt

from assetgen.core.frames import Frame
from assetgen.core.mass_properties import MassProperties
from assetgen.core.mesh import Mesh
from assetgen.core.mujoco_config import material
from assetgen.core.portable import norm

ROOT = "module"
"""Name of the default prim; every path below starts with /module."""
COLLIDER_VARIANT_SET = "collider"
SDF_VARIANT = "sdf"
PIECES_VARIANT = "convex_pieces"
MATERIAL_PATH = f"/{ROOT}/physics_material"
SDF_RESOLUTION = 256
"""PhysX's default. The SDF spacing is the mesh's largest extent over this: 0.59 mm for the
15 cm plate. Distances to flat walls interpolate exactly; only within about one spacing of
an edge does the SDF blur. The convex_pieces variant is exact everywhere."""
SUFFIXES = (".usda", ".usdc", ".usd")
""".usda is written as text directly; .usdc and .usd (crate) go through an Sdf layer."""

_PEG_COLOR = (0.85, 0.45, 0.15)
_MODULE_COLOR = (0.6, 0.6, 0.62)
_COLLIDER_SCHEMAS = ("PhysicsCollisionAPI", "PhysicsMeshCollisionAPI", "MaterialBindingAPI")
_XFORM_OP_ORDER = '["xformOp:translate", "xformOp:orient", "xformOp:scale"]'


# ---------------------------------------------------------------------------------------------
# input checks: everything is checked before anything is written
# ---------------------------------------------------------------------------------------------


def _check_shapes(mesh: Mesh, name: str) -> tuple[np.ndarray, np.ndarray]:
    """`mesh`'s vertices (n, 3) and faces (m, 3) as arrays; ValueError unless both are
    non-empty with the right shapes and dtypes. Values are checked in _format_meshes."""
    v = np.asarray(mesh.vertices)
    f = np.asarray(mesh.faces)
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
        raise ValueError(
            f"{name}.vertices has shape {v.shape}; expected a non-empty (n, 3) array in metres"
        )
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise ValueError(
            f"{name}.faces has shape {f.shape}; expected a non-empty (m, 3) array of triangles"
        )
    if v.dtype.kind not in "iuf":
        raise ValueError(f"{name}.vertices has dtype {v.dtype}; expected float coordinates")
    if f.dtype.kind not in "iu":
        raise ValueError(f"{name}.faces has dtype {f.dtype}; expected integer vertex indices")
    return v, f


def _check_frame(frame: Frame, name: str) -> np.ndarray:
    """Raise ValueError unless `frame` is finite with a non-zero quaternion; return the
    normalised quaternion (4,) (w, x, y, z)."""
    pos = np.asarray(frame.pos, dtype=float)
    quat = np.asarray(frame.quat, dtype=float)
    if pos.shape != (3,) or not np.isfinite(pos).all():
        raise ValueError(f"{name}.pos = {frame.pos!r}; expected 3 finite numbers in metres")
    if quat.shape != (4,) or not np.isfinite(quat).all() or not np.linalg.norm(quat) > 1e-12:
        raise ValueError(
            f"{name}.quat = {frame.quat!r}; expected a finite non-zero quaternion (w, x, y, z)"
        )
    return quat / norm(quat)


MATERIAL = material()
"""The physics material's (static friction, dynamic friction, restitution): the MJCF's."""


def _check_scalar(value: float, name: str, lo: float, hi: float, what: str) -> None:
    try:
        ok = bool(np.isfinite(value) and lo <= value <= hi)
    except TypeError:
        ok = False
    if not ok:
        raise ValueError(f"{name} = {value!r}; {what}")


# ---------------------------------------------------------------------------------------------
# .usda text: values formatted by USD (Gf / Vt str), so they read back bit-exactly
# ---------------------------------------------------------------------------------------------


def _f32(x: float) -> str:
    """A float attribute's value as Sdf writes it (shortest float32 digits)."""
    return str(Vt.FloatArray([float(x)]))[1:-1]


@lru_cache(maxsize=64)
def _counts(m: int) -> str:
    """faceVertexCounts of m triangles; cached, as most pieces share a handful of sizes."""
    return "[" + ", ".join(["3"] * m) + "]"


def _format_meshes(meshes: list[Mesh], names: list[str]) -> list[tuple[str, str, str, str]]:
    """Check every mesh and format its arrays as .usda values: (points, faceVertexCounts,
    faceVertexIndices, extent) per mesh.

    All meshes go through numpy and USD's formatter in one batch, then the text is split per
    mesh: a module has up to ~130 small pieces, and per-mesh calls would cost ~4x as much.
    Raises ValueError naming the mesh for shapes, non-finite values or bad face indices.
    """
    arrays = [_check_shapes(m, n) for m, n in zip(meshes, names, strict=True)]
    nv = np.array([len(v) for v, _ in arrays])
    nf = np.array([len(f) for _, f in arrays])
    v_start = np.concatenate([[0], np.cumsum(nv)])
    f_start = np.concatenate([[0], np.cumsum(nf)])
    # float32, as USD stores points: at 0.1 m that rounds by < 4 nm, far below the clearance;
    # + 0 turns -0 into 0 so the file has no "-0"
    with np.errstate(over="ignore", invalid="ignore"):
        points = np.concatenate([v for v, _ in arrays]).astype(np.float32) + np.float32(0.0)
    bad = ~np.isfinite(points).all(axis=1)
    if bad.any():
        row = int(np.argmax(bad))
        k = int(np.searchsorted(v_start, row, side="right")) - 1
        raise ValueError(
            f"{names[k]}.vertices has a non-finite value (NaN, inf, or beyond float32 range) "
            f"at row {row - v_start[k]}; pass finite coordinates in metres"
        )
    faces = np.concatenate([f for _, f in arrays])
    limit = np.repeat(nv, nf)[:, None]  # each face's mesh's vertex count
    bad = ((faces < 0) | (faces >= limit)).any(axis=1)
    if bad.any():
        k = int(np.searchsorted(f_start, int(np.argmax(bad)), side="right")) - 1
        f = arrays[k][1]
        raise ValueError(
            f"{names[k]}.faces has indices in [{f.min()}, {f.max()}] but only {nv[k]} "
            f"vertices; every index must lie in [0, {nv[k] - 1}]"
        )
    # extent of the float32 points themselves, so it bounds exactly what is stored
    extent = np.empty((2 * len(meshes), 3), dtype=np.float32)
    extent[0::2] = np.minimum.reduceat(points, v_start[:-1], axis=0)
    extent[1::2] = np.maximum.reduceat(points, v_start[:-1], axis=0)
    # USD's own formatting (shortest round-trip digits, as Sdf writes), split per element
    p_txt = str(Vt.Vec3fArray.FromNumpy(points))[2:-2].split("), (")
    i_txt = str(Vt.IntArray.FromNumpy(faces.astype(np.int32).reshape(-1)))[1:-1].split(", ")
    e_txt = str(Vt.Vec3fArray.FromNumpy(extent))[2:-2].split("), (")
    # Python ints: slicing lists with numpy integers is several times slower
    vs, fs = v_start.tolist(), (3 * f_start).tolist()
    return [
        (
            "[(" + "), (".join(p_txt[vs[k] : vs[k + 1]]) + ")]",
            _counts((fs[k + 1] - fs[k]) // 3),
            "[" + ", ".join(i_txt[fs[k] : fs[k + 1]]) + "]",
            f"[({e_txt[2 * k]}), ({e_txt[2 * k + 1]})]",
        )
        for k in range(len(meshes))
    ]


def _xform(
    name: str, pos: tuple, quat: np.ndarray, schemas: tuple = (), props: tuple = ()
) -> list[str]:
    """Opening lines of an Xform at (pos, quat): translate, orient, scale in double precision,
    Isaac Sim's standard op stack, exact to 1e-16 so frames read back as given. `props` are
    property lines that sort before "xformOp"; the caller adds children and the closing
    brace."""
    head = [f'def Xform "{name}"']
    if schemas:
        head = [f'def Xform "{name}" (', f"    prepend apiSchemas = {_tokens(schemas)}", ")"]
    w, x, y, z = (float(c) for c in quat)
    return [
        *head,
        "{",
        *props,
        f"    quatd xformOp:orient = {Gf.Quatd(w, x, y, z)}",
        "    double3 xformOp:scale = (1, 1, 1)",
        f"    double3 xformOp:translate = {Gf.Vec3d(*(float(c) for c in pos))}",
        f"    uniform token[] xformOpOrder = {_XFORM_OP_ORDER}",
    ]


def _tokens(items: tuple) -> str:
    return "[" + ", ".join(f'"{t}"' for t in items) + "]"


def _collider(approximation: str, schemas: tuple = (), extra: tuple = ()) -> tuple:
    """(apiSchemas, property lines) that make a Mesh a collider: CollisionAPI +
    MeshCollisionAPI with `approximation`, and the physics material bound. `extra` are lines
    that sort after physics:approximation and before points."""
    props = (
        # the physics purpose: what PhysX reads for friction and restitution
        f"    rel material:binding:physics = <{MATERIAL_PATH}> (",
        '        bindMaterialAs = "weakerThanDescendants"',
        "    )",
        f'    uniform token physics:approximation = "{approximation}"',
        *extra,
    )
    return _COLLIDER_SCHEMAS + schemas, props


def _mesh(
    name: str,
    arrays: tuple[str, str, str, str],
    collider: tuple | None,
    color: tuple | None = None,
    purpose: str | None = None,
) -> list[str]:
    """Lines of a Mesh prim; `arrays` from _format_meshes, `collider` from _collider (None:
    visual only). Properties come in Sdf's (sorted) order, so the text is canonical."""
    points, counts, indices, extent = arrays
    schemas, collider_props = collider if collider is not None else ((), ())
    head = [f'def Mesh "{name}"']
    if schemas:
        head = [f'def Mesh "{name}" (', f"    prepend apiSchemas = {_tokens(schemas)}", ")"]
    lines = [
        *head,
        "{",
        f"    float3[] extent = {extent}",
        f"    int[] faceVertexCounts = {counts}",
        f"    int[] faceVertexIndices = {indices}",
        *collider_props,
        f"    point3f[] points = {points}",
    ]
    if color is not None:
        lines += [
            f"    color3f[] primvars:displayColor = [{Gf.Vec3f(*color)}] (",
            '        interpolation = "constant"',
            "    )",
        ]
    if purpose is not None:
        lines.append(f'    uniform token purpose = "{purpose}"')
    # polygonal, not a subdivision cage (USD's fallback, catmullClark, would round it)
    lines += ['    uniform token subdivisionScheme = "none"', "}"]
    return lines


_FIELD = "\x00"
"""Marks a field in a template: never in .usda text, which is printable."""


@lru_cache(maxsize=1)
def _piece_template() -> tuple[str, ...]:
    """A convex piece's text (depth 4) split at its fields: name, extent, faceVertexCounts,
    faceVertexIndices, points. Built by _mesh itself, so pieces and other meshes cannot
    drift apart; filling it is cheaper than rebuilding ~20 lines per piece."""
    fields = (_FIELD,) * 4
    text = _block(_mesh(_FIELD, fields, _collider("convexHull"), purpose="guide"), 4)
    return tuple(text.split(_FIELD))


def _block(lines: list[str], level: int) -> str:
    """`lines` as one string, indented `level` steps (4 spaces each, as Sdf writes)."""
    pad = "    " * level
    return pad + ("\n" + pad).join(lines)


def _usda(
    arrays: list[tuple[str, str, str, str]],
    frames: dict[str, tuple[tuple, np.ndarray]],
    mass: float,
    com: np.ndarray,
    moments: np.ndarray,
    axes: np.ndarray,
    friction: tuple[float, float, float],
    sdf_resolution: int,
) -> str:
    """The stage as .usda text, from checked inputs; `arrays` holds the formatted module,
    peg and pieces, in that order. Each block is built at its final depth (one join each)."""
    # The collider choice is a variant set. The hole mesh itself is only visual; the `sdf`
    # variant makes it a collider. In `convex_pieces` it has no collision API at all, so
    # PhysX neither cooks its SDF nor keeps a disabled shape, and the pieces collide instead.
    # The module is static: no rigid body above it, so PhysX makes static colliders.
    hole_schemas, hole_props = _collider(
        "sdf",
        ("PhysxSDFMeshCollisionAPI",),
        # the type and variability PhysxSchema declares, so Isaac Sim takes it as the schema's
        (f"    uniform int physxSDFMeshCollision:sdfResolution = {int(sdf_resolution)}",),
    )
    hole_over = [
        'over "hole" (',
        f"    prepend apiSchemas = {_tokens(hole_schemas)}",
        ")",
        "{",
        *hole_props,
        "}",
    ]
    peg_pos, peg_quat = frames["peg_pose"]
    mass_props = (
        f"    point3f physics:centerOfMass = {Gf.Vec3f(*(float(c) for c in com))}",
        f"    float3 physics:diagonalInertia = {Gf.Vec3f(*(float(c) for c in moments))}",
        f"    float physics:mass = {_f32(mass)}",
        f"    quatf physics:principalAxes = {Gf.Quatf(*(float(c) for c in axes))}",
    )
    peg_xf = _xform("peg", peg_pos, peg_quat, ("PhysicsRigidBodyAPI", "PhysicsMassAPI"), mass_props)
    static, dynamic, restitution = friction
    material = [
        'def Material "physics_material" (',
        '    prepend apiSchemas = ["PhysicsMaterialAPI"]',
        ")",
        "{",
        f"    float physics:dynamicFriction = {_f32(dynamic)}",
        f"    float physics:restitution = {_f32(restitution)}",
        f"    float physics:staticFriction = {_f32(static)}",
        "}",
    ]

    # guide: the pieces collide but are not rendered over the visual module mesh
    s0, s1, s2, s3, s4, s5 = _piece_template()
    pieces = "\n\n".join(
        f"{s0}piece_{i:03d}{s1}{extent}{s2}{counts}{s3}{indices}{s4}{points}{s5}"
        for i, (points, counts, indices, extent) in enumerate(arrays[2:])
    )
    parts = [
        "#usda 1.0",
        "(",
        '    defaultPrim = "module"',
        '    doc = "Peg-in-hole module: peg, plate with blind hole, task frames."',
        "    kilogramsPerUnit = 1",
        "    metersPerUnit = 1",
        '    upAxis = "Z"',
        ")",
        "",
        f'def Xform "{ROOT}" (',
        '    kind = "component"',
        "    variants = {",
        f'        string {COLLIDER_VARIANT_SET} = "{SDF_VARIANT}"',
        "    }",
        f'    prepend variantSets = "{COLLIDER_VARIANT_SET}"',
        ")",
        "{",
        _block(_mesh("hole", arrays[0], None, color=_MODULE_COLOR), 1),
        "",
        _block(peg_xf, 1),
        "",
        # the peg is convex, so its hull is the peg itself: no clearance is lost
        _block(_mesh("mesh", arrays[1], _collider("convexHull"), color=_PEG_COLOR), 2),
        "    }",
        "",
        _block([*_xform("entrance", *frames["entrance"]), "}"], 1),
        "",
        _block([*_xform("bottom", *frames["bottom"]), "}"], 1),
        "",
        _block(material, 1),
        f'    variantSet "{COLLIDER_VARIANT_SET}" = {{',
        f'        "{PIECES_VARIANT}" {{',
        '            def Xform "collision_pieces"',
        "            {",
        pieces,
        "            }",
        "",
        "        }",
        f'        "{SDF_VARIANT}" {{',
        _block(hole_over, 3),
        "",
        "        }",
        "    }",
        "}",
        "",
        "",
    ]
    return "\n".join(parts)


# ---------------------------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------------------------


def usda_text(
    *,
    peg: Mesh,
    module: Mesh,
    pieces: list[Mesh],
    entrance: Frame,
    bottom: Frame,
    peg_pose: Frame,
    peg_mass: float,
    peg_com: np.ndarray,
    peg_inertia: np.ndarray,
    static_friction: float = MATERIAL[0],
    dynamic_friction: float = MATERIAL[1],
    restitution: float = MATERIAL[2],
    sdf_resolution: int = SDF_RESOLUTION,
) -> str:
    """The module's stage as .usda text; arguments as in write_usd.

    For callers that write (and hash) the bytes themselves: `usda_text(...).encode()` is
    exactly what write_usd writes to a .usda path. Raises ValueError for bad input.
    """
    if len(pieces) == 0:
        raise ValueError("pieces is empty; pass the module's convex collision pieces")
    arrays = _format_meshes(
        [module, peg, *pieces], ["module", "peg", *(f"pieces[{i}]" for i in range(len(pieces)))]
    )
    frames = {
        n: (tuple(float(c) for c in f.pos), _check_frame(f, n))
        for n, f in (("entrance", entrance), ("bottom", bottom), ("peg_pose", peg_pose))
    }
    props = MassProperties.checked(peg_mass, peg_com, peg_inertia)
    com = props.com
    moments, axes = props.principal()
    for value, n in ((static_friction, "static_friction"), (dynamic_friction, "dynamic_friction")):
        _check_scalar(value, n, 0.0, np.inf, "expected a finite friction coefficient >= 0")
    _check_scalar(restitution, "restitution", 0.0, 1.0, "expected a restitution in [0, 1]")
    if isinstance(sdf_resolution, bool) or not isinstance(sdf_resolution, int | np.integer):
        raise ValueError(f"sdf_resolution = {sdf_resolution!r}; expected an integer > 1")
    _check_scalar(sdf_resolution, "sdf_resolution", 2, 2**20, "expected an integer > 1")
    return _usda(
        arrays,
        frames,
        float(peg_mass),
        com,
        moments,
        axes,
        (float(static_friction), float(dynamic_friction), float(restitution)),
        int(sdf_resolution),
    )


def write_usd(
    path: Path,
    *,
    peg: Mesh,
    module: Mesh,
    pieces: list[Mesh],
    entrance: Frame,
    bottom: Frame,
    peg_pose: Frame,
    peg_mass: float,
    peg_com: np.ndarray,
    peg_inertia: np.ndarray,
    static_friction: float = MATERIAL[0],
    dynamic_friction: float = MATERIAL[1],
    restitution: float = MATERIAL[2],
    sdf_resolution: int = SDF_RESOLUTION,
) -> None:
    """Write the module as one USD stage for Isaac Sim, atomically.

    path             : .usda (text), .usdc or .usd (binary crate); its folder must exist.
    peg              : the peg in the peg frame (origin at the centre of its bottom face, z its
                       axis), metres.
    module           : plate with sleeve and hole in the module frame (origin at the centre of
                       the plate's top surface, z up), metres.
    pieces           : convex pieces whose union is the module, module frame, metres.
    entrance, bottom : task frames in the module frame.
    peg_pose         : the peg frame in the module frame (the design pose: seated, clearance on
                       every face).
    peg_mass         : kg, > 0.
    peg_com          : (3,) centre of mass in the peg frame, metres.
    peg_inertia      : (3, 3) inertia about the COM, peg-frame axes, kg m^2, positive definite.
    static_friction, dynamic_friction : >= 0; restitution in [0, 1]: one physics material,
                       bound to every collider.
    sdf_resolution   : PhysX SDF resolution of the hole collider (see SDF_RESOLUTION).

    The file goes to a temporary name in the same folder and is renamed into place, so `path`
    is either the complete new file or untouched. Raises ValueError for bad input.
    """
    path = Path(path)
    if path.suffix not in SUFFIXES:
        raise ValueError(f"path {str(path)!r} has suffix {path.suffix!r}; use one of {SUFFIXES}")
    if not path.parent.is_dir():
        raise ValueError(
            f"folder {str(path.parent)!r} of path {str(path)!r} does not exist; create it first"
        )
    text = usda_text(
        peg=peg,
        module=module,
        pieces=pieces,
        entrance=entrance,
        bottom=bottom,
        peg_pose=peg_pose,
        peg_mass=peg_mass,
        peg_com=peg_com,
        peg_inertia=peg_inertia,
        static_friction=static_friction,
        dynamic_friction=dynamic_friction,
        restitution=restitution,
        sdf_resolution=sdf_resolution,
    )
    # hidden and unique per call (parallel writers); same suffix, so Sdf picks the same format
    tmp = path.with_name(f".{path.stem}.tmp-{secrets.token_hex(6)}{path.suffix}")
    try:
        if path.suffix == ".usda":
            with open(tmp, "xb") as f:
                f.write(text.encode())
        else:
            layer = Sdf.Layer.CreateAnonymous(".usda")
            if not layer.ImportFromString(text) or not layer.Export(str(tmp)):
                raise OSError(f"USD could not write {str(tmp)!r}")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
