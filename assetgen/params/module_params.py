"""Module parameters (paper Table I plus the construction constants) and their validation.

Every length is in metres and every angle in radians, as everywhere inside the project.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields


class ParamError(ValueError):
    """A parameter outside the range the generator can build; the message says what to do."""


def check_range(name: str, value: float, lo: float, hi: float, unit: str, hint: str) -> None:
    """ParamError naming `name`, its value, the range [lo, hi] in `unit` and `hint` (what to
    do) unless the value is finite and in the range."""
    if not math.isfinite(value):
        raise ParamError(f"{name} = {value} is not a finite number; {hint}")
    if not lo <= value <= hi:
        raise ParamError(
            f"{name} = {value:g} {unit} is outside the allowed range "
            f"[{lo:g}, {hi:g}] {unit}; {hint}"
        )


CHAMFER_WALL_SHARE = 0.8
"""An entrance chamfer widens the hole by at most this share of the wall around it (the
chamfer stays inside the pieces that hold the hole's faces)."""


@dataclass(frozen=True)
class ModuleParams:
    """Everything that defines one peg-in-hole module. SI units (m, rad).

    The peg is a regular polygon (circumradius, vertex count) squashed by `aspect_ratio` along
    the in-plane axis at `squash_angle`, extruded to `peg_height`, and scaled by
    `1 - taper` at its bottom face. The hole is that peg's inserted part with every face plane
    moved out by `clearance`, in a 150 x 150 mm plate with a sleeve hanging below it.
    """

    n_vertices: int
    """Cross-section vertex count: 3..8 for polygons, 32 for the "circle" (any 3..64 is built)."""
    circumradius: float
    """Circumradius of the peg's top cross-section before squashing, m (Table I: 0.01-0.03)."""
    aspect_ratio: float
    """Scale along the squash axis, 1 = regular polygon (Table I: 0.25-1.0)."""
    squash_angle: float
    """Angle of the squash axis in the peg's xy plane, rad in [0, pi)."""
    peg_height: float
    """Peg length along its axis, m (Table I: 0.025-0.15)."""
    taper: float
    """Bottom cross-section is (1 - taper) times the top one (Table I: 0-0.25)."""
    hole_depth_fraction: float
    """Hole depth along the hole axis, entrance to floor, as a fraction of peg_height (0.4-0.8)."""
    hole_x: float
    """Hole entrance x in the module frame, m (original code: +-0.025)."""
    hole_y: float
    """Hole entrance y in the module frame, m (original code: +-0.025)."""
    hole_tilt_x: float
    """Hole axis tilt about the module's x axis, rad (Table I: +-15 deg)."""
    hole_tilt_y: float
    """Hole axis tilt about the module's y axis, rad (Table I: +-15 deg)."""
    hole_yaw: float
    """Rotation of the hole about its own axis, rad in [-pi, pi]; this is also the insertion yaw:
    the yaw about the hole axis the peg must have to enter (there is no separate parameter)."""
    clearance: float = 0.001
    """Gap between every peg face and the matching hole face in the design pose, m."""
    plate_size: float = 0.15
    """Side of the square plate, m."""
    plate_thickness: float = 0.005
    """Plate thickness below the mounting surface, m."""
    sleeve_wall: float = 0.005
    """Wall thickness of the sleeve around the hole below the plate, m."""
    floor_thickness: float = 0.005
    """Thickness of the sleeve's floor under the hole, m."""
    peg_chamfer: float = 0.0
    """Length of the chamfer on the peg's tip along the peg's axis, m (0: none, Table I). The
    side faces start this far above the bottom face, where the exact clearance starts; below,
    each side's chamfer face leans in to the bottom face, whose edges move in by
    peg_chamfer * tan(peg_chamfer_angle). The hole is the unchamfered peg's."""
    peg_chamfer_angle: float = math.pi / 4
    """Angle of the chamfer's faces from the side faces they cut, rad (5 - 60 deg)."""
    hole_chamfer: float = 0.0
    """Depth of the chamfer around the hole's entrance below the mounting surface, m (0: none,
    Table I; at most the plate's thickness). Below it the hole's faces are at the exact
    clearance; above, each side face opens by tan(hole_chamfer_angle) per metre of height
    (for a hole square to the plate: a bevel of that angle from the wall)."""
    hole_chamfer_angle: float = math.pi / 4
    """Angle of the entrance chamfer's faces from the hole's side faces, rad (5 - 60 deg)."""

    CHAMFER_FIELDS = (
        ("peg_chamfer", "peg_chamfer_angle"),
        ("hole_chamfer", "hole_chamfer_angle"),
    )
    """Written to module.json only with that chamfer, so Table I's records keep their form."""

    @property
    def hole_depth(self) -> float:
        """Entrance-to-floor distance along the hole axis, m."""
        return self.hole_depth_fraction * self.peg_height

    def to_json(self) -> dict:
        out = asdict(self)
        for length, angle in self.CHAMFER_FIELDS:
            if not out[length]:
                del out[length], out[angle]
        return out

    @staticmethod
    def from_json(d: dict) -> ModuleParams:
        names = {f.name for f in fields(ModuleParams)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise ParamError(f"unknown module parameter(s) {unknown}; valid names: {sorted(names)}")
        return ModuleParams(**d)

    def validate(self) -> ModuleParams:
        """Raise ParamError naming the first value the generator cannot build; return self."""
        hint = "pass a value inside the range or widen the sampler config within it"
        if not isinstance(self.n_vertices, int) or not 3 <= self.n_vertices <= 64:
            raise ParamError(
                f"n_vertices = {self.n_vertices!r} must be an integer in [3, 64] "
                "(Table I uses 3-8 and 32)"
            )
        deg = math.pi / 180
        check_range("circumradius", self.circumradius, 0.002, 0.05, "m", hint)
        check_range("aspect_ratio", self.aspect_ratio, 0.1, 1.0, "", hint)
        check_range("squash_angle", self.squash_angle, -math.pi, math.pi, "rad", hint)
        check_range("peg_height", self.peg_height, 0.005, 0.3, "m", hint)
        check_range("taper", self.taper, 0.0, 0.5, "", hint)
        if math.isfinite(self.hole_depth_fraction) and self.hole_depth_fraction >= 1.0:
            raise ParamError(
                f"hole_depth_fraction = {self.hole_depth_fraction:g} makes the hole deeper than "
                "the peg (>= 1); the peg must stick out to be grasped: use a value in (0.05, 0.95]"
            )
        check_range("hole_depth_fraction", self.hole_depth_fraction, 0.05, 0.95, "", hint)
        check_range("hole_x", self.hole_x, -0.06, 0.06, "m", hint)
        check_range("hole_y", self.hole_y, -0.06, 0.06, "m", hint)
        check_range("hole_tilt_x", self.hole_tilt_x, -30 * deg, 30 * deg, "rad", hint)
        check_range("hole_tilt_y", self.hole_tilt_y, -30 * deg, 30 * deg, "rad", hint)
        check_range("hole_yaw", self.hole_yaw, -math.pi, math.pi, "rad", hint)
        if math.isfinite(self.clearance) and self.clearance <= 0:
            raise ParamError(
                f"clearance = {self.clearance:g} m must be positive (the paper uses 0.001 m); "
                "a peg with no gap cannot be inserted"
            )
        check_range("clearance", self.clearance, 1e-5, 0.005, "m", hint)
        check_range("plate_size", self.plate_size, 0.05, 0.5, "m", hint)
        check_range("plate_thickness", self.plate_thickness, 0.001, 0.05, "m", hint)
        check_range("sleeve_wall", self.sleeve_wall, 0.0005, 0.05, "m", hint)
        check_range("floor_thickness", self.floor_thickness, 0.0005, 0.05, "m", hint)
        check_range("peg_chamfer", self.peg_chamfer, 0.0, 0.5 * self.hole_depth, "m",
                     "the chamfer must end in the hole's lower half; shorten it")  # fmt: skip
        check_range("peg_chamfer_angle", self.peg_chamfer_angle, 5 * deg, 60 * deg, "rad", hint)
        check_range("hole_chamfer", self.hole_chamfer, 0.0, self.plate_thickness, "m",
                     "the entrance chamfer ends within the plate; make it shallower")  # fmt: skip
        check_range("hole_chamfer_angle", self.hole_chamfer_angle, 5 * deg, 60 * deg, "rad", hint)
        width = self.hole_chamfer * math.tan(self.hole_chamfer_angle)
        if width > CHAMFER_WALL_SHARE * self.sleeve_wall:
            raise ParamError(
                f"hole_chamfer = {self.hole_chamfer * 1e3:g} mm at "
                f"{math.degrees(self.hole_chamfer_angle):g} deg widens the entrance by "
                f"{width * 1e3:.3f} mm, more than {CHAMFER_WALL_SHARE:g} of the "
                f"{self.sleeve_wall * 1e3:g} mm wall around the hole: make it shallower or steeper"
            )
        return self
