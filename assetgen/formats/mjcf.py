"""MJCF (MuJoCo) export of one module: static convex pieces, a free peg, frames as sites.

The file `peg_in_hole.xml` sits in the module folder beside `peg.stl` and `collision/`, and
names them by relative path, so the folder can be moved as a whole. Everything in it is SI
(metres, kilograms, seconds); the STL files are millimetres and are read with scale 0.001.

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

Contact softness is the point of `ContactConfig`: with MuJoCo's defaults a 0.2 kg peg sinks
0.3 - 0.4 mm into the floor under 5 N, a third of the 1 mm clearance. The defaults below were
measured with `assetgen.physics.mjcf_checks` (see ContactConfig and tests/test_mjcf_export.py).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from assetgen.checks.closed_mesh import CONVEX_TOLERANCE, check_closed_meshes
from assetgen.core.frames import Frame
from assetgen.core.mesh import Mesh
from assetgen.core.portable import norm
from assetgen.core.stl import merge_vertices, parse_stl_triangles_mm

MM = 0.001
"""Metres per STL unit (the STL files are millimetres)."""
__all__ = [
    "CONVEX_TOLERANCE",
    "ContactConfig",
    "mjcf_document",
    "read_checked_mesh",
    "write_mjcf",
]
CLEARANCE_NUMERIC = "clearance"
"""Name of the `<numeric>` custom field holding the clearance (m)."""
PEG_BODY = "peg"
PEG_JOINT = "peg_free"
PEG_GEOM = "peg"
SITES = ("entrance", "bottom", "peg_bottom")


@dataclass(frozen=True)
class ContactConfig:
    """MuJoCo physics and contact settings written into the MJCF (SI units).

    Goal: a 0.2 kg peg pressed into a wall or the floor with ~5 N sinks far less than the
    1 mm clearance, and stays put (no chatter), at the paper's 200 Hz. With MuJoCo's
    defaults (solref 0.02, solimp 0.9/0.95) it sinks 0.3 - 0.4 mm. Steady penetration of a
    contact row with constant impedance d, time constant T and damping ratio z under an
    unconstrained acceleration a into the surface is  r = a (1 - d) T^2 z^2  (MuJoCo docs),
    shared among the rows that hold the peg. T >= 2 x timestep keeps the spring stable under
    the standard integrators (refsafe would clamp a smaller T anyway), so stiffness has to
    come from d; but a too stiff contact (d >= 0.995, or impratio 10, or a pyramidal cone)
    chatters where the peg is wedged into a V between two walls: each wall's push moves the
    peg off the other, the contact is lost for a step, and the next step under the full
    force drives it ~0.6 mm in. The defaults are the stiffest measured to settle everywhere.

    Measured (assetgen.physics.mjcf_checks, 5 N, speed-guarded approach, orientation held) on the
    64 modules of seeds 0-23 and 100-139 at friction 0.3, 0.5 and 1.0: every push settled,
    none passed a wall; at rest the floor penetration (weight + 5 N) <= 27 um and the wall
    penetration <= 33 um (<= 0.1 mm in the worst of 16 directions: a squashed triangle
    wedged into its 22 deg corner, which multiplies the normal force ~5x); on the 20 x 20 mm
    test peg 20 um (floor) and 7 um (wall). With 20 N (the sim's force limit): <= 83 um.
    MuJoCo's defaults on the same modules: 0.41 mm (floor), 0.26 mm (wall). At friction 0.1
    some tapered pegs pushed sideways with no axial force climb their sloped walls out of the
    hole (an allowed motion, reported as not settled). Candidates that chattered in some of
    those pushes: d = 0.99 with z = 1 (8 of 192), d = 0.995 with z = 1.5 (7), impratio 10
    (7), the discrete integrator (T = h or 2h).
    """

    timestep: float = 0.005
    """Physics step, s: 200 Hz, the paper's physics rate."""
    integrator: str = "implicitfast"
    """MuJoCo's recommended integrator: Euler's cost, implicit velocity damping for any
    controller a simulator adds. Measured identical to Euler here (no damping in this file);
    MuJoCo 4's `discrete` chattered in V corners at friction 0.3 with T = h and T = 2h."""
    solver: str = "Newton"
    """Constraint solver: converges in a few iterations on these small problems."""
    iterations: int = 50
    """Solver iterations per step at most (Newton stops far earlier when converged)."""
    solref: tuple[float, float] = (0.01, 1.5)
    """(time constant s, damping ratio). T = 2 x timestep: the stiffest spring the standard
    integrators take (refsafe clamps to it). Damping ratio 1.5 (overdamped, k lower by 1.5^2):
    the penetration is removed without overshoot, so the peg does not lose contact; about
    as stiff with damping ratio 1 (d = 0.98 or 0.97) still chattered in 1 - 2 of 192."""
    solimp: tuple[float, float, float, float, float] = (0.99, 0.99, 0.001, 0.5, 2.0)
    """(dmin, dmax, width m, midpoint, power): constant impedance 0.99, so the penetration is
    linear in the force (width is then irrelevant): (1 - d) T^2 z^2 is 9 - 18x smaller than
    with MuJoCo's defaults (0.9 - 0.95, T = 0.02). 0.995 chattered (see above)."""
    friction: tuple[float, float, float] = (0.5, 0.005, 0.0001)
    """(sliding, torsional, rolling) friction: 0.5 sliding is typical of printed plastics
    (the simulator randomises it per reset anyway; 0.1 - 1.0 was measured)."""
    condim: int = 3
    """Contact dimensionality: normal + 2 tangential (sliding friction). Flat faces rest on
    several contact points (multiccd), which resist twisting without torsional friction."""
    margin: float = 0.0
    """Contact margin, m. Kept 0: a margin makes the constraint act before the surfaces touch,
    holding the peg `margin` off every wall (the clearance shrinks by it), and 20 - 50 um
    margins did not stop the chatter of stiffer settings."""
    cone: str = "elliptic"
    """Friction cone: elliptic is Coulomb's cone. Pyramidal let pushed pegs chatter and go
    through walls with these stiff contacts."""
    impratio: float = 1.0
    """Frictional-to-normal impedance ratio (elliptic cones). 10 (stiffer friction) chattered
    at friction 0.3; the price of 1 is slow creep along a wall under a sideways load
    (~0.1 mm/s at friction 1), harmless to the clearance."""
    noslip_iterations: int = 0
    """Extra no-slip solver passes: 5 - 10 did not settle the stiffer settings and left larger
    resting penetrations; off."""
    multiccd: bool = True
    """Several contact points per convex pair, so a flat face rests flat instead of rocking on
    one point (enabled by default in MuJoCo 4, written explicitly for 3.x)."""

    def validate(self) -> ContactConfig:
        """Raise ValueError naming each out-of-range field; return self."""
        bad = []
        if not (np.isfinite(self.timestep) and self.timestep > 0):
            bad.append(f"timestep = {self.timestep!r} (expected > 0 s)")
        if self.integrator not in ("Euler", "RK4", "implicit", "implicitfast", "discrete"):
            bad.append(f"integrator = {self.integrator!r} (a MuJoCo integrator name)")
        if self.solver not in ("Newton", "CG", "PGS"):
            bad.append(f"solver = {self.solver!r} (Newton, CG or PGS)")
        if self.cone not in ("elliptic", "pyramidal"):
            bad.append(f"cone = {self.cone!r} (elliptic or pyramidal)")
        if len(self.solref) != 2 or not self.solref[0] > 0 or not self.solref[1] > 0:
            bad.append(f"solref = {self.solref!r} (time constant > 0, damping ratio > 0)")
        elif self.integrator != "discrete" and self.solref[0] < 2 * self.timestep - 1e-12:
            bad.append(
                f"solref[0] = {self.solref[0]!r} s (must be >= 2 x timestep = "
                f"{2 * self.timestep!r} s, or MuJoCo's contact spring goes unstable)"
            )
        imp = self.solimp
        if len(imp) != 5 or not (0 < imp[0] < 1 and 0 < imp[1] < 1 and imp[2] >= 0):
            bad.append(f"solimp = {imp!r} (0 < dmin, dmax < 1, width >= 0, midpoint, power)")
        if len(self.friction) != 3 or min(self.friction) < 0:
            bad.append(f"friction = {self.friction!r} (three values >= 0)")
        if self.condim not in (1, 3, 4, 6):
            bad.append(f"condim = {self.condim!r} (1, 3, 4 or 6)")
        if not self.margin >= 0:
            bad.append(f"margin = {self.margin!r} (>= 0 m)")
        if not self.impratio >= 1:
            bad.append(f"impratio = {self.impratio!r} (>= 1)")
        if self.iterations < 1 or self.noslip_iterations < 0:
            bad.append("iterations must be >= 1 and noslip_iterations >= 0")
        if bad:
            raise ValueError("ContactConfig: " + "; ".join(bad))
        return self


# ---------------------------------------------------------------------------------------------
# input checks: everything is checked before anything is written
# ---------------------------------------------------------------------------------------------


def read_checked_mesh(path: Path, name: str, *, convex: bool = True) -> Mesh:
    """Read a binary millimetre STL as a Mesh (metres) and check it is a closed solid.

    Raises ValueError naming `name` (the path as written in the MJCF) when the file is
    missing, unreadable or corrupt, not watertight, inconsistently wound, has no positive
    volume, or (with `convex`) is not convex within CONVEX_TOLERANCE.
    """
    (mesh,) = checked_meshes({name: _read(path, name)}, convex=convex)
    return mesh


def checked_meshes(
    data: Mapping[str, bytes],
    *,
    convex: bool = True,
    parsed: Mapping[str, np.ndarray] | None = None,
) -> list[Mesh]:
    """The binary millimetre STL bytes in `data` (by name) as Meshes (metres), each checked to
    be a closed (and with `convex`, convex) solid, all at once; ValueError names a bad one.
    `parsed` may hold the triangles of some of them, already parsed from these bytes."""
    names = list(data)
    parsed = parsed or {}
    tris = []
    for name in names:
        if name in parsed:
            tris.append(parsed[name])
            continue
        try:
            tris.append(parse_stl_triangles_mm(data[name], name))
        except ValueError as e:
            raise ValueError(f"{name}: corrupt STL: {e}") from None
    meshes = merge_vertices(tris)
    check_closed_meshes(meshes, names, convex=convex)
    return meshes


def _read(path: Path, name: str) -> bytes:
    try:
        return Path(path).read_bytes()
    except FileNotFoundError:
        raise ValueError(f"{name}: file missing (looked for {path})") from None
    except OSError as e:
        raise ValueError(f"{name}: cannot be read ({e})") from None


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


def _check_mass(mass: float, com: np.ndarray, inertia: np.ndarray) -> tuple[np.ndarray, ...]:
    """Validated (com (3,) m, inertia (3, 3) kg m^2 about the COM in the peg frame)."""
    if not (isinstance(mass, int | float | np.floating) and np.isfinite(mass) and mass > 0):
        raise ValueError(f"peg_mass = {mass!r}; expected a finite mass > 0 in kilograms")
    com = np.asarray(com, dtype=float)
    if com.shape != (3,) or not np.isfinite(com).all():
        raise ValueError(f"peg_com = {com!r}; expected a finite (3,) point in the peg frame, m")
    inertia = np.asarray(inertia, dtype=float)
    if inertia.shape != (3, 3) or not np.isfinite(inertia).all():
        raise ValueError(
            f"peg_inertia has shape {inertia.shape} or non-finite entries; expected a finite "
            "(3, 3) inertia tensor about the COM in the peg frame, kg m^2"
        )
    if not np.allclose(inertia, inertia.T, rtol=0.0, atol=1e-9 * float(np.abs(inertia).max())):
        raise ValueError("peg_inertia is not symmetric; pass the (3, 3) inertia tensor")
    moments = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
    if not moments.min() > 0 or moments.max() > moments.sum() - moments.max() + 1e-12 * (
        moments.max()
    ):
        raise ValueError(
            f"peg_inertia has principal moments {moments.tolist()} kg m^2; they must be > 0 "
            "and obey the triangle inequality (a physical body)"
        )
    return com, 0.5 * (inertia + inertia.T)


# ---------------------------------------------------------------------------------------------
# XML text: deterministic (repr of floats is the shortest round-trip form)
# ---------------------------------------------------------------------------------------------


def _num(x: float) -> str:
    x = float(x)
    return "0" if x == 0 else repr(x)


def _vec(v) -> str:
    return " ".join(_num(x) for x in np.asarray(v, dtype=float).ravel())


def _xml_attr(text: str) -> str:
    return text.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")


def mjcf_text(
    *,
    peg_file: str,
    piece_files: list[str],
    entrance: Frame,
    bottom: Frame,
    peg_pose: Frame,
    peg_mass: float,
    peg_com: np.ndarray,
    peg_inertia: np.ndarray,
    clearance: float,
    contact: ContactConfig,
) -> str:
    """The MJCF document as text (arguments as in `write_mjcf`, already validated)."""
    c = contact
    ent_pos, ent_quat = _check_frame(entrance, "entrance")
    bot_pos, bot_quat = _check_frame(bottom, "bottom")
    peg_pos, peg_quat = _check_frame(peg_pose, "peg_pose")
    com, inertia = _check_mass(peg_mass, peg_com, peg_inertia)
    full = [
        inertia[0, 0],
        inertia[1, 1],
        inertia[2, 2],
        inertia[0, 1],
        inertia[0, 2],
        inertia[1, 2],
    ]
    scale = _vec([MM, MM, MM])
    site_size = _num(max(clearance, 0.5e-3))
    lines = [
        '<mujoco model="peg_in_hole">',
        "  <!-- assetgen: units m, kg, s; the STL meshes are millimetres (scale 0.001).",
        "       Module frame = world frame; the body `peg` has the peg frame as its frame. -->",
        '  <compiler angle="radian" inertiafromgeom="false"/>',
        f'  <option timestep="{_num(c.timestep)}" gravity="0 0 0" integrator="{c.integrator}"'
        f' solver="{c.solver}" iterations="{c.iterations}" cone="{c.cone}"'
        f' impratio="{_num(c.impratio)}" noslip_iterations="{c.noslip_iterations}">',
        f'    <flag multiccd="{"enable" if c.multiccd else "disable"}"/>',
        "  </option>",
        "  <custom>",
        f'    <numeric name="{CLEARANCE_NUMERIC}" data="{_num(clearance)}"/>',
        "  </custom>",
        "  <default>",
        f'    <geom type="mesh" condim="{c.condim}" friction="{_vec(c.friction)}"'
        f' solref="{_vec(c.solref)}" solimp="{_vec(c.solimp)}" margin="{_num(c.margin)}"'
        f' gap="0"/>',
        f'    <site size="{site_size}" rgba="1 0.3 0.1 1"/>',
        '    <default class="module">',
        '      <geom contype="0" conaffinity="1" group="1" rgba="0.6 0.6 0.65 1"/>',
        "    </default>",
        '    <default class="peg">',
        '      <geom contype="1" conaffinity="0" rgba="0.2 0.5 0.9 1"/>',
        "    </default>",
        "  </default>",
        "  <asset>",
        f'    <mesh name="peg" file="{_xml_attr(peg_file)}" scale="{scale}"/>',
    ]
    for i, f in enumerate(piece_files):
        lines.append(f'    <mesh name="piece_{i:03d}" file="{_xml_attr(f)}" scale="{scale}"/>')
    lines += [
        "  </asset>",
        "  <worldbody>",
        f'    <site name="entrance" pos="{_vec(ent_pos)}" quat="{_vec(ent_quat)}"/>',
        f'    <site name="bottom" pos="{_vec(bot_pos)}" quat="{_vec(bot_quat)}"/>',
    ]
    for i in range(len(piece_files)):
        lines.append(f'    <geom name="piece_{i:03d}" class="module" mesh="piece_{i:03d}"/>')
    lines += [
        f'    <body name="{PEG_BODY}" pos="{_vec(peg_pos)}" quat="{_vec(peg_quat)}">',
        f'      <freejoint name="{PEG_JOINT}"/>',
        f'      <inertial pos="{_vec(com)}" mass="{_num(peg_mass)}" fullinertia="{_vec(full)}"/>',
        f'      <geom name="{PEG_GEOM}" class="peg" mesh="peg"/>',
        '      <site name="peg_bottom" pos="0 0 0"/>',
        "    </body>",
        "  </worldbody>",
        "</mujoco>",
        "",
    ]
    return "\n".join(lines)


def write_mjcf(path: Path, **document) -> bytes:
    """Write the module's MJCF to `path` atomically after checking every input.

    path       : the .xml to write; its folder holds the mesh files, which the keyword
                 arguments (see mjcf_document) name relative to it.
    **document : mjcf_document's arguments.

    Raises ValueError as mjcf_document does; nothing is written then. A temporary name in
    the same folder is renamed onto `path`, so a half-written XML never carries the final
    name. Returns the bytes written (to hash without reading the file back).
    """
    path = Path(path)
    data = mjcf_document(path.parent, name=path.name, **document)
    tmp = path.parent / f".{path.stem}.{os.getpid()}.tmp.xml"
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return data


def mjcf_document(
    folder: Path,
    *,
    peg_file: str,
    piece_files: list[str],
    entrance: Frame,
    bottom: Frame,
    peg_pose: Frame,
    peg_mass: float,
    peg_com: np.ndarray,
    peg_inertia: np.ndarray,
    clearance: float,
    contact: ContactConfig = ContactConfig(),
    written: Mapping[str, bytes] | None = None,
    parsed: Mapping[str, np.ndarray] | None = None,
    name: str = "the MJCF",
) -> bytes:
    """The module's MJCF as bytes, after checking every input and compiling it in MuJoCo.

    folder      : the folder the XML will sit in, which holds the mesh files.
    peg_file    : peg STL (binary, mm, peg frame), relative to `folder`.
    piece_files : collision piece STLs (binary, mm, module frame, each convex), relative.
    entrance, bottom : the module's frames (module frame, m, quat w x y z).
    peg_pose    : initial pose of the peg frame in the module frame.
    peg_mass    : kg.  peg_com: (3,) m, peg frame.  peg_inertia: (3, 3) kg m^2 about the
                  COM, axes of the peg frame.
    clearance   : m, stored in the file for the physics checks.
    contact     : physics and contact settings (see ContactConfig).
    written     : the bytes of mesh files just written, by name (the module writer's): they
                  are checked and compiled instead of reading the files back, which costs
                  as much as the checks; files not in it are read.
    parsed      : their triangles (m, 3, 3) in metres, where already parsed from those
                  bytes (parse_stl_triangles_mm), so they are not parsed again.
    name        : how error messages name the document.

    Raises ValueError naming the file or value and the problem (missing or corrupt STL, not
    watertight, not convex, bad frame or mass properties, or a model MuJoCo refuses). The
    model is compiled from these bytes and the mesh bytes (no file is read twice), so the
    document returned is one MuJoCo accepts.
    """
    folder = Path(folder)
    contact.validate()
    if not (isinstance(clearance, int | float | np.floating) and 0 < clearance < 0.1):
        raise ValueError(f"clearance = {clearance!r}; expected a gap in metres, 0 < c < 0.1")
    if not piece_files:
        raise ValueError("piece_files is empty; the module needs at least one collision piece")
    if len(set(piece_files)) != len(piece_files):
        raise ValueError(f"piece_files lists a file twice: {piece_files}")
    written = written or {}
    data: dict[str, bytes] = {}
    for mesh in [peg_file, *piece_files]:
        if Path(mesh).is_absolute():
            raise ValueError(f"{mesh}: must be relative to the MJCF's folder {folder}")
        data[mesh] = written[mesh] if mesh in written else _read(folder / mesh, mesh)
    # every mesh is a convex solid: MuJoCo collides a mesh as its convex hull
    checked_meshes(data, convex=True, parsed=parsed)
    text = mjcf_text(
        peg_file=peg_file,
        piece_files=piece_files,
        entrance=entrance,
        bottom=bottom,
        peg_pose=peg_pose,
        peg_mass=peg_mass,
        peg_com=peg_com,
        peg_inertia=peg_inertia,
        clearance=float(clearance),
        contact=contact,
    )
    try:
        spec = mujoco.MjSpec.from_string(text, assets=data)
        # The document as written, compiled with MuJoCo's mesh thread pool off: for ~30 small
        # meshes the threads cost more than they save (compile 4.9 - 6.5 ms against 7.3 -
        # 8.0 ms a module in one sitting), and a dataset's workers already fill the cores.
        # The compiled model is the same, array for array.
        spec.compiler.usethread = False
        model = spec.compile()
    except ValueError as e:
        raise ValueError(f"{name}: MuJoCo refuses the model: {e}") from None
    _check_compiled(model, peg_pose)
    return text.encode("utf-8")


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
