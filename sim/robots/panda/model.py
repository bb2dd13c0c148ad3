"""The Franka Emika Panda, read at run time from gymnasium-robotics (the `[robot]` extra).

gymnasium-robotics (MIT, maintained by the Farama Foundation) ships a MuJoCo Panda with its
visual and collision meshes (envs/assets/kitchen_franka/franka_assets, after Vikash Kumar's
franka_sim, Apache-2.0). It is the only maintained package on PyPI that carries the meshes
themselves: MuJoCo Menagerie's pip package downloads them from GitHub at first use, which a
machine without internet cannot do. Nothing of the model is copied into this repository: the
files are read from the installed package and changed in memory only.

What is changed, and why:
- the joints' damping (100 and 10 N m s/rad in the kitchen model, which caps joint 1-4
  speeds at 0.87 rad/s under the 87 N m limit) is set to `ArmSettings.joint_damping`, and an
  armature (reflected rotor inertia) is added, as the real arm's drives have;
- the position actuators get the gains of `ArmSettings` (kp, and a kv the kitchen model
  lacks), keeping the published torque limits (87 N m on joints 1-4, 12 N m on 5-7);
- the fingers' slide joints and actuators are removed: the peg is held rigidly (the "secure
  grasp"), so the fingers are fixed at the peg's width;
- gravity is compensated by MuJoCo (body gravcomp), through the actuators (actuatorgravcomp),
  so the compensation counts against the torque limits as on the real arm.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

ASSET_DIR = "envs/assets/kitchen_franka/franka_assets"
"""Where gymnasium-robotics keeps the Panda's MJCF and meshes, inside its package."""
JOINTS = tuple(f"robot:panda0_joint{i}" for i in range(1, 8))
"""The arm's seven joint names in the package's model."""
FINGERS = ("panda0_leftfinger", "panda0_rightfinger")
FLANGE = "panda0_link7"
"""The last link: the hand and the held peg are fixed to it."""
TORQUE_LIMITS = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0])
"""Published joint torque limits, N m (Franka's control parameters)."""
VELOCITY_LIMITS = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])
"""Published joint velocity limits, rad/s."""
FINGER_TIP = 0.26
"""Distance of the fingertips from the flange along its z, m (pads from 0.20 to 0.26)."""
FINGER_BASE = 0.1654
"""The fingers' bodies sit this far along the flange's z, m."""
FINGER_DIRECTION = np.pi / 4
"""The fingers close along this direction in the flange's xy-plane, rad (the hand is turned
45 degrees on the flange)."""
FINGER_OUT = 0.0145
"""The fingertips reach this far beyond half the fingers' gap, across it, m (their lowest
collision capsules: 7.4 mm to the capsule's axis plus its 7 mm radius)."""
FINGER_PAD = 0.0161
"""The fingertips reach this far to either side of the gap's line, along the pads, m (the
capsule's half-length 9.1 mm plus its radius)."""
MAX_OPENING = 0.08
"""The widest peg the fingers close on, m (two 40 mm strokes)."""
HOME = np.array([0.0, -0.233, 0.0, -2.459, 0.0, 0.656, 0.0])
"""The nullspace posture: the peg upright 0.1 m over the plate's centre, elbow up, joint 7 at
the middle of its range (the grasp's yaw, scene.GRASP_YAW, is chosen for that)."""


class MissingRobotError(RuntimeError):
    """The `[robot]` extra is not installed."""


@dataclass(frozen=True)
class ArmSettings:
    """The arm's drive and controller settings (docs/robot.md has the measurement that chose
    them)."""

    controller: str = "impedance"
    """"impedance": six actuators on the peg's site, force = kv (commanded - measured twist),
    which MuJoCo maps to joint torques through the site's Jacobian at every physics step
    (the floating peg's controller, through the arm), the joints' total torque clamped at
    the published limits; "ik": damped least squares at the policy rate into joint
    position ramps (kp, kv below)."""
    kv_lin: float = 1000.0
    """impedance: linear damping gain, N s/m (force per m/s of twist error)."""
    kv_rot: float = 100.0
    """impedance: angular damping gain, N m s/rad."""
    max_force: float | None = 50.0
    """impedance: the most force the twist actuators apply at the peg, N (None: only the
    joints' torque limits bound it)."""
    max_torque: float | None = 10.0
    """impedance: the most torque they apply about the peg's bottom-face centre, N m."""
    posture_stiffness: float = 0.5
    """impedance: a joint spring to HOME, N m/rad, which holds the redundant motion (the
    elbow) in place of a nullspace projection, small next to the task's forces."""

    kp: tuple[float, ...] = (4500.0, 4500.0, 3500.0, 3500.0, 2000.0, 2000.0, 2000.0)
    """Position gains of the joints' actuators, N m/rad."""
    kv: tuple[float, ...] = (450.0, 450.0, 350.0, 350.0, 200.0, 200.0, 200.0)
    """Velocity gains of the joints' actuators, N m s/rad."""
    joint_damping: float = 1.0
    """Viscous damping of every arm joint, N m s/rad."""
    armature: float = 0.1
    """Reflected rotor inertia added to every arm joint, kg m^2."""
    damping: float = 0.01
    """Damped least squares' lambda for the differential inverse kinematics (m, rad): it
    bounds the joint speeds near a singularity. Measured (benchmarks.panda tracking): 0.05
    left 10-11 % of a 0.1 m/s command untracked along x and z; 0.01 leaves under 1 %."""
    nullspace_gain: float = 2.0
    """Rate (1/s) at which the joints drift to HOME within the task's nullspace."""

    @property
    def impedance(self) -> bool:
        """Whether the twist actuators drive the arm (else the joints' position ramps)."""
        return self.controller == "impedance"

    def validate(self) -> ArmSettings:
        bad = [
            name
            for name, ok in {
                "7 kp": len(self.kp) == 7 and all(k > 0 for k in self.kp),
                "7 kv": len(self.kv) == 7 and all(k >= 0 for k in self.kv),
                "joint_damping >= 0": self.joint_damping >= 0,
                "armature >= 0": self.armature >= 0,
                "damping > 0": self.damping > 0,
                "nullspace_gain >= 0": self.nullspace_gain >= 0,
                "controller in (impedance, ik)": self.controller in ("impedance", "ik"),
                "kv_lin > 0": self.kv_lin > 0,
                "kv_rot > 0": self.kv_rot > 0,
                "posture_stiffness >= 0": self.posture_stiffness >= 0,
                "max_force is None or > 0": self.max_force is None or self.max_force > 0,
                "max_torque is None or > 0": self.max_torque is None or self.max_torque > 0,
            }.items()
            if not ok
        ]
        if bad:
            raise ValueError(f"ArmSettings: these must hold: {bad}")
        return self


