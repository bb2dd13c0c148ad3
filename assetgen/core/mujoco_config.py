"""The one MuJoCo configuration of the project: what the simulator (sim) trains on and what
the exported `peg_in_hole.xml` (assetgen.formats.mjcf) carries, so that `assetgen physics`
checks the physics the agents train on.

Dependency-free apart from numpy (and mujoco for `apply_to_spec`): sim imports it without the
geometry code, assetgen imports it without sim. Two writers, one source:

    apply_to_spec(spec, physics)      the option block, on a mujoco.MjSpec (sim/scene.py)
    option_xml(physics)               the same as MJCF text (assetgen/formats/mjcf.py)
    contact_solref(z, physics)        geom solref for damping ratio z (k fixed)
    velocity_gains(m, com, I, ...)    the six velocity actuators' kv (linear, angular)
    actuator_xml(...)                 those actuators as MJCF text

tests/test_physics_config.py compiles an exported module and the simulator's model of the
same module and compares model.opt, the peg geom's contact parameters and the actuators.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

INTEGRATORS = ("discrete", "implicitfast", "implicit", "Euler")


@dataclass(frozen=True)
class PhysicsConfig:
    """MuJoCo settings: integration, the velocity controller and contact softness."""

    timestep: float = 0.005
    """Physics step, s (200 Hz)."""
    substeps: int = 4
    """Physics steps per control step (50 Hz control), run in C with no Python between."""
    integrator: str = "discrete"
    """MuJoCo integrator. `discrete` solves the contacts in the same effective inertia
    (M + h D) that integrates the controller's damping implicitly; under `implicitfast`
    that damping (h kv ~ M) dilutes each contact impulse and a full-speed impact sinks
    1.9 mm instead of <= 1.1 mm (measured, see sim/scene.py)."""
    tracking_time_constant: float = 0.005
    """Time constant of the velocity controller, s: kv = mass / tau (linear) and
    I_max / tau (angular, I_max the largest principal inertia about the bottom-face centre),
    each capped so no command asks for more than `force_limit`. One timestep is fine:
    the damping is integrated implicitly."""
    force_limit: float = 20.0
    """Most force a command can ask of a linear actuator, N: the gain is capped at
    force_limit / (2.2 x max_lin_vel), so even a full command reversal stays below it, and
    pushing into a wall at full command presses with kv x max_lin_vel = 9.1 N at most. The
    actuator is not clamped to it (see sim/scene.py): a clamped damper integrated implicitly
    spins knocked pegs up to km/s; past the limit only a contact's knock can take the peg."""
    torque_limit: float = 1.5
    """Most torque a command can ask of an angular actuator, N m (gain capped as for the
    force)."""
    # No contact margin: in MuJoCo 4 a margin moves the contact surface out by that much
    # (forces act from distance `margin`), which would eat into the 1 mm clearance.
    contact_timeconst: float = 0.005
    """Contact stiffness time constant T0, s: every contact spring has k = 1 / T0^2 and
    solref = (T0 / zeta, zeta) for its damping ratio zeta, so solref[0] * solref[1] = T0.
    Under the `discrete` integrator a row is resolvable (kept as authored) when
    solref[0] * solref[1] >= timestep, hence T0 = timestep: the stiffest resolvable spring.
    At full speed the transient penetration stays within one physics step's travel
    (1.25 mm); 2 x timestep would give ~1.9 mm. Measured with `assetgen physics` on the
    exported files (256 test-split modules): with zeta <= 1 a peg pushed with 5 N into a
    wall/floor corner does not settle (a limit cycle of ~0.1 - 0.3 mm); see docs/physics.md."""
    dampratio: float = 1.0
    """Nominal contact damping ratio (restitution 0): the exported file's, and the
    simulator's before its per-reset draw."""
    min_dampratio: float = 0.85
    """Contact damping ratio at restitution 1 (restitution 0: `dampratio`, linear between).
    Below ~0.8 a peg pushed into a wall chatters forever at 200 Hz (see sim/scene.py)."""
    solimp: tuple[float, float, float, float, float] = (0.99, 0.9999, 0.0005, 0.5, 2.0)
    """Contact impedance (dmin, dmax, width m, midpoint, power). An impedance near 1 makes the
    constraint nearly hard: steady penetration = F (1 - d) / (d^2 k m_eff), micrometres at
    the force limit, where the default (0.9, 0.95, 0.001) lets a 0.2 kg peg sink ~0.4 mm."""
    friction: float = 0.5
    """Nominal sliding friction (the exported file's; the simulator draws it per reset)."""
    torsional_friction: float = 0.005
    rolling_friction: float = 0.0001
    condim: int = 3
    """Contact dimensionality: normal + 2 tangential (sliding friction)."""
    cone: str = "elliptic"
    """Friction cone: elliptic (with impratio) models Coulomb friction more faithfully."""
    impratio: float = 10.0
    """Frictional-to-normal impedance ratio: > 1 makes friction stiffer (less creep)."""
    noslip_iterations: int = 0
    """Extra no-slip solver iterations (0: off)."""
    iterations: int = 30
    """Constraint solver (Newton) iterations per physics step at most."""
    runaway_speed: float = 10.0
    """A peg moving faster than this (m/s, 40 x the fastest command) or turning faster than
    10 x this (rad/s) has left physics: its env is reset and reported unstable."""
    multiccd: bool = True
    """Several contacts per convex pair, so a flat face rests on a flat face without
    rocking on one point."""

    @property
    def refsafe(self) -> bool:
        """MuJoCo's refsafe flag. Under `discrete` every contact row is resolvable by
        construction (solref[0] * solref[1] = T0 >= h); with refsafe on, rounding of
        T0 / zeta * zeta just below h would swap a row for MuJoCo's replacement spring,
        which makes a pressed peg chatter. Kept on for the continuous-time integrators."""
        return self.integrator != "discrete"

    def validate(self) -> PhysicsConfig:
        checks = {
            "substeps >= 1": self.substeps >= 1,
            "timestep > 0": self.timestep > 0,
            "runaway_speed > 0": self.runaway_speed > 0,
            "contact_timeconst >= timestep": self.contact_timeconst >= self.timestep - 1e-12,
            "contact_timeconst >= 2 timestep unless integrator is discrete": (
                self.integrator == "discrete" or self.contact_timeconst >= 2 * self.timestep - 1e-12
            ),
            f"integrator in {INTEGRATORS}": self.integrator in INTEGRATORS,
            "cone in (elliptic, pyramidal)": self.cone in ("elliptic", "pyramidal"),
            "0 < min_dampratio <= dampratio": 0 < self.min_dampratio <= self.dampratio,
            "friction >= 0": min(self.friction, self.torsional_friction) >= 0,
            "impratio >= 1": self.impratio >= 1,
            "iterations >= 1": self.iterations >= 1,
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"PhysicsConfig: these must hold: {bad}")
        return self


