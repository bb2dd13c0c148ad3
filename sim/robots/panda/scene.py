"""One module with a Panda holding its peg: the arm's base fixed to the module's body.

The module frame is the world frame, as in the floating-peg scene. The arm's base stands at
`Mount.base` (the module is static relative to it: both are on one rigid body) and the peg
is a body fixed to the flange (the "secure grasp"): its frame is the peg frame, turned so the
peg points away from the hand, its top `grip` inside the fingertips. The peg keeps the
floating peg's geoms, contact parameters and site (sim.engines.mujoco.scene.add_peg); the
arm's collision geoms touch the module (a real arm can hit the plate) and nothing else.

Sensors, read through `mujoco.rollout`'s sensordata at every physics step:
- peg_pos, peg_quat: the peg frame in the module frame (the env's state);
- peg_linvel, peg_angvel: its velocity (module frame);
- wrist_force, wrist_torque: what the flange exerts on the peg, at the grasp, in the peg
  frame (a wrist force/torque sensor between flange and peg).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from assetgen.core.mujoco_config import apply_to_spec
from sim.assets.loading import ModuleAsset
from sim.engines.mujoco.scene import PEG_SITE, REF_SITE, add_peg, add_pieces
from sim.robots.panda.model import (
    FINGER_DIRECTION,
    FINGER_OUT,
    FINGER_PAD,
    FINGER_TIP,
    FLANGE,
    MAX_OPENING,
    ArmSettings,
    panda_spec,
)
from sim.task.config import PhysicsConfig

WRIST_SITE = "wrist_site"
GRASP_YAW = -0.765
"""The peg's turn about the flange's z in the fingers for a hole without yaw, rad: upright
over the hole, the arm then has joint 7 at the middle of its range (HOME). `grasp` turns it by
half each hole's yaw, so that the seated peg and the entrance's orientation sit either side of
joint 7's middle."""
WRIST_REACH = math.radians(140.0)
"""The furthest joint 7 is asked to turn from the middle of its range (166 degrees) by a grasp
turned to spare the fingers, rad: a margin for the rest of the turn and its limit's 0.2 rad."""
SENSORS = ("peg_pos", "peg_quat", "peg_linvel", "peg_angvel", "wrist_force", "wrist_torque")
SENSOR_DIMS = (3, 4, 3, 3, 3, 3)


@dataclass(frozen=True)
class Mount:
    """Where the arm's base stands in the module frame."""

    base: tuple[float, float, float] = (-0.45, 0.0, -0.1)
    """Base position, m: behind the hole along -x, below the plate's surface (a pedestal
    under the module), so the flange works at mid reach over the whole spawn range."""
    max_grip: float = 0.04
    """The fingers hold at most this much of the peg's top, m (see scene.grasp)."""
    min_grip: float = 0.0025
    """The least grip, m: a module whose peg leaves less for the fingers is refused."""
    finger_clearance: float = 0.001
    """The fingertips stay this far above the mounting surface when the peg is seated, m."""


def grasp_width(asset: ModuleAsset) -> float:
    """The fingers' gap: the peg's width across its top, m (ValueError: wider than the
    fingers open)."""
    v = asset.peg.vertices
    width = float(2.0 * np.sqrt((v[:, :2] ** 2).sum(1)).max())
    if width > MAX_OPENING:
        raise ValueError(
            f"module {asset.id}: its peg is {width * 1e3:.1f} mm wide; the Panda's fingers "
            f"open to {MAX_OPENING * 1e3:.0f} mm"
        )
    return width