def asset_dir() -> Path:
    """The installed package's Panda folder, or MissingRobotError naming the extra."""
    spec = importlib.util.find_spec("gymnasium_robotics")
    if spec is None or not spec.submodule_search_locations:
        raise MissingRobotError(
            "the Panda arm needs the package 'gymnasium_robotics', which comes with the "
            '[robot] extra: pip install "peg-in-hole-assetgen[robot]" (in a checkout: '
            'pip install -e ".[robot]")'
        )
    root = Path(spec.submodule_search_locations[0]) / ASSET_DIR
    if not (root / "chain.xml").is_file():
        raise MissingRobotError(
            f"gymnasium_robotics at {root.parent.parent.parent} has no Panda model "
            f"({ASSET_DIR}/chain.xml); install the [robot] extra's version: "
            'pip install -e ".[robot]"'
        )
    return root


def panda_spec(
    settings: ArmSettings | None = None, grasp_width: float = 0.04, visual: bool = True
) -> mujoco.MjSpec:
    """The Panda as an MjSpec: its base body `panda0_link0` at the origin, the changes of
    the module doc applied, the fingers fixed `grasp_width` apart (m, at most MAX_OPENING).
    visual=False leaves out the visual meshes (they collide with nothing): a simulation
    model then takes 1 MB instead of 25."""
    settings = settings or ArmSettings()
    root = asset_dir()
    xml = (
        f'<mujoco model="panda"><include file="{root}/assets.xml"/>'
        f'<include file="{root}/actuator.xml"/>'
        f'<worldbody><include file="{root}/chain.xml"/></worldbody></mujoco>'
    )
    spec = mujoco.MjSpec.from_string(xml)
    # the package's compiler meshdir is relative to a main file we do not have: point every
    # mesh at its file
    for mesh in spec.meshes:
        mesh.file = str(root / "meshes" / Path(mesh.file).relative_to(root))
    spec.meshdir = ""
    if not visual:
        for g in list(spec.geoms):
            if g.contype == 0 and g.conaffinity == 0 and g.meshname.endswith("_viz"):
                spec.delete(g)
        for mesh in list(spec.meshes):
            if mesh.name.endswith("_viz"):
                spec.delete(mesh)
    for act in list(spec.actuators):
        spec.delete(act)
    half = min(max(grasp_width, 0.0), MAX_OPENING) / 2
    for side, name in zip((1.0, -1.0), FINGERS, strict=True):
        body = spec.body(name)
        for j in list(body.joints):
            spec.delete(j)
        # the finger slides along its body's y (the left finger +y, the right -y), which
        # the body's quat turns about the flange's z
        q = np.array(body.quat, dtype=float)
        axis = np.zeros(3)
        mujoco.mju_rotVecQuat(axis, np.array([0.0, side * half, 0.0]), q)
        body.pos = (np.array(body.pos, dtype=float) + axis).tolist()
    for i, name in enumerate(JOINTS):
        j = spec.joint(name)
        j.damping = [settings.joint_damping, 0.0, 0.0]
        j.armature = settings.armature
        j.actgravcomp = True
        # every actuator's torque on the joint, gravity compensation included, within the
        # published limit (the impedance's site actuators act on all joints at once)
        j.actfrclimited = True
        j.actfrcrange = [-TORQUE_LIMITS[i], TORQUE_LIMITS[i]]
        if settings.impedance:
            j.stiffness = [settings.posture_stiffness, 0.0, 0.0]
            j.springref = float(HOME[i])
            continue
        a = spec.add_actuator()
        a.name = f"arm{i + 1}"
        a.target = name
        a.trntype = mujoco.mjtTrn.mjTRN_JOINT
        a.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        a.gainprm[0] = settings.kp[i]
        a.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        a.biasprm[:3] = [0.0, -settings.kp[i], -settings.kv[i]]
        a.forcelimited = True
        a.forcerange = [-TORQUE_LIMITS[i], TORQUE_LIMITS[i]]
        a.ctrllimited = False
    for body in spec.bodies:
        if body.name.startswith("panda0_"):
            body.gravcomp = 1.0
    return spec