# ----------------------------------------------------------------------------- derived values


def contact_solref(dampratio, physics: PhysicsConfig) -> np.ndarray:
    """(..., 2) solref for the given damping ratios with the stiffness k = 1/T0^2 fixed."""
    z = np.asarray(dampratio, dtype=float)
    return np.stack([physics.contact_timeconst / z, z], axis=-1)


def geom_friction(physics: PhysicsConfig, sliding: float | None = None) -> list[float]:
    """(sliding, torsional, rolling) friction of the peg geom."""
    s = physics.friction if sliding is None else sliding
    return [float(s), physics.torsional_friction, physics.rolling_friction]


def velocity_gains(
    mass: float,
    com: np.ndarray,
    inertia: np.ndarray,
    physics: PhysicsConfig,
    max_lin_vel: float = 0.25,
    max_ang_vel: float = math.pi / 2,
) -> tuple[float, float]:
    """(kv_lin, kv_rot) of the six velocity actuators on the peg's bottom-face centre.

    Linear: mass / tau; angular: the largest principal inertia about the bottom-face centre
    (`com` m and `inertia` kg m^2 about the COM, both in the peg frame) / tau; each capped so
    a reversal from -max to +max velocity asks for at most the force/torque limit (2.2:
    margin)."""
    c = np.asarray(com, dtype=float)
    # parallel-axis theorem: I_site = I_com + m (|c|^2 I - c c^T)
    i_site = np.asarray(inertia, dtype=float) + mass * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
    kv_lin = min(mass / physics.tracking_time_constant, physics.force_limit / (2.2 * max_lin_vel))
    kv_rot = min(
        float(np.linalg.eigvalsh(i_site).max() / physics.tracking_time_constant),
        physics.torque_limit / (2.2 * max_ang_vel),
    )
    return float(kv_lin), float(kv_rot)


