"""The one MuJoCo configuration of the project: what the simulator (sim) trains on and what
the exported `peg_in_hole.xml` (assetgen.formats.mjcf) carries, so that `assetgen physics`
checks the physics the agents train on.

Dependency-free apart from numpy (and mujoco for `apply_to_spec`): sim imports it without the
geometry code, assetgen imports it without sim. Two writers, one source:

    apply_to_spec(spec, physics)      the option block, on a mujoco.MjSpec (the simulator's scene)
    option_xml(physics)               the same as MJCF text (assetgen/formats/mjcf.py)
    contact_solref(z, physics)        geom solref for damping ratio z (k fixed)
    velocity_gains(m, com, I, ...)    the six velocity actuators' kv (linear, angular)
    actuator_xml(...)                 those actuators as MJCF text

tests/test_physics_config.py compiles an exported module and the simulator's model of the
same module and compares model.opt, the peg geom's contact parameters and the actuators.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from assetgen.core.portable import dot as portable_dot
from assetgen.core.portable import symmetric_eigen
from assetgen.core.xml_text import xml_number, xml_vector

INTEGRATORS = ("discrete", "implicitfast", "implicit", "Euler")


@dataclass(frozen=True)
class PhysicsConfig:
    """MuJoCo settings: integration, the velocity controller and contact softness."""

    timestep: float = 0.0005
    """Physics step, s (2 kHz). MuJoCo finds a contact only once the surfaces overlap, so a
    peg meeting a wall at full speed (0.25 m/s) is up to one step's travel inside it before
    the contact acts: 0.125 mm at this step. Chosen with the contact stress benchmark
    (`assetgen bench contacts`, docs/physics.md): the largest step that keeps transient
    penetration within a quarter of a 0.5 mm clearance and half of 0.25 mm at p99."""
    substeps: int = 40
    """Physics steps per control step (50 Hz control), run in C with no Python between."""
    integrator: str = "discrete"
    """MuJoCo integrator. `discrete` solves the contacts in the same effective inertia
    (M + h D) that integrates the controller's damping implicitly; under `implicitfast`
    that damping dilutes each contact impulse (measured at 5 ms steps: a full-speed impact
    sank 1.9 mm instead of 1.1 mm)."""
    tracking_time_constant: float = 0.005
    """Time constant of the velocity controller, s: kv = mass / tau (linear) and
    I_max / tau (angular, I_max the largest principal inertia about the bottom-face centre),
    each capped so no command asks for more than `force_limit`. The damping is integrated
    implicitly, so any timestep is stable with it."""
    force_limit: float = 20.0
    """Most force a command can ask of a linear actuator, N: the gain is capped at
    force_limit / (2.2 x max_lin_vel), so even a full command reversal stays below it, and
    pushing into a wall at full command presses with kv x max_lin_vel = 9.1 N at most. The
    actuator is not clamped to it (see sim/engines/mujoco/scene.py): a clamped damper integrated
    implicitly spins knocked pegs up to km/s; past the limit only a contact's knock can take the
    peg."""
    torque_limit: float = 1.5
    """Most torque a command can ask of an angular actuator, N m (gain capped as for the
    force)."""
    contact_margin: float = 0.0
    """Distance (m) from which MuJoCo detects a contact (its geom gap equals it, so a contact
    acts only on penetration and the clearance stays exact). 0: any positive margin, down
    to 1 nm, takes MuJoCo 4.0's convex collision down another path, on which the sliding
    friction of the stress benchmark read up to 2.3 times the configured coefficient."""
    contact_timeconst: float = 0.001
    """Contact stiffness time constant T0, s: every contact spring has k = 1 / T0^2 and
    solref = (T0 / zeta, zeta) for its damping ratio zeta, so solref[0] * solref[1] = T0.
    Under the `discrete` integrator a row is resolvable (kept as authored) when
    solref[0] * solref[1] >= timestep. Two timesteps: one (the stiffest) pushes the
    penetration found at detection back out within a step, and a peg thrown at a wall with
    the actuators off rebounds at e = 0.12; at two it is 0.09 (the stress benchmark)."""
    dampratio: float = 5.0
    """Nominal contact damping ratio (restitution 0): the exported file's, and the
    simulator's before its per-reset draw. Overdamped: below ~3 a peg thrown at a wall
    rebounds faster than a tenth of its speed (the stress benchmark)."""
    min_dampratio: float = 4.0
    """Contact damping ratio at restitution 1 (restitution 0: `dampratio`, linear between):
    the draw randomises the damping over the range whose rebound stays near e = 0.1."""
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
    impratio: float = 100.0
    """Frictional-to-normal impedance ratio: > 1 makes friction stiffer (less creep). At 10
    a peg pressed into a corner crept down the walls at ~10 um/s; at 100 it holds."""
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
    nativeccd: bool = True
    """MuJoCo's own convex collision (GJK/EPA) for mesh pairs; False: libccd's."""
    ccd_iterations: int = 35
    """Iterations of the convex collision's distance and penetration search (MuJoCo's
    default; the MJCF names it only when it differs)."""
    ccd_tolerance: float = 1e-6
    """Tolerance (m) of that search (MuJoCo's default; the MJCF names it only when it
    differs)."""

    @property
    def refsafe(self) -> bool:
        """MuJoCo's refsafe flag. Under `discrete` every contact row is resolvable by
        construction (solref[0] * solref[1] = T0 >= h); with refsafe on, rounding of
        T0 / zeta * zeta just below h would swap a row for MuJoCo's replacement spring,
        which makes a pressed peg chatter. Kept on for the continuous-time integrators."""
        return self.integrator != "discrete"

    def validate(self) -> PhysicsConfig:
        """ValueError naming each setting out of range, with a value that would work."""
        h, t0 = self.timestep, self.contact_timeconst
        rows = [
            (self.timestep > 0, f"timestep = {h!r}: give a positive step in seconds, e.g. 0.001"),
            (self.substeps >= 1, f"substeps = {self.substeps!r}: give at least 1"),
            (
                self.runaway_speed > 0,
                f"runaway_speed = {self.runaway_speed!r}: give a positive speed, e.g. 10",
            ),
            (
                self.integrator in INTEGRATORS,
                f"integrator = {self.integrator!r}: use one of {list(INTEGRATORS)}",
            ),
            (
                self.integrator != "discrete" or t0 >= h - 1e-12,
                f"contact_timeconst = {t0!r} s is below the timestep {h!r} s: the discrete "
                f"integrator cannot resolve such a spring; use contact_timeconst >= {h!r} "
                f"(or timestep <= {t0!r})",
            ),
            (
                self.integrator == "discrete" or t0 >= 2 * h - 1e-12,
                f"contact_timeconst = {t0!r} s is below twice the timestep under "
                f"{self.integrator!r}: use contact_timeconst >= {2 * h!r} (or timestep <= "
                f"{t0 / 2!r}, or integrator 'discrete')",
            ),
            (
                self.cone in ("elliptic", "pyramidal"),
                f"cone = {self.cone!r}: use 'elliptic' or 'pyramidal'",
            ),
            (
                0 < self.min_dampratio <= self.dampratio,
                f"min_dampratio = {self.min_dampratio!r}, dampratio = {self.dampratio!r}: "
                f"need 0 < min_dampratio <= dampratio, e.g. min_dampratio = {self.dampratio!r}",
            ),
            (
                min(self.friction, self.torsional_friction, self.rolling_friction) >= 0,
                "friction, torsional_friction and rolling_friction must be >= 0",
            ),
            (self.impratio >= 1, f"impratio = {self.impratio!r}: give 1 or more"),
            (
                self.ccd_iterations >= 1,
                f"ccd_iterations = {self.ccd_iterations!r}: give at least 1, e.g. 35",
            ),
            (
                self.ccd_tolerance > 0,
                f"ccd_tolerance = {self.ccd_tolerance!r}: give a positive length in metres, "
                "e.g. 1e-6",
            ),
            (
                0 <= self.contact_margin < 1e-4,
                f"contact_margin = {self.contact_margin!r} m: give 0 to 1e-4, e.g. 1e-6",
            ),
            (self.iterations >= 1, f"iterations = {self.iterations!r}: give at least 1"),
        ]
        bad = [msg for ok, msg in rows if not ok]
        if bad:
            raise ValueError("PhysicsConfig: " + "; ".join(bad))
        return self


# ----------------------------------------------------------------------------- per clearance

CLEARANCE_TIMESTEPS: tuple[tuple[float, float], ...] = ((1e-3, 0.0005), (0.0, 0.00025))
"""(clearance from, m; timestep, s) rows: a module is stepped at the timestep of the first row
whose clearance its own reaches: 0.5 ms from 1 mm up, 0.25 ms below. What set them (the
contact stress benchmark, docs/physics.md): a peg pressed into an acute corner of its hole
stays as deep as the impact left it (friction wedges it), so the depth at rest follows the
transient, which follows the step; at 0.5 ms the depth at rest is 7 % of a 0.5 mm and 14 %
of a 0.25 mm clearance, at 0.25 ms 3 % of 0.25 mm."""


def physics_for(clearance: float, base: PhysicsConfig | None = None) -> PhysicsConfig:
    """The physics a module of this clearance (m) is simulated with: `base` (the defaults)
    with the timestep of CLEARANCE_TIMESTEPS, the control period kept (more substeps) and
    the contact time constant kept at the same multiple of the timestep."""
    base = base or PhysicsConfig()
    if not (math.isfinite(clearance) and clearance > 0):
        raise ValueError(f"clearance = {clearance!r}: give a positive gap in metres")
    h = next(t for lo, t in CLEARANCE_TIMESTEPS if clearance >= lo - 1e-12)
    period = base.timestep * base.substeps
    return replace(
        base,
        timestep=h,
        substeps=max(1, round(period / h)),
        contact_timeconst=h * (base.contact_timeconst / base.timestep),
    )


# ----------------------------------------------------------------------------- versions

PHYSICS_VERSION = 2
"""Version of the project's physics: PhysicsConfig's defaults and `physics_for`. Every
dataset.json and every exported MJCF records it; the simulator refuses a dataset of another
version unless told to keep that dataset's physics. Bump it with any change to either."""

