"""MuJoCo models built from module assets: static convex pieces, a free peg, a velocity
controller inside MuJoCo.

The module frame is the world frame of each environment (a module is static: the manipulator
holding the peg stands on the same rigid body). The peg body's frame is the peg frame, so a
free joint's qpos is the peg pose directly. The controller is six velocity actuators on a
site at the peg's bottom-face centre, measured against a reference site at the module origin:
with `site` + `refsite` transmission the actuator velocity is the site's linear/angular
velocity expressed in the module frame, and force = kv (ctrl - velocity). The gains are
capped so a command never asks for more than the force/torque limits, but the actuators are
not clamped: a clamped damper whose damping MuJoCo still integrates implicitly injects
energy once a contact knocks the peg beyond the clamp (a peg knocked to 24 rad/s spun up to
2400 rad/s and flew off at km/s); unclamped, such a disturbance is damped like any error.
Tracking zero linear velocity of that site while turning makes the peg
rotate about its bottom-face centre. The damping term is integrated implicitly (the
`discrete` integrator), so kv may exceed what explicit Euler would allow at 200 Hz.

Restitution: MuJoCo contacts have no restitution coefficient; the contact is a damped spring
on the penetration (solref = time constant, damping ratio). With the impedance near 1 the
penetration follows  r'' = -b r' - k r.  The restitution draw sets the damping ratio zeta
(see `restitution_to_dampratio` for the mapping and why it is not the analytic inverse) and
keeps k fixed (solref = (T0 / zeta, zeta) gives k = 1 / T0^2 whatever zeta), so it changes
the damping only, never the stiffness (penetration).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from assetgen.core.mujoco_config import apply_to_spec, geom_friction, velocity_gains
from assetgen.core.mujoco_config import contact_solref as contact_solref
from sim.assets.loading import ModuleAsset
from sim.task.config import PhysicsConfig

PEG_SITE = "peg_site"
REF_SITE = "ref_site"
_AXES = np.eye(6)


def restitution_to_dampratio(e: np.ndarray | float, physics: PhysicsConfig) -> np.ndarray:
    """Coefficient of restitution in [0, 1] -> contact damping ratio in
    [physics.min_dampratio, physics.dampratio].

    A linear damped spring returns e = exp(-zeta pi / sqrt(1 - zeta^2)), i.e. zeta =
    -ln e / sqrt(pi^2 + ln^2 e); restitution 0.05 already needs zeta = 0.69. Measured at
    200 Hz with the controller pushing a peg into the plate, every zeta below ~0.8 ends in
    a chatter limit cycle (the peg bounces 0.5 mm forever), and the free-peg rebound is
    0.1-0.4 whatever zeta (numerical: the penetration found at detection is pushed out
    within a step). So the draw randomises the contact's damping over the range that stays
    settled, linearly: e = 0 -> dampratio (1, critical), e = 1 -> min_dampratio. Not a restitution
    coefficient: MuJoCo has none, and PhysX (the original) ignores restitution below its
    bounce-threshold velocity (0.2 m/s by default), about this task's top speed.
    """
    e = np.clip(np.asarray(e, dtype=float), 0.0, 1.0)
    return physics.dampratio - e * (physics.dampratio - physics.min_dampratio)


def geom_contacts(
    m: mujoco.MjModel, d: mujoco.MjData, geoms: range
) -> tuple[np.ndarray, np.ndarray]:
    """The contacts of d (forward run) that involve `geoms`: distances (k,) m (negative:
    penetration) and normal forces (k,) N."""
    mine = [c for c in range(d.ncon) if d.contact[c].geom1 in geoms or d.contact[c].geom2 in geoms]
    dist = np.array([d.contact[c].dist for c in mine])
    force = np.zeros(len(mine))
    f6 = np.zeros(6)
    for j, c in enumerate(mine):
        mujoco.mj_contactForce(m, d, c, f6)
        force[j] = f6[0]
    return dist, force


def _add_mesh(spec: mujoco.MjSpec, name: str, vertices: np.ndarray, faces: np.ndarray) -> None:
    mesh = spec.add_mesh()
    mesh.name = name
    mesh.uservert = vertices.astype(float).ravel().tolist()
    mesh.userface = faces.astype(int).ravel().tolist()


def add_pieces(
    spec: mujoco.MjSpec,
    asset: ModuleAsset,
    physics: PhysicsConfig,
    *,
    prefix: str = "",
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
    collision_bit: int = 1,
) -> None:
    """Add one module's static convex pieces and its reference site (the module origin) to
    `spec`; the pieces touch what has `collision_bit` in its contype."""
    solref = contact_solref(physics.dampratio, physics).tolist()
    solimp = list(physics.solimp)
    for i, piece in enumerate(asset.pieces):
        _add_mesh(spec, f"{prefix}piece{i}", piece.vertices, piece.faces)
        g = spec.worldbody.add_geom()
        g.name = f"{prefix}piece{i}"
        g.type = mujoco.mjtGeom.mjGEOM_MESH
        g.meshname = f"{prefix}piece{i}"
        g.pos = list(offset)
        g.contype = 0
        g.conaffinity = collision_bit
        # the peg's geom has priority: its friction/solref (randomised per reset) rule
        g.friction = [0.0, 0.005, 0.0001]
        g.solref = solref
        g.solimp = solimp
        g.margin = g.gap = physics.contact_margin  # detected early, active on penetration
        g.group = 1
    ref = spec.worldbody.add_site()
    ref.name = f"{prefix}{REF_SITE}"
    ref.pos = list(offset)


def add_peg(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    asset: ModuleAsset,
    physics: PhysicsConfig,
    *,
    prefix: str = "",
    collision_bit: int = 1,
) -> None:
    """Give the peg body `body` (its frame the peg frame: free, or fixed to a robot's hand)
    the peg's geoms (one per convex piece), its inertia and the site at its frame's origin
    (the bottom-face centre)."""
    solref = contact_solref(physics.dampratio, physics).tolist()
    solimp = list(physics.solimp)
    # a convex peg is one geom; a part that is not convex is one geom per convex piece,
    # `peg` then `peg_1`, `peg_2`, ... (contiguous ids: BatchSim sets them together)
    shapes = asset.peg_pieces or (asset.peg,)
    geom_names = [f"{prefix}peg"] + [f"{prefix}peg_{i}" for i in range(1, len(shapes))]
    for name, shape in zip(geom_names, shapes, strict=True):
        _add_mesh(spec, name, shape.vertices, shape.faces)
    body.explicitinertial = True
    body.mass = asset.peg_mass
    body.ipos = asset.peg_com.tolist()
    inertia = asset.peg_inertia
    body.fullinertia = [
        inertia[0, 0],
        inertia[1, 1],
        inertia[2, 2],
        inertia[0, 1],
        inertia[0, 2],
        inertia[1, 2],
    ]
    for name in geom_names:
        g = body.add_geom()
        g.name = name
        g.type = mujoco.mjtGeom.mjGEOM_MESH
        g.meshname = name
        g.contype = collision_bit
        g.conaffinity = 0
        g.priority = 1
        g.condim = 3
        g.friction = geom_friction(physics)
        g.solref = solref
        g.solimp = solimp
        g.margin = g.gap = physics.contact_margin
    site = body.add_site()
    site.name = f"{prefix}{PEG_SITE}"


def add_environment(
    spec: mujoco.MjSpec,
    asset: ModuleAsset,
    physics: PhysicsConfig,
    *,
    prefix: str = "",
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
    collision_bit: int = 1,
    max_lin_vel: float = 0.25,
    max_ang_vel: float = math.pi / 2,
) -> None:
    """Add one module (static pieces), its peg (free body) and the six actuators to `spec`.

    `offset` places the module origin in the world (shards hold many modules side by side);
    `collision_bit` is the contype of the peg and the conaffinity of the pieces, so a peg
    only touches modules that share its bit.
    """
    add_pieces(spec, asset, physics, prefix=prefix, offset=offset, collision_bit=collision_bit)
    body = spec.worldbody.add_body()
    body.name = f"{prefix}peg"
    body.pos = [offset[0], offset[1], offset[2] + 0.2]
    body.add_freejoint().name = f"{prefix}peg_free"
    add_peg(spec, body, asset, physics, prefix=prefix, collision_bit=collision_bit)

    # no command asks for more than the limit: a reversal from -max to +max velocity needs
    # kv * 2 * max <= limit (2.2 for a margin)
    kv_lin, kv_rot = velocity_gains(
        asset.peg_mass, asset.peg_com, asset.peg_inertia, physics, max_lin_vel, max_ang_vel
    )
    for k in range(6):
        a = spec.add_actuator()
        a.name = f"{prefix}vel{k}"
        a.trntype = mujoco.mjtTrn.mjTRN_SITE
        a.target = f"{prefix}{PEG_SITE}"
        a.refsite = f"{prefix}{REF_SITE}"
        a.gear = _AXES[k].tolist()
        kv = kv_lin if k < 3 else kv_rot
        a.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        a.gainprm[0] = kv
        a.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        a.biasprm[:3] = [0.0, 0.0, -kv]
        a.ctrllimited = False
        a.forcelimited = False  # see the module docstring: clamping made pegs spin up


def build_model(
    assets: list[ModuleAsset],
    physics: PhysicsConfig,
    *,
    max_lin_vel: float = 0.25,
    max_ang_vel: float = math.pi / 2,
    spacing: float = 2.0,
    pad_geoms: int = 0,
) -> mujoco.MjModel:
    """`build_spec(...)`, compiled."""
    return build_spec(
        assets,
        physics,
        max_lin_vel=max_lin_vel,
        max_ang_vel=max_ang_vel,
        spacing=spacing,
        pad_geoms=pad_geoms,
    ).compile()


def build_spec(
    assets: list[ModuleAsset],
    physics: PhysicsConfig,
    *,
    max_lin_vel: float = 0.25,
    max_ang_vel: float = math.pi / 2,
    spacing: float = 2.0,
    pad_geoms: int = 0,
) -> mujoco.MjSpec:
    """One model's spec holding `len(assets)` environments (one: the usual case; more: a
    shard); callers may add to it (the contact stress benchmark adds a sensor) before
    compiling.

    In a shard, env k sits at x = k * spacing with collision bit k mod 31 + 1... peg k only
    collides with module k's bit group, and same-bit modules are 31 * spacing apart.
    """
    spec = mujoco.MjSpec()
    spec.modelname = "peg_in_hole"
    apply_to_spec(spec, physics)  # the option block the exported MJCF carries too
    for k, asset in enumerate(assets):
        prefix = f"e{k}_" if len(assets) > 1 else ""
        add_environment(
            spec,
            asset,
            physics,
            prefix=prefix,
            offset=(k * spacing, 0.0, 0.0),
            collision_bit=1 << (k % 31),
            max_lin_vel=max_lin_vel,
            max_ang_vel=max_ang_vel,
        )
    for i in range(pad_geoms):
        # inert spheres: they only enlarge the model (the capacity model of batch.py)
        g = spec.worldbody.add_geom()
        g.name = f"pad{i}"
        g.size = [0.001, 0, 0]
        g.pos = [0.0, 0.0, -10.0]
        g.contype = 0
        g.conaffinity = 0
    return spec
