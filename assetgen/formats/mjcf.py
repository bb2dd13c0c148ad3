"""MJCF (MuJoCo) export of one module: static convex pieces, a free peg, frames as sites.

The file `peg_in_hole.xml` is self-contained: the peg and the convex collision pieces are
inline mesh data (assetgen.core.inline_mesh: the STL files' own float32 millimetre numbers,
with scale 0.001), so it loads alone, from any folder, in MuJoCo, its viewer or MuJoCo Warp.
Everything else in it is SI (metres, kilograms, seconds).

- The module is a set of static convex mesh geoms in the worldbody (MuJoCo collides a mesh
  as its convex hull, which is why the module comes as an exact convex decomposition). They
  have contype 0 and conaffinity 1, the peg contype 1 and conaffinity 0, so pieces collide
  with the peg only, never with each other.
- The peg is the body `peg` on a free joint (`peg_free`); its body frame IS the peg frame:
  origin at the centre of the bottom face, z along the axis. MuJoCo recentres a mesh geom on
  its centroid and principal axes, but it does that by moving the geom inside the body, never
  the body frame, and the inertia is given explicitly (`<inertial>`: mass, pos = COM,
  fullinertia about the COM in the peg frame), so the free joint's qpos is the peg pose.
- Sites: `entrance` and `bottom` (worldbody, the module's frames) and `peg_bottom` (on the
  peg at its frame origin). The clearance is stored as `<numeric name="clearance">`, so the
  file alone is enough for the checks in `assetgen.physics.mjcf_checks`.
- Gravity is 0: in the task the peg is held by a manipulator standing on the module's body.

Physics: the file carries the project's one MuJoCo configuration, the simulator's
(assetgen.core.mujoco_config.PhysicsConfig): its option block, contact solref/solimp at the
nominal damping ratio and friction, and the simulator's six velocity actuators on
`peg_bottom` (reference: the site `origin`), with gains from the peg's mass properties. With
command 0 (the default) they are the damper that holds the peg as the task's controller
does; ctrl is a velocity in the module frame (m/s, rad/s). `assetgen physics` thus checks
the physics agents train on.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from assetgen.checks.closed_mesh import CONVEX_TOLERANCE, check_closed_meshes
from assetgen.core.frames import Frame
from assetgen.core.inline_mesh import (
    PEG_MESH,
    mesh_element,
    piece_name,
    read_inline_meshes,
    same_mesh,
    stored,
)
from assetgen.core.mass_properties import MassProperties
from assetgen.core.mesh import Mesh
from assetgen.core.mujoco_config import (
    PhysicsConfig,
    actuator_xml,
    geom_default_xml,
    option_xml,
    physics_for,
    physics_version_xml,
    velocity_gains,
)
from assetgen.core.portable import norm
from assetgen.core.xml_text import xml_number, xml_vector

__all__ = [
    "CONVEX_TOLERANCE",
    "PhysicsConfig",
    "mjcf_document",
    "piece_name",
    "write_mjcf",
]
CLEARANCE_NUMERIC = "clearance"
"""Name of the `<numeric>` custom field holding the clearance (m)."""
PEG_BODY = "peg"
PEG_JOINT = "peg_free"
PEG_GEOM = "peg"
SITES = ("entrance", "bottom", "peg_bottom", "origin")
ORIGIN_SITE = "origin"
"""World site at the module origin: the actuators' reference frame (velocities in the module
frame), as the simulator's `ref_site`."""


# ---------------------------------------------------------------------------------------------
# input checks: everything is checked before anything is written
# ---------------------------------------------------------------------------------------------