LEGACY_PHYSICS: dict[int, dict] = {
    1: {"timestep": 0.005, "substeps": 4, "contact_timeconst": 0.005, "dampratio": 1.0,
        "min_dampratio": 0.85, "impratio": 10.0},
}  # fmt: skip
"""Earlier versions' settings where they differ from the defaults' fields. Version 1: the
physics of generator 0.5.0 and before (5 ms steps), whose datasets record no version."""


def physics_record(physics: PhysicsConfig, version: int = PHYSICS_VERSION) -> dict:
    """`physics` as JSON (dataset.json), with its version."""
    d = asdict(physics)
    d["solimp"] = list(physics.solimp)
    return {"version": version, **d}


def physics_from_record(record: dict | None) -> tuple[int, PhysicsConfig]:
    """(version, PhysicsConfig) of a dataset.json record; None (a dataset older than the
    record) is version 1. ValueError for a malformed record."""
    if record is None:
        return 1, replace(PhysicsConfig(), **LEGACY_PHYSICS[1])
    try:
        fields = {k: v for k, v in record.items() if k != "version"}
        if "solimp" in fields:
            fields["solimp"] = tuple(fields["solimp"])
        return int(record["version"]), PhysicsConfig(**fields).validate()
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"a malformed physics record ({e}); regenerate the dataset") from None


