"""The task and the physics as frozen dataclasses; the defaults are the paper's numbers.

Every number of the task (the paper's, see docs/task.md) lives in `TaskConfig`; how MuJoCo is
made to behave (controller gains, contact softness) lives in `PhysicsConfig`, nested in it.
PhysicsConfig is the project's one MuJoCo configuration (assetgen.core.mujoco_config): the
exported MJCF files carry the same settings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from assetgen.core.mujoco_config import PhysicsConfig
from sim.cameras.config import CameraConfig

__all__ = ["EVAL_CONFIG", "PhysicsConfig", "TaskConfig"]


READINGS: dict[str, tuple[tuple[str, int], ...]] = {
    "wrist": (("wrist_force_noise", 3), ("wrist_torque_noise", 3)),
    "joints": (("joint_position_noise", 7), ("joint_velocity_noise", 7)),
    "peg": (("peg_position_noise", 3), ("peg_rotation_noise", 6)),
}
"""The readings that can join the observation (TaskConfig.readings): each a run of values,
(the TaskConfig field of their noise's std, how many) in order. "wrist" and "joints" are a
robot's; "peg" is every embodiment's."""
ENV_READINGS = ("peg",)
"""Readings the env computes from the pegs' poses, whatever holds them (the rest are the
engine's: a robot's)."""


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
    curriculum_success: float | None = None
    """If set, the spawn ranges follow the training episodes' success instead of the env
    steps (sim/task/curriculum.py): starting at the entrance, they widen by
    `curriculum_increment` of the full ranges whenever `curriculum_window` finished episodes
    succeeded at this rate or more, and narrow by as much below half of it; curriculum_steps
    is then unused."""
    curriculum_increment: float = 0.05
    """Step of the success-gated curriculum, a fraction of the full spawn ranges."""
    curriculum_window: int = 256
    """Finished training episodes between two decisions of the success-gated curriculum."""
    near_starts: float | None = None
    """If set (in (0, 1]), this share of the training episodes starts near the hole: spawned at
    `near_start_scale` of the full ranges, whatever the curriculum's scale, so that an agent
    that has stopped exploring still meets insertions it can complete (the rest spawn as
    without it). None draws nothing more: the episodes are those of a run without it."""
    near_start_scale: float = 0.05
    """The fraction of the full spawn ranges that near starts are drawn in."""
    inside_starts: float | None = None
    """If set (in (0, 1)), this share of the training episodes starts with the peg inside its
    hole: on the hole's axis, turned as it sits on the seat, its bottom drawn uniformly
    between the entrance and twice `success_radius` above the seat. It is a reverse
    curriculum's first stage: a push down succeeds, so the critic meets the success reward
    before the agent can find the hole. These episodes are marked (`info["assisted"]`) and
    left out of the training statistics, the success-gated curriculum and the module replay:
    they say nothing of the task's own starts. None draws nothing more."""
    inside_starts_until: float | None = None
    """If set (in (0, 1]), the inside starts stop for good once `curriculum_window` task
    episodes (inside starts not counted) in a row succeeded at this rate or more
    (sim/task/takeoff_gate.py): a hand-over from the reverse curriculum to the task's own
    starts once the agent has taken off. None: inside starts for the whole run."""
    module_replay: float | None = None
    """If set (in (0, 1]), a rotating env draws this share of its next modules weighted by
    their recent failure rate instead of taking them in turn (sim/task/module_replay.py)."""
    friction_range: tuple[float, float] = (0.0, 1.0)
    """Static and dynamic friction coefficients are each drawn uniformly here at reset.
    MuJoCo has one Coulomb coefficient: it gets the dynamic one (see scene.py)."""
    restitution_range: tuple[float, float] = (0.0, 1.0)
    """Restitution drawn uniformly here at reset, mapped onto the contact damping ratio
    (scene.restitution_to_dampratio: 0 -> physics.dampratio, 1 -> physics.min_dampratio)."""
    dist_pos_weight: float = 0.8
    """Weight of ||t|| (m) in the distance d = w_t ||t|| + w_r ||R - I||_F to the seat."""
    dist_rot_weight: float = 0.2
    """Weight of ||R - I||_F in the distance to the seat."""
    dist_axis_weight: float = 0.0
    """Training shaping, not the paper's: weight of the peg origin's distance from the hole's
    axis (m), added to d. On the plate beside the hole, ||t|| hardly changes as the peg
    slides onto the axis (4 mm off a 20 mm deep seat: 0.4 mm), so the paper's d gives
    almost no reward for finding the hole; this term does. A success's rewards still sum to
    1, and success and failure are unchanged. 0: the paper's d, bit for bit."""
    success_radius: float = 0.005
    """Success: the peg frame's origin within this of the bottom frame's origin, m."""
    failure_depth: float = 0.0025
    """Failure: a peg point this far below the mounting surface outside the hole, m (half
    the plate's thickness: deeper than any contact transient, see task.failed)."""
    failure_reward: float = -1.0
    """Reward of the step that ends an episode in failure."""
    readings: tuple[str, ...] = ()
    """Readings appended to the 18-D observation, in this order, from READINGS: "wrist"
    (the wrist's force N and torque N m on the peg, peg frame: 6 values) and "joints" (the
    arm's joint positions rad and velocities rad/s: 14), a robot's only; "peg" (the peg's
    own pose in the module frame: its position m, then the first two columns of its
    rotation matrix: 9 values), what a robot knows of its hand from its joints
    (proprioception), for every embodiment. Empty: the paper's observation, draw for
    draw."""
    wrist_force_noise: float = 1.0
    """Std of the Gaussian noise on each wrist force reading, N (Forge's 1 N)."""
    wrist_torque_noise: float = 0.05
    """Std of the Gaussian noise on each wrist torque reading, N m."""
    joint_position_noise: float = 0.001
    """Std of the Gaussian noise on each joint position reading, rad."""
    joint_velocity_noise: float = 0.01
    """Std of the Gaussian noise on each joint velocity reading, rad/s."""
    peg_position_noise: float = 0.0005
    """Std of the Gaussian noise on each coordinate of the peg reading's position, m."""
    peg_rotation_noise: float = 0.01
    """Std of the Gaussian noise on each entry of the peg reading's rotation columns (0.01:
    about 0.6 degrees)."""
    camera: CameraConfig | None = None
    """A camera's image appended to the observation after the readings, flattened (channels,
    height, width) with its sensor noise where the task's noise is on (sim/cameras,
    docs/cameras.md). None: no image, and every draw is the paper's."""
    physics: PhysicsConfig | None = None
    """MuJoCo settings. None: the project's physics for the modules' clearance
    (assetgen.core.mujoco_config.physics_for: finer steps for finer clearances), which the
    env resolves from its modules; a PhysicsConfig: exactly that."""

    @property
    def control_dt(self) -> float:
        """Seconds per control step (the physics' substeps x timestep; 50 Hz by default)."""
        p = self.physics or PhysicsConfig()
        return p.timestep * p.substeps

    def curriculum_scale(self, env_steps: int) -> float:
        """Fraction of the full spawn ranges in use after `env_steps` env steps (summed over
        envs): rising linearly over curriculum_steps, 1 without a curriculum."""
        if self.curriculum_steps <= 0:
            return 1.0
        return min(1.0, env_steps / self.curriculum_steps)

    def validate(self) -> TaskConfig:
        if self.physics is not None:
            self.physics.validate()
        checks = {
            "max_steps >= 1": self.max_steps >= 1,
            "curriculum_steps >= 0": self.curriculum_steps >= 0,
            "curriculum_success is None or in (0, 1]": self.curriculum_success is None
            or 0.0 < self.curriculum_success <= 1.0,
            "0 < curriculum_increment <= 1": 0.0 < self.curriculum_increment <= 1.0,
            "curriculum_window >= 1": self.curriculum_window >= 1,
            "near_starts is None or in (0, 1]": self.near_starts is None
            or 0.0 < self.near_starts <= 1.0,
            "0 <= near_start_scale <= 1": 0.0 <= self.near_start_scale <= 1.0,
            "inside_starts is None or in (0, 1)": self.inside_starts is None
            or 0.0 < self.inside_starts < 1.0,
            "inside_starts_until is None, or in (0, 1] with inside_starts set": (
                self.inside_starts_until is None
                or (self.inside_starts is not None and 0.0 < self.inside_starts_until <= 1.0)
            ),
            "dist_axis_weight >= 0 and finite": math.isfinite(self.dist_axis_weight)
            and self.dist_axis_weight >= 0.0,
            f"readings from {sorted(READINGS)}, each once": set(self.readings) <= set(READINGS)
            and len(set(self.readings)) == len(self.readings),
            "reading noises >= 0": all(
                getattr(self, field) >= 0 for run in READINGS.values() for field, _ in run
            ),
            "module_replay is None or in (0, 1]": self.module_replay is None
            or 0.0 < self.module_replay <= 1.0,
            "spawn_z low <= high": self.spawn_z[0] <= self.spawn_z[1],
            "success_radius > 0": self.success_radius > 0,
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"TaskConfig: these must hold: {bad}")
        if self.camera is not None:
            self.camera.validate()
        return self


EVAL_CONFIG = TaskConfig(curriculum_steps=0)
"""The paper's evaluation protocol: noise on, full spawn ranges (no curriculum)."""


def reading_noise(cfg: TaskConfig) -> np.ndarray:
    """(k,) the noise std of each value cfg.readings adds to the observation, in order."""
    return np.array(
        [getattr(cfg, field) for r in cfg.readings for field, n in READINGS[r] for _ in range(n)]
    )