def _grip_bound(asset: ModuleAsset, width: float, yaw: float, clearance: float) -> float:
    """The deepest grip (m) at which the fingertips of fingers `width` apart, with the peg
    turned `yaw` in them, stay `clearance` above the mounting surface once the peg is seated
    in its (tilted) hole."""
    up = asset.bottom[:3, :3].T @ np.array([0.0, 0.0, 1.0])  # the surface's normal, peg frame
    # the fingertips' extreme points in the flange's xy-plane, then in the peg frame: the
    # peg frame is the flange's turned by `yaw` about z and half a turn about x
    u = np.array([math.cos(FINGER_DIRECTION), math.sin(FINGER_DIRECTION)])
    v = np.array([-u[1], u[0]])
    c, s = math.cos(yaw), math.sin(yaw)
    lowest = np.inf
    for a in (-1.0, 1.0):
        for b in (-1.0, 1.0):
            x, y = a * (0.5 * width + FINGER_OUT) * u + b * FINGER_PAD * v
            px, py = c * x + s * y, s * x - c * y  # (Rz(yaw) Rx(pi))^T (x, y, 0)
            lowest = min(lowest, px * up[0] + py * up[1])
    h = float(asset.peg.vertices[:, 2].max())
    return h - (clearance - asset.bottom[2, 3] - lowest) / up[2]


def grasp(asset: ModuleAsset, mount: Mount) -> tuple[float, float]:
    """The peg's turn about the flange's z in the fingers (rad) and how much of its top they
    cover (m).

    The turn: GRASP_YAW less half the yaw of the module's seated peg (its hole's yaw, up to
    180 degrees either way), so that joint 7 holds both the entrance's orientation (the
    middle of the spawns, and every spawn at the curriculum's start) and the seat's at most
    90 degrees from the middle of its range, and the turn between them, the shorter way,
    passes through it. The grip: `mount.max_grip`, at most half of
    what stays out of the hole, and no deeper than keeps the fingertips `finger_clearance`
    above the surface of a seated peg in a tilted hole; where the tilt asks for less than
    that, the turn moves (up to 90 degrees, the least that does, and never so far that joint 7
    would turn more than WRIST_REACH from its middle at the seat or the entrance) until the
    fingers straddle the tilt's axis. ValueError (naming the module) where no turn gives
    `mount.min_grip`."""
    r = asset.bottom[:3, :3]
    hole_yaw = math.atan2(r[1, 0], r[0, 0])
    centre = GRASP_YAW - 0.5 * hole_yaw
    # joint 7 turns from its middle by about (peg yaw - hole yaw / 2 + offset): both the seat
    # and the entrance's orientation keep within WRIST_REACH of it
    most = math.degrees(WRIST_REACH - 0.5 * abs(hole_yaw))
    h = float(asset.peg.vertices[:, 2].max())
    want = min(mount.max_grip, 0.5 * (h + float(asset.bottom[2, 3])))
    width = min(grasp_width(asset) + 0.002, MAX_OPENING)
    best = (-np.inf, centre)
    for off in sorted(np.radians(np.arange(-90, 91, 5)), key=abs):
        if abs(math.degrees(off)) > most:
            continue
        yaw = centre + off
        g = min(want, _grip_bound(asset, width, yaw, mount.finger_clearance))
        if g >= want - 1e-9:
            best = (g, yaw)
            break
        best = max(best, (g, yaw))
    grip, yaw = best
    if grip < mount.min_grip:
        raise ValueError(
            f"module {asset.id}: its peg ({h * 1e3:.1f} mm) stands "
            f"{(h + asset.bottom[2, 3]) * 1e3:.1f} mm out of its hole when seated, tilted by "
            f"{math.degrees(math.acos(min(1.0, r[2, 2]))):.1f} deg; the Panda's fingers need "
            f"{mount.min_grip * 1e3:.1f} mm of it clear of the plate"
        )
    return math.remainder(yaw, 2.0 * math.pi), grip


def refusal(asset: ModuleAsset, mount: Mount | None = None) -> str | None:
    """Why the Panda cannot hold this module's peg (its width or its grasp), or None."""
    try:
        grasp_width(asset)
        grasp(asset, mount or Mount())
    except ValueError as err:
        return str(err)
    return None


def peg_in_flange(asset: ModuleAsset, mount: Mount) -> tuple[np.ndarray, np.ndarray]:
    """The peg frame in the flange frame: position (3,), quaternion (4,). The peg's z points
    away from the hand (the flange's -z), turned and gripped as `grasp` says: its top lies
    the grip inside the fingertips."""
    h = float(asset.peg.vertices[:, 2].max())
    yaw, grip = grasp(asset, mount)
    pos = np.array([0.0, 0.0, FINGER_TIP - grip + h])
    # half a turn about the flange's x, after the yaw about its z
    return pos, np.array([0.0, math.cos(0.5 * yaw), math.sin(0.5 * yaw), 0.0])