def describe(physics: PhysicsConfig) -> str:
    """A short summary for messages: `1 ms steps, T0 1 ms, zeta 3`."""
    return (
        f"{physics.timestep * 1e3:g} ms steps, contact T0 {physics.contact_timeconst * 1e3:g} ms, "
        f"damping ratio {physics.dampratio:g}"
    )


# ----------------------------------------------------------------------------- derived values


def contact_solref(dampratio, physics: PhysicsConfig) -> np.ndarray:
    """(..., 2) solref for the given damping ratios with the stiffness k = 1/T0^2 fixed."""
    z = np.asarray(dampratio, dtype=float)
    return np.stack([physics.contact_timeconst / z, z], axis=-1)


def geom_friction(physics: PhysicsConfig, sliding: float | None = None) -> list[float]:
    """(sliding, torsional, rolling) friction of the peg geom."""
    s = physics.friction if sliding is None else sliding
    return [float(s), physics.torsional_friction, physics.rolling_friction]


def material(physics: PhysicsConfig | None = None) -> tuple[float, float, float]:
    """(static friction, dynamic friction, restitution) of the physics material the USD
    files carry: the MJCF's nominal sliding friction for both, and restitution 0 (the
    MJCF's damping ratio is the restitution draw's e = 0 end)."""
    p = physics or PhysicsConfig()
    return (p.friction, p.friction, 0.0)


