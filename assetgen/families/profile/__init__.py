"""The `profile` family: a peg of a non-convex cross-section (L, T, cross, star, keyed
round, splined shaft, random polygon) into its hole in a 15 x 15 cm plate, at an exact
clearance on every face, concave corners included.

Module frame as Table I's: the plate's top face is z = 0, the plate spans +-75 mm and is
5 mm thick; the hole, tilted and offset as Table I samples them, is cut through the plate
into a sleeve hanging below it (5 mm walls and floor). The peg is a straight prism of its
section (its frame at the bottom face's area centroid, z along the peg); its hole is the
prism of the section's mitred offset by the clearance (assetgen.geometry.polygon_offset),
continued up through the plate. Both are split into convex pieces exactly
(assetgen.geometry.convex_partition): the peg's are its solids, the hole's are the holes
the assembly layout carves from the plate and the sleeve. The peg's pieces are not moved out
one by one (assetgen.geometry.clearance_hole): at a convex corner that a cut meets at an
acute angle, that would grow a spike of hole into the plate.

The pegs are not tapered: a tapered non-convex section's exact hole has faces that move
out by different amounts at each height, and its convex pieces are then not prisms.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace

import numpy as np

from assetgen.core.frames import Frame
from assetgen.core.portable import matmul, norm
from assetgen.families.interface import Family
from assetgen.families.parts import Assembly, Part, Step
from assetgen.families.profile import sections
from assetgen.geometry.convex_partition import convex_partition
from assetgen.geometry.polygon_offset import (
    OffsetError,
    centroid,
    check_simple,
    edge_lines,
    mitred_offset,
)
from assetgen.geometry.polytope import polytope_vertices, transform_planes
from assetgen.params.module_params import ParamError
from assetgen.params.sampler import OneClearance, check_ranges

DEG = math.pi / 180
PLATE_SIZE = 0.15
"""Plate side, m (Table I's)."""
PLATE_THICKNESS = 0.005
"""Plate thickness, m (Table I's)."""
WALL = 0.005
"""Sleeve wall and floor around the hole, m (Table I's)."""
REACH = 0.5
"""How far (m) up its axis the hole is closed: beyond any material."""
SHAPES = ("L", "T", "cross", "star", "keyed", "spline", "random")
"""The cross-sections the sampler draws from (assetgen.families.profile.sections)."""
MAX_RADIUS = 0.035
"""Farthest a section's vertex may lie from the peg's axis, m."""
MIN_FEATURE = 0.004
"""Narrowest arm, slot or tooth gap the sampler draws, m: printable, and over twice the
largest clearance the sampler allows (so the offset hole stays an offset)."""


def section_planes(poly: np.ndarray) -> np.ndarray:
    """The side planes (k, 4) of the straight prism over a convex counter-clockwise polygon."""
    normals, d = edge_lines(poly)
    return np.column_stack([normals, np.zeros(len(poly)), d])


def prism(poly: np.ndarray, z0: float, z1: float) -> np.ndarray:
    """The straight prism over a convex polygon between z0 and z1, as half-space rows."""
    return np.vstack([section_planes(poly), [[0.0, 0.0, 1.0, z1]], [[0.0, 0.0, -1.0, -z0]]])


def plate() -> np.ndarray:
    """Table I's plate (6, 4): 15 x 15 cm, 5 mm thick, its top face z = 0."""
    half = PLATE_SIZE / 2
    return np.array(
        [[1, 0, 0, half], [-1, 0, 0, half], [0, 1, 0, half], [0, -1, 0, half],
         [0, 0, 1, 0.0], [0, 0, -1, PLATE_THICKNESS]], dtype=float,
    )  # fmt: skip


def rotation(tilt_x: float, tilt_y: float, yaw: float) -> np.ndarray:
    """Rx(tilt_x) Ry(tilt_y) Rz(yaw), as Table I turns its hole."""
    cx, sx, cy, sy = math.cos(tilt_x), math.sin(tilt_x), math.cos(tilt_y), math.sin(tilt_y)
    cz, sz = math.cos(yaw), math.sin(yaw)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return matmul(matmul(rx, ry), rz)


@dataclass(frozen=True)
class ProfileParams:
    """One profile module. SI units (m, rad)."""

    shape: str
    """The section's kind, one of SHAPES (informative: `section` defines it)."""
    section: tuple[tuple[float, float], ...]
    """The peg's cross-section: a simple counter-clockwise polygon, m, its area centroid at
    the origin (the peg's axis), every vertex within 35 mm of it."""
    peg_height: float
    """Peg height, m (0.025 - 0.15)."""
    hole_depth_fraction: float
    """Hole depth along its axis, fraction of the peg height (0.4 - 0.8)."""
    hole_x: float
    """Hole entrance x, m (-0.025 - 0.025)."""
    hole_y: float
    """Hole entrance y, m (-0.025 - 0.025)."""
    hole_tilt_x: float
    """Tilt of the hole axis about the module's x, rad (-15 - 15 deg)."""
    hole_tilt_y: float
    """Tilt about the module's y, rad (-15 - 15 deg)."""
    hole_yaw: float
    """Turn of the hole (and the seated peg) about its axis, rad (-pi - pi)."""
    clearance: float = 1e-3
    """Gap between the peg and its hole on every face, m (0 - 5 mm)."""

    @property
    def hole_depth(self) -> float:
        return self.hole_depth_fraction * self.peg_height

    def polygon(self) -> np.ndarray:
        return np.asarray(self.section, dtype=float)

    def validate(self) -> ProfileParams:
        if self.shape not in SHAPES:
            raise ParamError(f"shape = {self.shape!r}; valid shapes: {list(SHAPES)}")
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name not in ("shape", "section") and not (
                isinstance(v, int | float) and math.isfinite(v)
            ):
                raise ParamError(f"{f.name} = {v!r} is not a finite number")
        ranges = {
            "peg_height": (0.025, 0.15),
            "hole_depth_fraction": (0.4, 0.8),
            "hole_x": (-0.025, 0.025),
            "hole_y": (-0.025, 0.025),
            "hole_tilt_x": (-15 * DEG, 15 * DEG),
            "hole_tilt_y": (-15 * DEG, 15 * DEG),
            "hole_yaw": (-math.pi, math.pi),
        }
        for name, (lo, hi) in ranges.items():
            v = getattr(self, name)
            if not lo - 1e-12 <= v <= hi + 1e-12:
                raise ParamError(f"{name} = {v:g} is outside [{lo:g}, {hi:g}]")
        if not 0 < self.clearance <= 0.005:
            raise ParamError(f"clearance = {self.clearance:g} m; give a gap in (0, 0.005] m")
        try:
            poly = check_simple(self.polygon(), "section")
            mitred_offset(poly, self.clearance)
        except OffsetError as e:
            raise ParamError(f"{self.shape} section: {e}") from e
        reach = float(np.linalg.norm(poly, axis=1).max())
        if reach > MAX_RADIUS:
            raise ParamError(
                f"section reaches {reach * 1e3:.1f} mm from the axis; at most "
                f"{MAX_RADIUS * 1e3:g} mm"
            )
        if float(norm(centroid(poly))) > 1e-9:
            raise ParamError("section: its area centroid must be the origin (the peg's axis)")
        return self

    def to_json(self) -> dict:
        d = asdict(self)
        d["section"] = [list(v) for v in self.section]
        return d

    @staticmethod
    def from_json(d: dict) -> ProfileParams:
        names = {f.name for f in fields(ProfileParams)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise ParamError(f"unknown profile parameter(s) {unknown}; valid: {sorted(names)}")
        d = dict(d)
        if "section" in d:
            d["section"] = tuple(tuple(float(x) for x in v) for v in d["section"])
        return ProfileParams(**d).validate()


def frames(p: ProfileParams) -> tuple[Frame, np.ndarray, np.ndarray]:
    """(entrance, bottom (4, 4), design pose (4, 4)) in the module frame, as Table I's."""
    r = rotation(p.hole_tilt_x, p.hole_tilt_y, p.hole_yaw)
    axis = r[:, 2]
    entrance = np.array([p.hole_x, p.hole_y, 0.0])
    bottom = np.eye(4)
    bottom[:3, :3] = r
    bottom[:3, 3] = entrance - p.hole_depth * axis
    design = bottom.copy()
    design[:3, 3] += p.clearance * axis
    return Frame(tuple(entrance), (1.0, 0.0, 0.0, 0.0)), bottom, design


def sleeve(p: ProfileParams, offset: np.ndarray, design: np.ndarray) -> np.ndarray:
    """The sleeve (k, 4): in the design frame, a box around the hole's section grown by the
    wall, from the wall below the hole's floor up, cut at mid-plate (module frame)."""
    lo = offset.min(axis=0) - WALL
    hi = offset.max(axis=0) + WALL
    floor = -p.clearance - WALL
    box = np.array(
        [[1, 0, 0, hi[0]], [-1, 0, 0, -lo[0]], [0, 1, 0, hi[1]], [0, -1, 0, -lo[1]],
         [0, 0, -1, -floor], [0, 0, 1, REACH]], dtype=float,
    )  # fmt: skip
    return np.vstack([transform_planes(box, design), [[0.0, 0.0, 1.0, -PLATE_THICKNESS / 2]]])


def sleeve_reach(p, outline: np.ndarray) -> float:
    """How far (m) from the plate's centre the sleeve around the holes' `outline` (points
    (k, 2) in the design frame's xy) reaches in x or y, at or below the plate's top: at most
    the plate's half-width for the module to fit. `p`: a family's params with Table I's
    placement (frames)."""
    _, _, design = frames(p)
    box = sleeve(p, outline, design)
    box[-1, 3] = 0.0  # up to the plate's top: the hole's wall there, too
    return float(np.abs(polytope_vertices(box)[:, :2]).max())


def build_profile(p: ProfileParams) -> Assembly:
    """The base (the plate and the sleeve, the hole's pieces cut from them) and the peg
    (its section's convex pieces), seated at its design pose, and the one step."""
    p.validate()
    poly = p.polygon()
    offset = mitred_offset(poly, p.clearance)
    entrance, bottom, design = frames(p)
    peg_solids = tuple(
        prism(piece, 0.0, p.peg_height) for piece in convex_partition(poly, overlap=True)
    )
    holes = tuple(
        transform_planes(prism(piece, -p.clearance, REACH), design)
        for piece in convex_partition(offset, overlap=True)
    )
    base = Part("base", (plate(), sleeve(p, offset, design)), holes)
    peg = Part("peg", peg_solids, (), design, shared_corners=True)
    step = Step(
        "peg",
        p.clearance,
        entrance,
        Frame.from_matrix(bottom),
        p.hole_depth + float(np.linalg.norm(poly, axis=1).max()) + 0.01,
    )
    return Assembly(base, (peg,), (step,))


@dataclass(frozen=True)
class ProfileSampler(OneClearance):
    """Uniform ranges of the sampled parameters (SI units, angles in rad); the placement's
    are Table I's."""

    shapes: tuple[str, ...] = SHAPES
    """The sections drawn, each equally likely."""
    size: tuple[float, float] = (0.01, 0.03)
    """Outer radius of the section, m (Table I's circumradius)."""
    arm: tuple[float, float] = (0.3, 0.5)
    """L, T and cross: an arm's width, fraction of the shape's side (or bar's length)."""
    star_points: tuple[int, int] = (4, 8)
    """Star: points, inclusive."""
    star_inner: tuple[float, float] = (0.45, 0.7)
    """Star: the notches' radius, fraction of the tips'."""
    flat_probability: float = 0.5
    """Keyed round: probability of a flat (a D-shaft, convex) rather than a keyway."""
    key_width: tuple[float, float] = (0.15, 0.3)
    """Keyed round: the keyway's width, fraction of the diameter."""
    key_depth: tuple[float, float] = (0.12, 0.3)
    """Keyed round: the keyway's depth or the flat's, fraction of the radius."""
    teeth: tuple[int, int] = (4, 10)
    """Splined shaft: teeth, inclusive (capped so a gap at the root is at least 4 mm)."""
    tooth_depth: tuple[float, float] = (0.12, 0.25)
    """Splined shaft: the teeth's height, fraction of the outer radius."""
    random_vertices: tuple[int, int] = (6, 12)
    """Random polygon: vertices, inclusive."""
    random_radius: tuple[float, float] = (0.5, 1.0)
    """Random polygon: a vertex's distance from the centre, fraction of the size."""
    max_reflex: float = 240 * DEG
    """Random polygon: the largest interior angle of a concave corner, rad."""
    peg_height: tuple[float, float] = (0.025, 0.15)
    """Peg height, m."""
    hole_depth_fraction: tuple[float, float] = (0.4, 0.8)
    """Hole depth, fraction of the peg height."""
    hole_position: tuple[float, float] = (-0.025, 0.025)
    """Hole entrance x and y (each), m."""
    hole_tilt: tuple[float, float] = (-15 * DEG, 15 * DEG)
    """Tilt of the hole axis about the module's x and y (each), rad."""
    hole_yaw: tuple[float, float] = (-math.pi, math.pi)
    """Turn of the hole about its axis, rad."""
    clearance: float = 1e-3
    """Peg to hole, m (fixed; `--clearance-mm` sets it)."""

    WHAT = "profile sampler"

    def validate(self) -> ProfileSampler:
        """Known shapes, ranges of two finite numbers low <= high, a clearance the features
        hold, and the first draws of each shape build."""
        unknown = sorted(set(self.shapes) - set(SHAPES))
        if unknown or not self.shapes:
            raise ParamError(f"shapes {list(self.shapes)}: give some of {list(SHAPES)}")
        check_ranges(self, skip=("shapes",))
        if not 0.0 <= self.flat_probability <= 1.0:
            raise ParamError(f"flat_probability = {self.flat_probability} must be in [0, 1]")
        if not 0 < self.clearance < MIN_FEATURE / 2:
            raise ParamError(
                f"clearance = {self.clearance:g} m: the sections' narrowest gaps "
                f"({MIN_FEATURE * 1e3:g} mm) hold clearances below {MIN_FEATURE / 2 * 1e3:g} mm"
            )
        for shape in self.shapes:
            probe = replace(self, shapes=(shape,))
            for seed in range(4):
                try:
                    probe.sample(seed).validate()
                except (ParamError, ValueError) as e:
                    raise ParamError(f"sampler draws an unbuildable {shape} module: {e}") from e
        return self

    def section(self, rng: np.random.Generator, shape: str, size: float) -> np.ndarray:
        """A section of `shape` and outer radius `size`, its other parameters drawn."""

        def u(lo_hi: tuple[float, float]) -> float:
            return float(rng.uniform(*lo_hi))

        def k(lo_hi: tuple[int, int]) -> int:
            return int(rng.integers(lo_hi[0], lo_hi[1] + 1))

        if shape in ("L", "T", "cross"):
            side = 2 * size / math.sqrt(2)
            arm = max(u(self.arm), MIN_FEATURE / side)
            build = {"L": sections.l_shape, "T": sections.t_shape, "cross": sections.cross_shape}
            return build[shape](size, arm)
        if shape == "star":
            return sections.star(size, k(self.star_points), u(self.star_inner))
        if shape == "keyed":
            flat = bool(rng.random() < self.flat_probability)
            width, depth = u(self.key_width), u(self.key_depth)
            width = max(width, MIN_FEATURE / (2 * size))
            return sections.keyed_round(size, "flat" if flat else "keyway", width, depth)
        if shape == "spline":
            depth = u(self.tooth_depth)
            root = (1 - depth) * size
            teeth = min(k(self.teeth), max(3, int(math.pi * root / MIN_FEATURE)))
            return sections.spline_shaft(size, teeth, depth)
        return sections.random_polygon(
            rng, size, k(self.random_vertices), self.random_radius[0], self.max_reflex
        )

    def sample(self, seed: int) -> ProfileParams:
        """The parameters of `seed` (numpy's PCG64, drawn in a fixed order). A placement
        whose sleeve would lean out of the plate is drawn again from the same stream, so
        every seed builds."""
        rng = np.random.default_rng(seed)

        def u(lo_hi: tuple[float, float]) -> float:
            return float(rng.uniform(*lo_hi))

        shape = self.shapes[int(rng.integers(len(self.shapes)))]
        size = u(self.size)
        poly = self.section(rng, shape, size)
        poly = poly - centroid(poly)
        section = tuple((float(x), float(y)) for x, y in poly)
        for _ in range(100):
            p = ProfileParams(
                shape=shape,
                section=section,
                peg_height=u(self.peg_height),
                hole_depth_fraction=u(self.hole_depth_fraction),
                hole_x=u(self.hole_position),
                hole_y=u(self.hole_position),
                hole_tilt_x=u(self.hole_tilt),
                hole_tilt_y=u(self.hole_tilt),
                hole_yaw=u(self.hole_yaw),
                clearance=self.clearance,
            )
            if sleeve_reach(p, mitred_offset(p.polygon(), p.clearance)) <= PLATE_SIZE / 2:
                return p
        raise ParamError(
            f"seed {seed}: no placement of its {shape} peg fits the plate in 100 draws"
        )


FAMILY = Family(
    name="profile",
    summary="a peg of a non-convex section (L, T, cross, star, keyed, splined, random) into "
    "its hole in a plate, exact on every face",
    sampler=ProfileSampler,
    params=ProfileParams,
    build=build_profile,
)
"""The family (assetgen.families.interface); its modules take the assembly layout."""
