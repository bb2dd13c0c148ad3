"""The PhysX settings of the referee engine (sim/engines/physx/batch.py), in PhysX's own terms.

MuJoCo's `PhysicsConfig` describes a soft-contact engine (time constants, damping ratios,
impedance); PhysX's contacts are rigid constraints found ahead of time within a contact
offset, so its settings are different quantities and live here, in one place. The task
(spawn, noise, gains, limits, success and failure) is the same `TaskConfig` for both.
docs/physics.md gives the reason for each choice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class PhysxConfig:
    """PhysX 5 (SAPIEN 3, CPU) settings for the peg-in-hole scenes."""

    timestep: float = 0.001
    """Physics step, s. PhysX finds contacts ahead of time (within `contact_offset`), so a
    peg at the task's top speed (0.25 m/s) cannot pass a wall between two steps as long as
    it moves less than the offset in one: 0.25 mm a step here against a 2 mm offset."""
    position_iterations: int = 16
    """Solver position iterations per step (TGS; PhysX's default is 4, Isaac Lab's Factory
    tasks use 192 at 1/120 s)."""
    velocity_iterations: int = 1
    """Solver velocity iterations per step (PhysX's default)."""
    contact_offset: float = 0.002
    """m: shapes closer than the sum of their offsets get (speculative) contacts. It must
    exceed a step's travel at the top speed; larger offsets give more contact points."""
    rest_offset: float = 0.0
    """m: surfaces come to rest this far apart (0: touching, so the clearance is the
    file's)."""
    bounce_threshold: float = 0.2
    """m/s: below this relative speed PhysX applies no restitution (Isaac Sim's default;
    the task's speeds are at most 0.25 m/s, so restitution acts only on the fastest
    impacts, as in the original)."""
    max_depenetration_velocity: float = 1.0
    """m/s: the most speed PhysX may give a body to push it out of a penetration."""
    pcm: bool = True
    """PhysX's persistent contact manifold (PCM), Isaac Sim's default. On, it reported
    contacts as deep as a peg's insertion (24.7 mm) along the hole's axis in one module's
    pushes, and up to 72 mm in impacts; off, those runs read micrometres but sliding
    friction goes wrong (docs/physics.md)."""
    cook_scale: float = 100.0
    """Convex meshes are cooked scaled up by this factor and scaled back in the shape:
    PhysX's cooking merges vertices within about 0.7 mm of the hull, more than the
    clearances simulated; scaled, every corner of the pieces and the peg survives (checked
    per shape: a mesh that loses a vertex is refused)."""
    cpu_workers: int = 0
    """PhysX worker threads (0: the calling thread only)."""
    spacing: float = 0.5
    """m between neighbouring envs on the scene's grid. Envs collide only with their own
    module (collision groups); the spacing keeps the broad phase from pairing every peg
    with every module."""

    def validate(self, control_dt: float) -> PhysxConfig:
        """Raise ValueError naming a setting PhysX cannot use, with one that works."""
        steps = control_dt / self.timestep if self.timestep > 0 else 0.0
        if not (self.timestep > 0 and math.isclose(steps, round(steps), rel_tol=1e-9)):
            raise ValueError(
                f"timestep = {self.timestep}: must divide the control step {control_dt} s "
                f"into whole steps, e.g. {control_dt / max(1, round(steps or 1))}"
            )
        if self.position_iterations < 1 or self.velocity_iterations < 0:
            raise ValueError(
                f"position_iterations = {self.position_iterations}, velocity_iterations = "
                f"{self.velocity_iterations}: need at least 1 and 0 (e.g. 16 and 1)"
            )
        if not (0 <= self.rest_offset < self.contact_offset):
            raise ValueError(
                f"rest_offset = {self.rest_offset}, contact_offset = {self.contact_offset}: "
                "need 0 <= rest_offset < contact_offset (e.g. 0 and 0.002 m)"
            )
        if self.cook_scale < 1 or self.spacing <= 0 or self.bounce_threshold < 0:
            raise ValueError(
                f"cook_scale = {self.cook_scale}, spacing = {self.spacing}, bounce_threshold "
                f"= {self.bounce_threshold}: need cook_scale >= 1 (e.g. 100), spacing > 0 "
                "and bounce_threshold >= 0"
            )
        return self

    def substeps(self, control_dt: float) -> int:
        """Physics steps per control step."""
        return round(control_dt / self.timestep)
