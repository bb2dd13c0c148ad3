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
    FINGER_TIP,
    FLANGE,
    MAX_OPENING,
    ArmSettings,
    panda_spec,
)
from sim.task.config import PhysicsConfig

WRIST_SITE = "wrist_site"
GRASP_YAW = -0.765
"""The peg's turn about the flange's z in the fingers, rad: upright over the hole, the arm then
has joint 7 at the middle of its range (HOME), so any turn of the peg about its axis up to
166 degrees either way is in the wrist's reach."""
SENSORS = ("peg_pos", "peg_quat", "peg_linvel", "peg_angvel", "wrist_force", "wrist_torque")
SENSOR_DIMS = (3, 4, 3, 3, 3, 3)


@dataclass(frozen=True)
class Mount:
    """Where the arm's base stands in the module frame."""

    base: tuple[float, float, float] = (-0.45, 0.0, -0.1)
    """Base position, m: behind the hole along -x, below the plate's surface (a pedestal
    under the module), so the flange works at mid reach over the whole spawn range."""
    max_grip: float = 0.04
    """The fingers hold the top `min(max_grip, (h - depth) / 2)` of a peg of height h whose
    hole is `depth` deep, m: never deeper than the part that stays out of the hole."""
    min_grip: float = 0.0025
    """A peg that sticks out of its seated hole by less than twice this is refused: the
    fingers would reach the plate (the train and test splits' pegs stick out 5.9 mm or
    more)."""


def grip_depth(asset: ModuleAsset, mount: Mount) -> float:
    """How much of the peg's top the fingers cover, m (ValueError: too little of it stays
    out of its hole for the fingers)."""
    h = float(asset.peg.vertices[:, 2].max())
    depth = float(-asset.bottom[2, 3])
    g = min(mount.max_grip, 0.5 * (h - depth))
    if g < mount.min_grip:
        raise ValueError(
            f"module {asset.id}: its peg ({h * 1e3:.1f} mm) stands {(h - depth) * 1e3:.1f} mm "
            f"out of its {depth * 1e3:.1f} mm hole when seated; the Panda's fingers need "
            f"{2 * mount.min_grip * 1e3:.0f} mm"
        )
    return g


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


def peg_in_flange(asset: ModuleAsset, mount: Mount) -> tuple[np.ndarray, np.ndarray]:
    """The peg frame in the flange frame: position (3,), quaternion (4,). The peg's z points
    away from the hand (the flange's -z) and its top lies `grip_depth` inside the fingertips."""
    h = float(asset.peg.vertices[:, 2].max())
    pos = np.array([0.0, 0.0, FINGER_TIP - grip_depth(asset, mount) + h])
    # half a turn about the flange's x, after GRASP_YAW about its z
    c, s = math.cos(0.5 * GRASP_YAW), math.sin(0.5 * GRASP_YAW)
    return pos, np.array([0.0, c, s, 0.0])


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
