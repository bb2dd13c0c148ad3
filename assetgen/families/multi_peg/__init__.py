"""The `multi-peg` family: a carrier with 2-4 parallel pegs into their holes in one plate,
each at the exact clearance (dowel pins, connectors).

Module frame as Table I's (the plate's top face is z = 0, 15 x 15 cm, 5 mm thick). The pegs
stand under a carrier plate; each is a convex prism (an n-gon, 3-8 sides, or Table I's
32-gon "circle"), its hole the prism's clearance hole (every face moved out by the
clearance: assetgen.geometry.clearance_hole), cut through the plate into one sleeve under
all of them (5 mm walls and floor). The holes share one axis direction, tilted, turned and
offset as Table I samples its hole (the tilt to 10 degrees: a wide carrier must stay clear of
the plate when seated).

The part's frame is the reference peg's (the first): the centre of its bottom face, z up the
pegs. The step's entrance and bottom frames are the reference hole's, so the task observes
the carrier exactly as it observes a peg: the 18-D observation and every agent carry over.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace

import numpy as np

from assetgen.core.frames import Frame
from assetgen.core.portable import matmul
from assetgen.families.interface import Family
from assetgen.families.parts import Assembly, Part, Step
from assetgen.families.profile import (
    PLATE_SIZE,
    PLATE_THICKNESS,
    REACH,
    frames,
    plate,
    prism,
    section_planes,
    sleeve,
    sleeve_reach,
)
from assetgen.geometry.clearance_hole import clearance_hole
from assetgen.geometry.polytope import polytope_vertices
from assetgen.params.module_params import ParamError, check_range
from assetgen.params.sampler import ChamferRanges, OneClearance, check_ranges

DEG = math.pi / 180
CARRIER = 0.008
"""Carrier plate thickness, m."""
MARGIN = 0.004
"""Carrier beyond the pegs' sections, m."""
EMBED = 0.001
"""m each peg reaches into the carrier (solids that only touch on a face leave slivers)."""
CLEAR = 0.002
"""The least gap (m) between the seated carrier and the plate's top."""
ROUND = 32
"""Sides of a "circle" peg (Table I's)."""


def section(n: int, radius: float, angle: float) -> np.ndarray:
    """A regular n-gon (counter-clockwise) of circumradius `radius`, turned by `angle`."""
    t = angle + 2 * math.pi * np.arange(n) / n
    return radius * np.column_stack([np.cos(t), np.sin(t)])


