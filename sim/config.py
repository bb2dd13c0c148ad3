"""The task and the physics as frozen dataclasses; the defaults are the paper's numbers.

Every number of the task (the paper's, see docs/task.md) lives in `TaskConfig`; how MuJoCo is
made to behave (controller gains, contact softness) lives in `PhysicsConfig`, nested in it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


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
    that damping (h kv ~ M) diluted each contact impulse and a full-speed impact sank
    1.9 mm instead of <= 1.1 mm (measured, see scene.py)."""
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
    spun knocked pegs up to km/s; past the limit only a contact's knock can take the peg."""
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
    (The "solref[0] >= 2 timestep" rule belongs to the continuous-time integrators, whose
    explicit constraint spring it keeps stable.) At full speed the transient penetration
    stays within one physics step's travel (1.25 mm); 2 x timestep would give ~1.9 mm."""
    solimp: tuple[float, float, float, float, float] = (0.99, 0.9999, 0.0005, 0.5, 2.0)
    """Contact impedance (dmin, dmax, width m, midpoint, power). An impedance near 1 makes the
    constraint nearly hard: steady penetration = F (1 - d) / (d^2 k m_eff), micrometres at
    the force limit, where the default (0.9, 0.95, 0.001) lets a 0.2 kg peg sink ~0.4 mm."""
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
    10 x this (rad/s) has left physics: its env is reset and reported unstable like a
    non-finite one. No contact of a 9 N controller comes near it; a solver blow-up passes it
    within a step or two (pegs that spun up reached km/s), before such states reach a
    learner."""
    multiccd: bool = True
    """Several contacts per convex pair, so a flat face rests on a flat face without
    rocking on one point."""
    min_dampratio: float = 0.85
    """Contact damping ratio at restitution 1 (restitution 0: 1.0, linear between). Below
    ~0.8 a peg pushed into a wall chatters forever at 200 Hz (see scene.py)."""


@dataclass(frozen=True)
class TaskConfig:
    """The peg-in-hole task (the paper's numbers, see docs/task.md). Units: m, s, rad."""

    max_steps: int = 500
    """Control steps per episode before truncation (10 s at 50 Hz)."""
    max_lin_vel: float = 0.25
    """Action 1.0 on a linear axis, m/s."""
    max_ang_vel: float = math.radians(90.0)
    """Action 1.0 on an angular axis, rad/s."""
    obs_pos_noise: float = 0.0005
    """Std of the Gaussian position error of the estimated peg pose, m (0.5 mm)."""
    obs_rot_noise: float = math.radians(1.0)
    """Std of each component of the rotation-vector error of the estimated pose, rad."""
    act_lin_noise: float = 0.0005
    """Std of the Gaussian error on each executed linear velocity component, m/s."""
    act_ang_noise: float = math.radians(1.0)
    """Std of the Gaussian error on each executed angular velocity component, rad/s."""
    noise: bool = True
    """Observation and command noise on (off for exact tests)."""
    spawn_xy: float = 0.25
    """Spawn x, y within +- this of the entrance, m."""
    spawn_z: tuple[float, float] = (0.15, 0.25)
    """Spawn height above the entrance, m (uniform)."""
    spawn_max_angle: float = math.pi
    """Spawn orientation: a random axis and an angle uniform in [0, this], rad."""
    curriculum_steps: int = 50_000_000
    """Environment steps (summed over envs) over which the spawn ranges grow linearly from
    zero to full; 0 turns the curriculum off (full ranges from the start)."""
    friction_range: tuple[float, float] = (0.0, 1.0)
    """Static and dynamic friction coefficients are each drawn uniformly here at reset.
    MuJoCo has one Coulomb coefficient: it gets the dynamic one (see scene.py)."""
    restitution_range: tuple[float, float] = (0.0, 1.0)
    """Restitution drawn uniformly here at reset, mapped onto the contact damping ratio
    (scene.restitution_to_dampratio: 0 -> 1.0, 1 -> physics.min_dampratio)."""
    dist_pos_weight: float = 0.8
    """Weight of ||t|| (m) in the distance d = w_t ||t|| + w_r ||R - I||_F to the seat."""
    dist_rot_weight: float = 0.2
    """Weight of ||R - I||_F in the distance to the seat."""
    success_radius: float = 0.005
    """Success: the peg frame's origin within this of the bottom frame's origin, m."""
    failure_depth: float = 0.0025
    """Failure: a peg point this far below the mounting surface outside the hole, m (half
    the plate's thickness: deeper than any contact transient, see task.failed)."""
    failure_reward: float = -1.0
    """Reward of the step that ends an episode in failure."""
    physics: PhysicsConfig = field(default_factory=PhysicsConfig)
    """MuJoCo settings."""

    @property
    def control_dt(self) -> float:
        """Seconds per control step."""
        return self.physics.timestep * self.physics.substeps

    def validate(self) -> TaskConfig:
        p = self.physics
        checks = {
            "max_steps >= 1": self.max_steps >= 1,
            "substeps >= 1": p.substeps >= 1,
            "timestep > 0": p.timestep > 0,
            "runaway_speed > 0": p.runaway_speed > 0,
            "contact_timeconst >= timestep": p.contact_timeconst >= p.timestep - 1e-12,
            "contact_timeconst >= 2 timestep unless integrator is discrete": (
                p.integrator == "discrete" or p.contact_timeconst >= 2 * p.timestep - 1e-12
            ),
            "integrator in (discrete, implicitfast, implicit, Euler)": p.integrator
            in ("discrete", "implicitfast", "implicit", "Euler"),
            "curriculum_steps >= 0": self.curriculum_steps >= 0,
            "spawn_z low <= high": self.spawn_z[0] <= self.spawn_z[1],
            "success_radius > 0": self.success_radius > 0,
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"TaskConfig: these must hold: {bad}")
        return self


EVAL_CONFIG = TaskConfig(curriculum_steps=0)
"""The paper's evaluation protocol: noise on, full spawn ranges (no curriculum)."""