def add_twist_actuators(spec: mujoco.MjSpec, settings: ArmSettings) -> None:
    """Six actuators on the peg's site, measured against the module's origin (the floating
    peg's transmission): force = kv (ctrl - the site's velocity along the axis), which
    MuJoCo turns into joint torques through the site's Jacobian."""
    for k in range(6):
        a = spec.add_actuator()
        a.name = f"twist{k}"
        a.trntype = mujoco.mjtTrn.mjTRN_SITE
        a.target = PEG_SITE
        a.refsite = REF_SITE
        a.gear = np.eye(6)[k].tolist()
        kv = settings.kv_lin if k < 3 else settings.kv_rot
        a.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        a.gainprm[0] = kv
        a.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        a.biasprm[:3] = [0.0, 0.0, -kv]
        a.ctrllimited = False
        limit = settings.max_force if k < 3 else settings.max_torque
        a.forcelimited = limit is not None  # the joints clamp their total torque as well
        if limit is not None:
            a.forcerange = [-limit, limit]


def build_arm_spec(
    asset: ModuleAsset,
    physics: PhysicsConfig,
    mount: Mount | None = None,
    settings: ArmSettings | None = None,
    visual: bool = True,
) -> mujoco.MjSpec:
    """The arm, the module and the peg in one spec (see the module doc); mount and
    settings: the defaults of Mount and ArmSettings if None; visual: with the arm's visual
    meshes (for viewing; the simulation leaves them out)."""
    mount = mount or Mount()
    width = min(grasp_width(asset) + 0.002, MAX_OPENING)
    spec = panda_spec(settings, grasp_width=width, visual=visual)
    spec.modelname = "panda_peg_in_hole"
    apply_to_spec(spec, physics)
    # the arm's links take their inertia from their geoms (the module's scene does not)
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_AUTO
    # gravity acts, and the arm compensates it through its actuators (model.py): the
    # compensation counts against the torque limits
    spec.option.gravity = [0.0, 0.0, -9.81]
    for g in spec.geoms:
        if g.contype or g.conaffinity:
            # the arm touches the module's pieces (conaffinity 1) and not itself or the peg
            g.contype, g.conaffinity = 1, 0
    spec.body("panda0_link0").pos = list(mount.base)
    add_pieces(spec, asset, physics)
    flange = spec.body(FLANGE)
    peg = flange.add_body()
    peg.name = "peg"
    pos, quat = peg_in_flange(asset, mount)
    peg.pos, peg.quat = pos.tolist(), quat.tolist()
    peg.gravcomp = 1.0
    add_peg(spec, peg, asset, physics)
    settings = settings or ArmSettings()
    if settings.impedance:
        add_twist_actuators(spec, settings)
    wrist = peg.add_site()
    wrist.name = WRIST_SITE
    wrist.pos = [0.0, 0.0, float(asset.peg.vertices[:, 2].max())]  # the peg's top
    for name, kind in zip(
        SENSORS,
        (
            mujoco.mjtSensor.mjSENS_FRAMEPOS,
            mujoco.mjtSensor.mjSENS_FRAMEQUAT,
            mujoco.mjtSensor.mjSENS_FRAMELINVEL,
            mujoco.mjtSensor.mjSENS_FRAMEANGVEL,
            mujoco.mjtSensor.mjSENS_FORCE,
            mujoco.mjtSensor.mjSENS_TORQUE,
        ),
        strict=True,
    ):
        s = spec.add_sensor()
        s.name = name
        s.type = kind
        if name.startswith("wrist"):
            s.objtype = mujoco.mjtObj.mjOBJ_SITE
            s.objname = WRIST_SITE
        else:
            s.objtype = mujoco.mjtObj.mjOBJ_SITE
            s.objname = PEG_SITE
            s.reftype = mujoco.mjtObj.mjOBJ_SITE
            s.refname = REF_SITE
    return spec