def _check_frame(frame: Frame, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Finite position (3,) m and normalised quaternion (4,) (w, x, y, z), or ValueError."""
    pos = np.asarray(frame.pos, dtype=float)
    quat = np.asarray(frame.quat, dtype=float)
    if pos.shape != (3,) or not np.isfinite(pos).all():
        raise ValueError(f"{name}.pos = {frame.pos!r}; expected 3 finite numbers in metres")
    if quat.shape != (4,) or not np.isfinite(quat).all() or not np.linalg.norm(quat) > 1e-9:
        raise ValueError(
            f"{name}.quat = {frame.quat!r}; expected a finite non-zero quaternion (w, x, y, z)"
        )
    return pos, quat / norm(quat)


# ---------------------------------------------------------------------------------------------
# XML text: deterministic (assetgen.core.xml_text: repr of floats, the shortest round trip)
# ---------------------------------------------------------------------------------------------


def mjcf_text(
    *,
    peg: Mesh,
    pieces: Sequence[Mesh],
    entrance: Frame,
    bottom: Frame,
    peg_pose: Frame,
    peg_mass: float,
    peg_com: np.ndarray,
    peg_inertia: np.ndarray,
    clearance: float,
    contact: PhysicsConfig,
) -> str:
    """The MJCF document as text (arguments as in `write_mjcf`, already validated)."""
    c = contact
    ent_pos, ent_quat = _check_frame(entrance, "entrance")
    bot_pos, bot_quat = _check_frame(bottom, "bottom")
    peg_pos, peg_quat = _check_frame(peg_pose, "peg_pose")
    props = MassProperties.checked(peg_mass, peg_com, peg_inertia)
    com, inertia = props.com, props.inertia
    full = [
        inertia[0, 0],
        inertia[1, 1],
        inertia[2, 2],
        inertia[0, 1],
        inertia[0, 2],
        inertia[1, 2],
    ]
    kv_lin, kv_rot = velocity_gains(float(peg_mass), com, inertia, c)
    site_size = xml_number(max(clearance, 0.5e-3))
    lines = [
        '<mujoco model="peg_in_hole">',
        "  <!-- assetgen: units m, kg, s; the inline meshes are millimetres (scale 0.001).",
        "       Module frame = world frame; the body `peg` has the peg frame as its frame. -->",
        '  <compiler angle="radian" inertiafromgeom="false"/>',
        *option_xml(c),
        "  <custom>",
        f'    <numeric name="{CLEARANCE_NUMERIC}" data="{xml_number(clearance)}"/>',
        physics_version_xml(),
        "  </custom>",
        "  <default>",
        f'    <geom type="mesh" {geom_default_xml(c)}/>',
        f'    <site size="{site_size}" rgba="1 0.3 0.1 1"/>',
        '    <default class="module">',
        '      <geom contype="0" conaffinity="1" group="1" rgba="0.6 0.6 0.65 1"/>',
        "    </default>",
        '    <default class="peg">',
        '      <geom contype="1" conaffinity="0" priority="1" rgba="0.2 0.5 0.9 1"/>',
        "    </default>",
        "  </default>",
        "  <asset>",
        "    " + mesh_element(PEG_MESH, peg),
    ]
    lines += ["    " + mesh_element(piece_name(i), p) for i, p in enumerate(pieces)]
    lines += [
        "  </asset>",
        "  <worldbody>",
        f'    <site name="entrance" pos="{xml_vector(ent_pos)}" quat="{xml_vector(ent_quat)}"/>',
        f'    <site name="bottom" pos="{xml_vector(bot_pos)}" quat="{xml_vector(bot_quat)}"/>',
        f'    <site name="{ORIGIN_SITE}" pos="0 0 0"/>',
    ]
    for i in range(len(pieces)):
        lines.append(f'    <geom name="{piece_name(i)}" class="module" mesh="{piece_name(i)}"/>')
    lines += [
        f'    <body name="{PEG_BODY}" pos="{xml_vector(peg_pos)}" quat="{xml_vector(peg_quat)}">',
        f'      <freejoint name="{PEG_JOINT}"/>',
        f'      <inertial pos="{xml_vector(com)}" mass="{xml_number(peg_mass)}" '
        f'fullinertia="{xml_vector(full)}"/>',
        f'      <geom name="{PEG_GEOM}" class="peg" mesh="{PEG_MESH}"/>',
        '      <site name="peg_bottom" pos="0 0 0"/>',
        "    </body>",
        "  </worldbody>",
        *actuator_xml("peg_bottom", ORIGIN_SITE, kv_lin, kv_rot),
        "</mujoco>",
        "",
    ]
    return "\n".join(lines)


def write_mjcf(path: Path, **document) -> bytes:
    """Write the module's MJCF to `path` atomically after checking every input.

    path       : the .xml to write (self-contained: it names no other file).
    **document : mjcf_document's arguments.

    Raises ValueError as mjcf_document does; nothing is written then. A temporary name in
    the same folder is renamed onto `path`, so a half-written XML never carries the final
    name. Returns the bytes written (to hash without reading the file back).
    """
    path = Path(path)
    data = mjcf_document(name=path.name, **document)
    tmp = path.parent / f".{path.stem}.{os.getpid()}.tmp.xml"
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return data


def mjcf_document(
    *,
    peg: Mesh,
    pieces: Sequence[Mesh],
    entrance: Frame,
    bottom: Frame,
    peg_pose: Frame,
    peg_mass: float,
    peg_com: np.ndarray,
    peg_inertia: np.ndarray,
    clearance: float,
    contact: PhysicsConfig | None = None,
    name: str = "the MJCF",
) -> bytes:
    """The module's MJCF as bytes, after checking every input and compiling it in MuJoCo.

    peg         : the peg surface (m, peg frame).
    pieces      : the convex collision pieces (m, module frame).
    entrance, bottom : the module's frames (module frame, m, quat w x y z).
    peg_pose    : initial pose of the peg frame in the module frame.
    peg_mass    : kg.  peg_com: (3,) m, peg frame.  peg_inertia: (3, 3) kg m^2 about the
                  COM, axes of the peg frame.
    clearance   : m, stored in the file for the physics checks.
    contact     : the MuJoCo configuration; None: the simulator's for this clearance
                  (assetgen.core.mujoco_config.physics_for).
    name        : how error messages name the document.

    The meshes are stored as float32 millimetres (assetgen.core.inline_mesh.stored: pass
    them stored already, as the module writer does, and they are written unchanged). The
    document is read back, and its meshes must equal the stored ones bit for bit and each be
    a closed convex solid (MuJoCo collides a mesh as its convex hull); then MuJoCo compiles
    it. Raises ValueError naming the mesh or value and the problem (not closed, not convex,
    bad frame or mass properties, or a model MuJoCo refuses).
    """
    if not (isinstance(clearance, int | float | np.floating) and 0 < clearance < 0.1):
        raise ValueError(f"clearance = {clearance!r}; expected a gap in metres, 0 < c < 0.1")
    contact = (contact or physics_for(float(clearance))).validate()
    if not pieces:
        raise ValueError("pieces is empty; the module needs at least one collision piece")
    for what, m in [("peg", peg), *((piece_name(i), p) for i, p in enumerate(pieces))]:
        v = np.asarray(m.vertices, dtype=float)
        if v.ndim != 2 or v.shape[1] != 3 or not np.isfinite(v).all():
            raise ValueError(f"{name}: mesh {what!r} needs finite (n, 3) vertices in metres")
    meshes = stored([peg, *pieces])
    text = mjcf_text(
        peg=meshes[0],
        pieces=meshes[1:],
        entrance=entrance,
        bottom=bottom,
        peg_pose=peg_pose,
        peg_mass=peg_mass,
        peg_com=peg_com,
        peg_inertia=peg_inertia,
        clearance=float(clearance),
        contact=contact,
    )
    names = [PEG_MESH, *(piece_name(i) for i in range(len(pieces)))]
    model = verified_model(text, dict(zip(names, meshes, strict=True)), name)
    _check_compiled(model, peg_pose)
    return text.encode("utf-8")


def verified_model(text: str, meshes: dict[str, Mesh], name: str) -> mujoco.MjModel:
    """Check an MJCF document holding `meshes` inline (stored, by name, in file order) and
    compile it: its meshes must read back bit for bit and each be a closed convex solid
    (MuJoCo collides a mesh as its convex hull), then MuJoCo must accept the model.
    ValueError naming `name` and the mesh or the problem otherwise."""
    back = read_inline_meshes(text, name)
    if list(back) != list(meshes) or not all(same_mesh(back[n], m) for n, m in meshes.items()):
        raise ValueError(f"{name}: its inline meshes do not read back as written")
    # every mesh is a convex solid, checked on what the file holds
    check_closed_meshes(list(back.values()), list(back), convex=True)
    try:
        spec = mujoco.MjSpec.from_string(text)
        # MuJoCo's mesh thread pool off: for ~30 small meshes the threads cost more than they
        # save, and a dataset's workers already fill the cores. The model is the same.
        spec.compiler.usethread = False
        return spec.compile()
    except ValueError as e:
        raise ValueError(f"{name}: MuJoCo refuses the model: {e}") from None


def _check_compiled(model: mujoco.MjModel, peg_pose: Frame) -> None:
    """The compiled peg body sits exactly at peg_pose (MuJoCo may move geoms, not bodies)."""
    body = model.body(PEG_BODY)
    pos, quat = _check_frame(peg_pose, "peg_pose")
    if (
        np.abs(body.pos - pos).max() > 1e-12
        or min(np.abs(body.quat - quat).max(), np.abs(body.quat + quat).max()) > 1e-9
    ):
        raise ValueError(
            f"compiled peg body frame {body.pos}, {body.quat} is not peg_pose {pos}, {quat}"
        )