def velocity_gains(
    mass: float,
    com: np.ndarray,
    inertia: np.ndarray,
    physics: PhysicsConfig,
    max_lin_vel: float = 0.25,
    max_ang_vel: float = math.pi / 2,
    portable: bool = False,
) -> tuple[float, float]:
    """(kv_lin, kv_rot) of the six velocity actuators on the peg's bottom-face centre.

    Linear: mass / tau; angular: the largest principal inertia about the bottom-face centre
    (`com` m and `inertia` kg m^2 about the COM, both in the peg frame) / tau; each capped so
    a reversal from -max to +max velocity asks for at most the force/torque limit (2.2:
    margin). portable: the moments by assetgen.core.portable (the same bits on every CPU);
    False: numpy's BLAS and LAPACK, as Table I's pinned files (see MassProperties.principal).
    """
    c = np.asarray(com, dtype=float)
    # parallel-axis theorem: I_site = I_com + m (|c|^2 I - c c^T)
    cc = float(portable_dot(c, c)) if portable else np.dot(c, c)
    i_site = np.asarray(inertia, dtype=float) + mass * (cc * np.eye(3) - np.outer(c, c))
    biggest = symmetric_eigen(i_site)[0][-1] if portable else np.linalg.eigvalsh(i_site).max()
    kv_lin = min(mass / physics.tracking_time_constant, physics.force_limit / (2.2 * max_lin_vel))
    kv_rot = min(
        float(biggest / physics.tracking_time_constant),
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
    opt.ccd_iterations = physics.ccd_iterations
    opt.ccd_tolerance = physics.ccd_tolerance
    if not physics.multiccd:
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_MULTICCD
    if not physics.nativeccd:
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_NATIVECCD
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    if not physics.refsafe:
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_REFSAFE
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE


# ----------------------------------------------------------------------------- MJCF text writer


def _ccd_attributes(physics: PhysicsConfig) -> str:
    """The convex collision's search settings as `<option>` attributes, where they differ
    from MuJoCo's defaults (files written before the fields keep their bytes)."""
    default = PhysicsConfig()
    out = ""
    if physics.ccd_iterations != default.ccd_iterations:
        out += f' ccd_iterations="{physics.ccd_iterations}"'
    if physics.ccd_tolerance != default.ccd_tolerance:
        out += f' ccd_tolerance="{xml_number(physics.ccd_tolerance)}"'
    return out


def option_xml(physics: PhysicsConfig, indent: str = "  ") -> list[str]:
    """The `<option>` element (with its `<flag>`) as MJCF lines: what apply_to_spec sets."""
    flags = [
        f'multiccd="{"enable" if physics.multiccd else "disable"}"',
        *([] if physics.nativeccd else ['nativeccd="disable"']),
        'autoreset="disable"',
    ]
    if not physics.refsafe:
        flags.append('refsafe="disable"')
    return [
        f'{indent}<option timestep="{xml_number(physics.timestep)}" gravity="0 0 0"'
        f' integrator="{physics.integrator}" solver="Newton"'
        f' iterations="{physics.iterations}" cone="{physics.cone}"'
        f' impratio="{xml_number(physics.impratio)}"'
        f' noslip_iterations="{physics.noslip_iterations}"'
        f"{_ccd_attributes(physics)}>",
        f"{indent}  <flag {' '.join(flags)}/>",
        f"{indent}</option>",
    ]


PHYSICS_TEXT = "physics_version"
"""Name of the MJCF `<text>` custom field that holds PHYSICS_VERSION."""


def physics_version_xml(indent: str = "    ") -> str:
    """The `<text>` element (inside `<custom>`) recording the physics version."""
    return f'{indent}<text name="{PHYSICS_TEXT}" data="assetgen physics {PHYSICS_VERSION}"/>'


def geom_default_xml(physics: PhysicsConfig) -> str:
    """Attributes of the default geom: contact parameters at the nominal damping ratio and
    friction, the detection margin (inactive until penetration: gap = margin)."""
    solref = contact_solref(physics.dampratio, physics)
    return (
        f'condim="{physics.condim}" friction="{xml_vector(geom_friction(physics))}"'
        f' solref="{xml_vector(solref)}" solimp="{xml_vector(physics.solimp)}"'
        f' margin="{xml_number(physics.contact_margin)}" gap="{xml_number(physics.contact_margin)}"'
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
            f' gear="{gear}" kv="{xml_number(kv)}" ctrllimited="false" forcelimited="false"/>'
        )
    if block:
        lines.append(f"{indent}</actuator>")
    return lines