# ----------------------------------------------------------------------------- MjSpec writer


def apply_to_spec(spec, physics: PhysicsConfig) -> None:
    """Set the option block of a mujoco.MjSpec (gravity 0, autoreset off: the simulator
    resets diverging envs itself and reports them)."""
    import mujoco

    opt = spec.option
    opt.timestep = physics.timestep
    opt.gravity = [0.0, 0.0, 0.0]
    opt.integrator = {
        "discrete": mujoco.mjtIntegrator.mjINT_DISCRETE,
        "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
        "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
        "Euler": mujoco.mjtIntegrator.mjINT_EULER,
    }[physics.integrator]
    opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
    opt.iterations = physics.iterations
    opt.cone = {
        "elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC,
        "pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL,
    }[physics.cone]
    opt.impratio = physics.impratio
    opt.noslip_iterations = physics.noslip_iterations
    if not physics.multiccd:
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_MULTICCD
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    if not physics.refsafe:
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_REFSAFE
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE


# ----------------------------------------------------------------------------- MJCF text writer


def _num(x: float) -> str:
    x = float(x)
    return "0" if x == 0 else repr(x)


def _vec(v) -> str:
    return " ".join(_num(x) for x in np.asarray(v, dtype=float).ravel())


def option_xml(physics: PhysicsConfig, indent: str = "  ") -> list[str]:
    """The `<option>` element (with its `<flag>`) as MJCF lines: what apply_to_spec sets."""
    flags = [
        f'multiccd="{"enable" if physics.multiccd else "disable"}"',
        'autoreset="disable"',
    ]
    if not physics.refsafe:
        flags.append('refsafe="disable"')
    return [
        f'{indent}<option timestep="{_num(physics.timestep)}" gravity="0 0 0"'
        f' integrator="{physics.integrator}" solver="Newton"'
        f' iterations="{physics.iterations}" cone="{physics.cone}"'
        f' impratio="{_num(physics.impratio)}" noslip_iterations="{physics.noslip_iterations}">',
        f"{indent}  <flag {' '.join(flags)}/>",
        f"{indent}</option>",
    ]


def geom_default_xml(physics: PhysicsConfig) -> str:
    """Attributes of the default geom: contact parameters at the nominal damping ratio and
    friction, margin 0."""
    solref = contact_solref(physics.dampratio, physics)
    return (
        f'condim="{physics.condim}" friction="{_vec(geom_friction(physics))}"'
        f' solref="{_vec(solref)}" solimp="{_vec(physics.solimp)}" margin="0" gap="0"'
    )


def actuator_xml(
    site: str,
    refsite: str,
    kv_lin: float,
    kv_rot: float,
    indent: str = "  ",
    prefix: str = "",
    block: bool = True,
) -> list[str]:
    """The six velocity actuators (`<actuator>` block) on `site`, measured against `refsite`
    (the module origin): force = kv (ctrl - velocity) in the module frame, unclamped. Named
    `<prefix>vel0` .. `<prefix>vel5`; `block=False` gives the six lines alone (to put several
    parts' actuators in one block)."""
    lines = [f"{indent}<actuator>"] if block else []
    for k in range(6):
        gear = " ".join("1" if j == k else "0" for j in range(6))
        kv = kv_lin if k < 3 else kv_rot
        lines.append(
            f'{indent}  <velocity name="{prefix}vel{k}" site="{site}" refsite="{refsite}"'
            f' gear="{gear}" kv="{_num(kv)}" ctrllimited="false" forcelimited="false"/>'
        )
    if block:
        lines.append(f"{indent}</actuator>")
    return lines