@dataclass(frozen=True)
class MultiPegParams:
    """One multi-peg module. SI units (m, rad)."""

    pegs: tuple[tuple[float, float, int, float, float], ...]
    """Per peg: its axis's x and y in the carrier frame (the first at the origin, the
    reference), its polygon's sides (3-8, or 32 for a circle), circumradius (4-10 mm) and
    turn about its axis."""
    peg_length: float
    """Length of the pegs under the carrier, m (0.02 - 0.045)."""
    depth_fraction: float
    """Hole depth along the axis, fraction of the peg length (0.3 - 0.6)."""
    hole_x: float
    """The reference hole's entrance x, m (-0.025 - 0.025)."""
    hole_y: float
    """The reference hole's entrance y, m (-0.025 - 0.025)."""
    hole_tilt_x: float
    """Tilt of the holes' axis about the module's x, rad (-10 - 10 deg)."""
    hole_tilt_y: float
    """Tilt about the module's y, rad (-10 - 10 deg)."""
    hole_yaw: float
    """Turn of the pattern about the axis, rad (-pi - pi)."""
    clearance: float = 1e-3
    """Gap between each peg and its hole, m (0 - 5 mm)."""
    peg_chamfer: float = 0.0
    """Length of the chamfer on every peg's tip along the axis, m (0: none; at most half the
    hole's depth). The side faces, and the exact clearance, start this far above the tip;
    below, each side's chamfer face leans in to the tip, whose edges move in by
    peg_chamfer * tan(peg_chamfer_angle). Each hole is its unchamfered peg's."""
    peg_chamfer_angle: float = math.pi / 4
    """Angle of the chamfer's faces from the side faces, rad (5 - 60 deg)."""
    hole_chamfer: float = 0.0
    """Depth of the chamfer around every hole's entrance below the surface, m (0: none; at
    most the plate's 5 mm). Above it each side face of a hole opens by tan(hole_chamfer_angle)
    per metre of height, as Table I's entrance chamfer; below it the holes are exact."""
    hole_chamfer_angle: float = math.pi / 4
    """Angle of the entrance chamfer's faces from the holes' side faces, rad (5 - 60 deg)."""

    @property
    def hole_depth(self) -> float:
        return self.depth_fraction * self.peg_length

    @property
    def chamfer_inset(self) -> float:
        """How far the chamfer moves each peg tip's edges in, m."""
        return self.peg_chamfer * math.tan(self.peg_chamfer_angle)

    def validate(self) -> MultiPegParams:
        if not 2 <= len(self.pegs) <= 4:
            raise ParamError(f"pegs: {len(self.pegs)} given; a carrier holds 2 to 4")
        ranges = {
            "peg_length": (0.02, 0.045),
            "depth_fraction": (0.3, 0.6),
            "hole_x": (-0.025, 0.025),
            "hole_y": (-0.025, 0.025),
            "hole_tilt_x": (-10 * DEG, 10 * DEG),
            "hole_tilt_y": (-10 * DEG, 10 * DEG),
            "hole_yaw": (-math.pi, math.pi),
        }
        for name, (lo, hi) in ranges.items():
            v = getattr(self, name)
            if not (isinstance(v, int | float) and lo - 1e-12 <= v <= hi + 1e-12):
                raise ParamError(f"{name} = {v!r} is outside [{lo:g}, {hi:g}]")
        if not 0 < self.clearance <= 0.005:
            raise ParamError(f"clearance = {self.clearance:g} m; give a gap in (0, 0.005] m")
        for k, (x, y, n, r, _) in enumerate(self.pegs):
            if k == 0 and (x, y) != (0.0, 0.0):
                raise ParamError(f"peg 0 (the reference) sits at ({x:g}, {y:g}); put it at 0, 0")
            if n not in (*range(3, 9), ROUND) or not 0.004 <= r <= 0.01:
                raise ParamError(
                    f"peg {k}: {n} sides, circumradius {r * 1e3:g} mm; give 3-8 sides or "
                    f"{ROUND}, and 4-10 mm"
                )
        if self.peg_chamfer:
            self._check_chamfer()
        if self.hole_chamfer:
            self._check_hole_chamfer()
        for i in range(len(self.pegs)):
            for j in range(i):
                (xi, yi, _, ri, _), (xj, yj, _, rj, _) = self.pegs[i], self.pegs[j]
                gap = math.hypot(xi - xj, yi - yj) - ri - rj - 2 * self.clearance
                if gap < 0.004:
                    raise ParamError(
                        f"pegs {j} and {i}: their holes are {gap * 1e3:.1f} mm apart; at least "
                        "4 mm of plate between them"
                    )
        return self

    def _check_chamfer(self) -> None:
        """ParamError where the chamfer is out of its ranges or a peg's tip cannot take it
        (its edges would move in by more than CHAMFER_FILL of its inradius)."""
        check_range("peg_chamfer", self.peg_chamfer, 0.0, 0.5 * self.hole_depth, "m",
                    "the chamfer must end in the hole's lower half; shorten it")  # fmt: skip
        check_range("peg_chamfer_angle", self.peg_chamfer_angle, 5 * DEG, 60 * DEG, "rad",
                    "give 5-60 deg")  # fmt: skip
        for k, (_, _, n, r, _) in enumerate(self.pegs):
            limit = CHAMFER_FILL * r * math.cos(math.pi / n)  # a regular n-gon's inradius
            if self.chamfer_inset > limit:
                raise ParamError(
                    f"peg {k}: the chamfer moves its tip's edges in by "
                    f"{self.chamfer_inset * 1e3:.3f} mm; its {n}-gon of {r * 1e3:g} mm takes "
                    f"at most {limit * 1e3:.3f} mm: shorten the chamfer or flatten its angle"
                )

    def _check_hole_chamfer(self) -> None:
        """ParamError where the entrance chamfer leaves the plate's slab or leaves less than
        CHAMFER_FILL of the 4 mm of plate between two holes."""
        check_range("hole_chamfer", self.hole_chamfer, 0.0, PLATE_THICKNESS, "m",
                    "the entrance chamfer ends within the plate; make it shallower")  # fmt: skip
        check_range("hole_chamfer_angle", self.hole_chamfer_angle, 5 * DEG, 60 * DEG, "rad",
                    "give 5-60 deg")  # fmt: skip
        width = self.hole_chamfer * math.tan(self.hole_chamfer_angle)
        if width > CHAMFER_FILL * 0.002:
            raise ParamError(
                f"hole_chamfer = {self.hole_chamfer * 1e3:g} mm at "
                f"{math.degrees(self.hole_chamfer_angle):g} deg widens each entrance by "
                f"{width * 1e3:.3f} mm; two holes 4 mm apart take at most "
                f"{CHAMFER_FILL * 2:g} mm each: make it shallower or steeper"
            )

    def to_json(self) -> dict:
        d = asdict(self)
        d["pegs"] = [list(p) for p in self.pegs]
        for length, angle in (("peg_chamfer", "peg_chamfer_angle"),
                              ("hole_chamfer", "hole_chamfer_angle")):  # fmt: skip
            if not d[length]:  # the records of modules without one keep their form
                del d[length], d[angle]
        return d

    @staticmethod
    def from_json(d: dict) -> MultiPegParams:
        names = {f.name for f in fields(MultiPegParams)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise ParamError(f"unknown multi-peg parameter(s) {unknown}; valid: {sorted(names)}")
        d = dict(d)
        if "pegs" in d:
            d["pegs"] = tuple(
                (float(x), float(y), int(n), float(r), float(a)) for x, y, n, r, a in d["pegs"]
            )
        return MultiPegParams(**d).validate()


CHAMFER_FILL = 0.8
"""A peg tip's edges move in by at most this share of its inradius (Table I's rule)."""


def chamfered_prism(poly: np.ndarray, length: float, chamfer: float, angle: float) -> np.ndarray:
    """The straight prism over a convex polygon from z = 0 to `length`, its tip (z = 0)
    chamfered: below z = `chamfer` each side face gives way to one leaning in by tan(angle)
    per metre down (each side's half-space n . x <= d - (chamfer - z) tan(angle))."""
    solid = prism(poly, 0.0, length)
    if not chamfer:
        return solid
    g = math.tan(angle)
    sides = section_planes(poly)
    rows = np.column_stack([sides[:, :2], np.full(len(sides), -g), sides[:, 3] - chamfer * g])
    return np.vstack([solid, rows / math.sqrt(1.0 + g * g)])


def entrance_bevel(hole: np.ndarray, axis: np.ndarray, depth: float, angle: float) -> np.ndarray:
    """The entrance chamfer's part of a convex clearance hole (module frame): each side face
    (the planes along the insertion axis) opened by g = tan(angle) per metre above z = -depth
    (n . x - d <= g (z + depth)), capped as the hole and cut at that depth. With the hole it
    makes the chamfered hole (every side opening at the same rate: Table I's rule)."""
    g = math.tan(angle)
    sides = hole[np.abs(matmul(hole[:, :3], axis)) < 1e-9]
    rows = np.column_stack([sides[:, :2], sides[:, 2] - g, sides[:, 3] + g * depth])
    rows /= np.linalg.norm(rows[:, :3], axis=1, keepdims=True)
    return np.vstack([rows, hole[-1:], [[0.0, 0.0, -1.0, depth]]])


def _sections(p: MultiPegParams) -> list[np.ndarray]:
    return [section(n, r, a) + np.array([x, y]) for x, y, n, r, a in p.pegs]


def _reach(p: MultiPegParams) -> np.ndarray:
    """Two corners (2, 2) of a box in the carrier's xy holding every hole: the pegs' outline
    grown by twice the clearance (a mitred corner reaches at most that far: a triangle's)."""
    outline = np.vstack(_sections(p))
    grow = 2 * p.clearance
    return np.vstack([outline.min(axis=0) - grow, outline.max(axis=0) + grow])


def _carrier(p: MultiPegParams) -> np.ndarray:
    """The carrier (6, 4) over the pegs' sections, in the carrier frame."""
    pts = np.vstack(_sections(p))
    lo, hi = pts.min(axis=0) - MARGIN, pts.max(axis=0) + MARGIN
    top = p.peg_length + CARRIER
    e = np.eye(3)
    return np.vstack([np.column_stack([e, [hi[0], hi[1], top]]),
                      np.column_stack([-e, [-lo[0], -lo[1], -p.peg_length]])])  # fmt: skip


def fits(p: MultiPegParams) -> bool:
    """Whether the sleeve stays on the plate and the seated carrier clears its top."""
    if sleeve_reach(p, _reach(p)) > PLATE_SIZE / 2:
        return False
    _, _, design = frames(p)
    carrier = matmul(polytope_vertices(_carrier(p)), design[:3, :3].T) + design[:3, 3]
    return bool(carrier[:, 2].min() >= CLEAR)


def build_multi_peg(p: MultiPegParams) -> Assembly:
    """The base (the plate and one sleeve, the pegs' holes cut from them) and the carrier
    with its pegs, seated, and the one step (the reference hole's frames)."""
    p.validate()
    if not fits(p):
        raise ParamError("the carrier's holes leave the plate, or the seated carrier meets it")
    entrance, bottom, design = frames(p)
    axis = design[:3, 2]
    pegs = [prism(s, 0.0, p.peg_length + EMBED) for s in _sections(p)]
    # each hole is its unchamfered peg's: the clearance stays exact above the chamfer
    holes = [h for peg in pegs for h in clearance_hole([peg], p.clearance, design, axis, REACH)]
    if p.hole_chamfer:
        holes += [entrance_bevel(h, axis, p.hole_chamfer, p.hole_chamfer_angle) for h in holes]
    if p.peg_chamfer:
        pegs = [
            chamfered_prism(s, p.peg_length + EMBED, p.peg_chamfer, p.peg_chamfer_angle)
            for s in _sections(p)
        ]
    outline = np.vstack(_sections(p))
    base = Part("base", (plate(), sleeve(p, _reach(p), design)), tuple(holes))
    carrier = Part("carrier", (*pegs, _carrier(p)), (), design)
    travel = p.hole_depth + float(np.linalg.norm(outline, axis=1).max()) + 0.01
    step = Step("carrier", p.clearance, entrance, Frame.from_matrix(bottom), travel)
    return Assembly(base, (carrier,), (step,))


@dataclass(frozen=True)
class MultiPegSampler(OneClearance, ChamferRanges):
    """Uniform ranges of the sampled parameters (SI units, angles in rad)."""

    pegs: tuple[int, int] = (2, 4)
    """Pegs on the carrier, inclusive."""
    circle_probability: float = 0.25
    """Probability that a peg is a 32-gon "circle" (Table I's); otherwise an n-gon."""
    sides: tuple[int, int] = (3, 8)
    """Sides of an n-gon peg, inclusive."""
    radius: tuple[float, float] = (0.004, 0.01)
    """A peg's circumradius, m."""
    spacing: tuple[float, float] = (0.015, 0.03)
    """Distance between neighbouring pegs' axes, m (raised to leave 4 mm between holes)."""
    line_probability: float = 0.5
    """Probability that the pegs stand in a line; otherwise at a regular polygon's corners
    (for 3 and 4 pegs; 2 pegs are always a line)."""
    peg_length: tuple[float, float] = (0.02, 0.045)
    """Length of the pegs under the carrier, m."""
    depth_fraction: tuple[float, float] = (0.3, 0.6)
    """Hole depth, fraction of the peg length."""
    hole_position: tuple[float, float] = (-0.025, 0.025)
    """The reference hole's entrance x and y (each), m."""
    hole_tilt: tuple[float, float] = (-10 * DEG, 10 * DEG)
    """Tilt of the holes' axis about the module's x and y (each), rad."""
    hole_yaw: tuple[float, float] = (-math.pi, math.pi)
    """Turn of the pattern about the axis, rad."""
    clearance: float = 1e-3
    """Each peg to its hole, m (fixed; `--clearance-mm` sets it)."""
    peg_chamfer: tuple[float, float] = (0.0, 0.0)
    """Length of the chamfer on the pegs' tips, m (default: none). Drawn after every other
    parameter, and only where the range is not (0, 0), so a seed's other parameters stay;
    cut to half the hole's depth where that is less."""
    peg_chamfer_angle: tuple[float, float] = (45 * DEG, 45 * DEG)
    """Angle of the chamfer's faces from the side faces, rad."""
    hole_chamfer: tuple[float, float] = (0.0, 0.0)
    """Depth of the chamfer around the holes' entrances, m (default: none); drawn after the
    pegs' chamfer, and only where the range is not (0, 0)."""
    hole_chamfer_angle: tuple[float, float] = (45 * DEG, 45 * DEG)
    """Angle of the entrance chamfer's faces from the holes' side faces, rad."""

    WHAT = "multi-peg sampler"

    def to_json(self) -> dict:
        return self.without_unused_chamfers(super().to_json())

    def validate(self) -> MultiPegSampler:
        """Ranges of two finite numbers low <= high, probabilities in [0, 1], and the first
        draws build."""
        check_ranges(self)
        for name in ("circle_probability", "line_probability"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ParamError(f"{name} = {getattr(self, name)} must be in [0, 1]")
        if not 2 <= self.pegs[0] <= self.pegs[1] <= 4:
            raise ParamError(f"pegs = {self.pegs}: a carrier holds 2 to 4")
        if self.hole_chamfered:  # the deepest, flattest entrance chamfer, as a module's rule
            corner = replace(
                self.sample(0),
                hole_chamfer=self.hole_chamfer[1],
                hole_chamfer_angle=self.hole_chamfer_angle[1],
            )
            try:
                corner._check_hole_chamfer()
            except ParamError as e:
                raise ParamError(f"{self.WHAT}'s hole_chamfer range: {e}") from e
        if self.chamfered:  # the longest, flattest chamfer on the smallest peg there can be
            inset = self.peg_chamfer[1] * math.tan(self.peg_chamfer_angle[1])
            limit = CHAMFER_FILL * self.radius[0] * math.cos(math.pi / min(self.sides[0], ROUND))
            if inset > limit:
                raise ParamError(
                    f"peg_chamfer up to {self.peg_chamfer[1] * 1e3:g} mm at "
                    f"{math.degrees(self.peg_chamfer_angle[1]):g} deg moves a tip's edges in by "
                    f"{inset * 1e3:.3f} mm; the smallest peg takes {limit * 1e3:.3f} mm"
                )
        for seed in range(4):
            try:
                build_multi_peg(self.sample(seed))
            except ParamError as e:
                raise ParamError(f"sampler draws an unbuildable multi-peg module: {e}") from e
        return self

    def sample(self, seed: int) -> MultiPegParams:
        """The parameters of `seed` (numpy's PCG64, drawn in a fixed order). A placement
        that leaves the plate or a carrier that meets it is drawn again from the same
        stream, so every seed builds."""
        rng = np.random.default_rng(seed)

        def u(lo_hi: tuple[float, float]) -> float:
            return float(rng.uniform(*lo_hi))

        count = int(rng.integers(self.pegs[0], self.pegs[1] + 1))
        shapes = []
        for _ in range(count):
            n = (
                ROUND
                if rng.random() < self.circle_probability
                else int(rng.integers(self.sides[0], self.sides[1] + 1))
            )
            shapes.append((n, u(self.radius), u((0.0, 2 * math.pi))))
        widest = 2 * max(r for _, r, _ in shapes) + 2 * self.clearance + 0.004
        spacing = max(u(self.spacing), widest)
        if count == 2 or rng.random() < self.line_probability:
            xy = [(k * spacing, 0.0) for k in range(count)]
        else:  # a regular polygon of side `spacing`, the first corner at the origin
            rim = spacing / (2 * math.sin(math.pi / count))
            xy = [(rim * (math.cos(2 * math.pi * k / count) - 1),
                   rim * math.sin(2 * math.pi * k / count)) for k in range(count)]  # fmt: skip
        pegs = tuple(
            (float(x), float(y), n, r, a) for (x, y), (n, r, a) in zip(xy, shapes, strict=True)
        )
        # the reference (first) peg is the one nearest the pattern's centre, at the origin
        centre = np.mean(xy, axis=0)
        ref = int(np.argmin([math.hypot(x - centre[0], y - centre[1]) for x, y, *_ in pegs]))
        x0, y0 = pegs[ref][:2]
        order = [ref, *(k for k in range(count) if k != ref)]
        pegs = tuple((pegs[k][0] - x0, pegs[k][1] - y0, *pegs[k][2:]) for k in order)
        for _ in range(100):
            p = MultiPegParams(
                pegs=pegs,
                peg_length=u(self.peg_length),
                depth_fraction=u(self.depth_fraction),
                hole_x=u(self.hole_position),
                hole_y=u(self.hole_position),
                hole_tilt_x=u(self.hole_tilt),
                hole_tilt_y=u(self.hole_tilt),
                hole_yaw=u(self.hole_yaw),
                clearance=self.clearance,
            )
            if fits(p):
                if self.chamfered:  # drawn last, and only when asked
                    length = u(self.peg_chamfer)
                    p = replace(p, peg_chamfer=min(length, 0.5 * p.hole_depth),
                                peg_chamfer_angle=u(self.peg_chamfer_angle))  # fmt: skip
                if self.hole_chamfered:
                    p = replace(p, hole_chamfer=u(self.hole_chamfer),
                                hole_chamfer_angle=u(self.hole_chamfer_angle))  # fmt: skip
                return p
        raise ParamError(f"seed {seed}: no placement of its carrier fits the plate in 100 draws")


FAMILY = Family(
    name="multi-peg",
    summary="a carrier with 2-4 parallel pegs into their holes in one plate, each at its "
    "exact clearance",
    sampler=MultiPegSampler,
    params=MultiPegParams,
    build=build_multi_peg,
)
"""The family (assetgen.families.interface); its modules take the assembly layout."""
