"""The `profile-bolt` family: a square profile into a socket, then a bolt from the side
through the block and the profile, securing it (the paper's assembly-sequence demo).

Module frame as for Table I: the plate's top face is z = 0, the plate spans +-75 mm. A socket
block stands on the plate's centre; its socket is the profile's clearance hole, open at the
top. Step 1 inserts the profile along -z. Step 2 inserts the bolt along -x: through the
block's +x wall, across the profile's cross hole, into the -x wall; its hex head stops short
of the block's +x face by the bolt clearance (its seat).

Part frames follow the peg's: origin at the centre of the leading face (the profile's bottom,
the bolt's tip), z along the part towards its back. Every length is in metres.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace

import numpy as np

from assetgen.core.frames import Frame
from assetgen.core.portable import matmul, rigid_inverse
from assetgen.families.interface import Family
from assetgen.families.parts import Assembly, Part, Step
from assetgen.geometry.clearance_hole import clearance_hole
from assetgen.params.module_params import ParamError
from assetgen.params.sampler import config_from_json, config_to_json

PLATE_SIZE = 0.15
"""Plate side, m (as Table I's)."""
PLATE_THICKNESS = 0.005
"""Plate thickness, m."""
BLOCK_FLOOR = 0.005
"""Material under the socket, m."""
MIN_WALL = 0.0015
"""Thinnest material the family builds (printable), m."""
SHANK_SIDES = 32
"""The bolt shank is a regular 32-gon prism (vertices on the nominal diameter)."""
HEAD_ACROSS_FLATS = 1.6
"""Hex head width across flats, times the shank diameter (about ISO 4017)."""
HEAD_HEIGHT = 0.65
"""Hex head height, times the shank diameter."""
SLOT = {"neck_width": 0.3, "neck_depth": 0.1, "channel_width": 0.55, "channel_depth": 0.12}
"""T-slot proportions, times the profile side: a neck opening on the face, then a wider
channel behind it (as in aluminium extrusion profiles)."""
REACH = 0.5
"""How far (m) up its insertion axis a clearance hole is closed: beyond any material."""


def box(lo, hi) -> np.ndarray:
    """The axis-aligned box lo <= x <= hi as (6, 4) half-space rows."""
    e = np.eye(3)
    return np.vstack(
        [np.column_stack([e, np.asarray(hi, float)]), np.column_stack([-e, -np.asarray(lo, float)])]
    )


def prism(normals_xy: np.ndarray, offsets: np.ndarray, z0: float, z1: float) -> np.ndarray:
    """A right prism along z: side planes (n_xy, 0) . x <= offset, between z0 and z1."""
    sides = np.column_stack([normals_xy, np.zeros(len(normals_xy)), offsets])
    return np.vstack([sides, [[0.0, 0.0, 1.0, z1]], [[0.0, 0.0, -1.0, -z0]]])


@dataclass(frozen=True)
class ProfileBoltParams:
    """One profile-bolt assembly. SI units (m)."""

    profile_side: float
    """Side of the profile's square section, m (0.015 - 0.03)."""
    profile_length: float
    """Profile length, m (0.04 - 0.1)."""
    insertion_depth: float
    """How deep the profile goes into the socket, m (0.02 - 0.05; at least 5 mm of the
    profile stays above the block)."""
    slots: bool
    """T-slots along the profile's four faces (the profile and its socket are non-convex)."""
    bolt_diameter: float
    """Shank diameter, m (0.004 - 0.008)."""
    bolt_height: float
    """Height of the bolt axis above the profile's bottom face, as a fraction of the
    insertion depth (0.3 - 0.7)."""
    wall: float
    """Socket block wall thickness around the socket, m (0.008 - 0.015)."""
    engagement: float
    """How far the bolt's tip goes into the far wall, as a fraction of the wall (0.3 - 0.7)."""
    profile_clearance: float = 0.25e-3
    """Gap between the profile and its socket, m (the paper's demo: 0.25 mm)."""
    bolt_clearance: float = 0.5e-3
    """Gap between the bolt and its holes (block and profile), m."""

    def validate(self) -> ProfileBoltParams:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name != "slots" and not (isinstance(v, int | float) and math.isfinite(v)):
                raise ParamError(f"{f.name} = {v!r} is not a finite number")
        ranges = {
            "profile_side": (0.015, 0.03),
            "profile_length": (0.04, 0.1),
            "insertion_depth": (0.02, 0.05),
            "bolt_diameter": (0.004, 0.008),
            "bolt_height": (0.3, 0.7),
            "wall": (0.008, 0.015),
            "engagement": (0.3, 0.7),
        }
        for name, (lo, hi) in ranges.items():
            v = getattr(self, name)
            if not lo <= v <= hi:
                raise ParamError(f"{name} = {v:g} is outside [{lo:g}, {hi:g}]")
        for name in ("profile_clearance", "bolt_clearance"):
            v = getattr(self, name)
            if not 0 < v <= 0.005:
                raise ParamError(f"{name} = {v:g} m; a clearance must be a gap in (0, 0.005] m")
        if self.profile_length - self.insertion_depth < 0.005:
            raise ParamError(
                f"insertion_depth = {self.insertion_depth:g} m leaves "
                f"{(self.profile_length - self.insertion_depth) * 1e3:.1f} mm of the "
                f"{self.profile_length * 1e3:g} mm profile above the block; at least 5 mm "
                "must stay out to be grasped: shorten insertion_depth or lengthen profile_length"
            )
        hole = self.bolt_diameter / 2 + self.bolt_clearance
        if 2 * hole > self.profile_side - 2 * MIN_WALL:
            raise ParamError(
                f"bolt_diameter = {self.bolt_diameter * 1e3:g} mm: its hole "
                f"({2 * hole * 1e3:g} mm) is wider than the {self.profile_side * 1e3:g} mm "
                f"profile allows (its side less {MIN_WALL * 1e3:g} mm a side)"
            )
        centre = self.bolt_height * self.insertion_depth
        if centre - hole < MIN_WALL or centre + hole > self.insertion_depth - MIN_WALL:
            raise ParamError(
                f"bolt_height = {self.bolt_height:g}: the bolt hole (radius {hole * 1e3:g} "
                f"mm) at {centre * 1e3:.2f} mm does not fit inside the "
                f"{self.insertion_depth * 1e3:g} mm of profile in the socket with "
                f"{MIN_WALL * 1e3:g} mm of material around it"
            )
        if self.wall * (1 - self.engagement) - self.bolt_clearance < MIN_WALL:
            raise ParamError(
                f"engagement = {self.engagement:g}: the bolt's blind hole leaves less than "
                f"{MIN_WALL * 1e3:g} mm of the {self.wall * 1e3:g} mm wall"
            )
        half = self.profile_side / 2 + self.profile_clearance + self.wall
        if half > PLATE_SIZE / 2 - HEAD_HEIGHT * self.bolt_diameter - 0.01:
            raise ParamError(
                f"profile_side + wall: the block ({2 * half * 1e3:g} mm) and "
                "the bolt head do not fit on the plate"
            )
        return self

    def to_json(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_json(d: dict) -> ProfileBoltParams:
        names = {f.name for f in fields(ProfileBoltParams)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise ParamError(f"unknown profile-bolt parameter(s) {unknown}; valid: {sorted(names)}")
        return ProfileBoltParams(**d).validate()


def profile_section(side: float, slots: bool) -> list[tuple[tuple[float, float], ...]]:
    """The profile's cross-section as axis-aligned rectangles ((x0, y0), (x1, y1)) whose
    union is the section: the square, or with a T-slot in each face a core square, and a
    corner square and two lips per corner (13 rectangles, overlapping)."""
    a = side / 2
    if not slots:
        return [((-a, -a), (a, a))]
    dn, dc = SLOT["neck_depth"] * side, SLOT["channel_depth"] * side
    wn, wc = SLOT["neck_width"] * side / 2, SLOT["channel_width"] * side / 2
    c0 = a - dn - dc
    rects = [((-c0, -c0), (c0, c0))]
    quadrant = [
        ((wc, wc), (a, a)),  # the corner square between the +x and +y slots' channels
        ((a - dn, wn), (a, wc)),  # the +x slot's lip over its channel
        ((wn, a - dn), (wc, a)),  # the +y slot's lip
    ]
    for sx in (1, -1):
        for sy in (1, -1):
            for (x0, y0), (x1, y1) in quadrant:
                xs = sorted((sx * x0, sx * x1))
                ys = sorted((sy * y0, sy * y1))
                rects.append(((xs[0], ys[0]), (xs[1], ys[1])))
    return rects


def _bolt_rotation() -> np.ndarray:
    """The bolt frame's z (its axis, tip to head) along the module's +x."""
    return np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])


def build_profile_bolt(p: ProfileBoltParams) -> Assembly:
    """The base (plate and socket block, with the socket and the bolt's holes), the profile
    (with its cross hole) and the bolt, in their design poses, and the two steps."""
    p.validate()
    s, cp, cb = p.profile_side, p.profile_clearance, p.bolt_clearance
    a = s / 2
    half = a + cp + p.wall  # the block's half width
    height = BLOCK_FLOOR + cp + p.insertion_depth  # the block's top
    # profile: frame at its bottom face's centre, seated cp above the socket floor
    profile_solids = tuple(
        box([x0, y0, 0.0], [x1, y1, p.profile_length])
        for (x0, y0), (x1, y1) in profile_section(s, p.slots)
    )
    profile_pose = np.eye(4)
    profile_pose[2, 3] = BLOCK_FLOOR + cp
    # bolt: frame at its tip's centre, z towards the head, along the module's +x
    r = p.bolt_diameter / 2
    z_bolt = BLOCK_FLOOR + cp + p.bolt_height * p.insertion_depth
    x_tip = -(a + cp) - p.engagement * p.wall
    shank_length = half + cb - x_tip
    angles = 2 * math.pi * np.arange(SHANK_SIDES) / SHANK_SIDES
    normals = np.column_stack([np.cos(angles), np.sin(angles)])
    # the shank runs on into the head: a union of solids that only touch on a face leaves
    # coincident vertices in manifold3d's mesh (2 of 1024 bolts were not one closed body)
    shank = prism(
        normals,
        np.full(SHANK_SIDES, r * math.cos(math.pi / SHANK_SIDES)),
        0.0,
        shank_length + HEAD_HEIGHT * p.bolt_diameter / 2,
    )
    hex_angles = math.pi / 3 * np.arange(6)
    hex_normals = np.column_stack([np.cos(hex_angles), np.sin(hex_angles)])
    head = prism(
        hex_normals,
        np.full(6, HEAD_ACROSS_FLATS * p.bolt_diameter / 2),
        shank_length,
        shank_length + HEAD_HEIGHT * p.bolt_diameter,
    )
    bolt_pose = np.eye(4)
    bolt_pose[:3, :3] = _bolt_rotation()
    bolt_pose[:3, 3] = [x_tip, 0.0, z_bolt]
    bolt_hole = clearance_hole([shank], cb, bolt_pose, np.array([1.0, 0.0, 0.0]), REACH)
    profile_hole = clearance_hole(
        profile_solids, cp, profile_pose, np.array([0.0, 0.0, 1.0]), REACH
    )
    # the profile's cross hole, in the profile frame
    in_profile = matmul(rigid_inverse(profile_pose), bolt_pose)
    cross_hole = clearance_hole([shank], cb, in_profile, np.array([1.0, 0.0, 0.0]), REACH)
    plate = box(
        [-PLATE_SIZE / 2, -PLATE_SIZE / 2, -PLATE_THICKNESS], [PLATE_SIZE / 2, PLATE_SIZE / 2, 0.0]
    )
    block = box([-half, -half, 0.0], [half, half, height])
    base = Part("base", (plate, block), tuple(profile_hole + bolt_hole))
    profile = Part("profile", profile_solids, tuple(cross_hole), profile_pose)
    # the bolt prints standing on its head
    bolt = Part("bolt", (shank, head), (), bolt_pose, np.diag([1.0, -1.0, -1.0]))
    up = np.eye(4)
    up[:3, 3] = [0.0, 0.0, BLOCK_FLOOR]
    side_bottom = bolt_pose.copy()
    side_bottom[0, 3] -= cb
    side_entrance = bolt_pose.copy()
    side_entrance[0, 3] = half
    steps = (
        Step(
            "profile",
            cp,
            Frame((0.0, 0.0, height), (1.0, 0.0, 0.0, 0.0)),
            Frame.from_matrix(up),
            p.insertion_depth,
        ),
        Step(
            "bolt",
            cb,
            Frame.from_matrix(side_entrance),
            Frame.from_matrix(side_bottom),
            half - x_tip,
        ),
    )
    return Assembly(base, (profile, bolt), steps)


@dataclass(frozen=True)
class ProfileBoltSampler:
    """Uniform ranges of the sampled parameters (SI units); clearances fixed."""

    profile_side: tuple[float, float] = (0.015, 0.03)
    """Side of the profile's square section, m."""
    profile_length: tuple[float, float] = (0.05, 0.1)
    """Profile length, m (raised to the insertion depth + 5 mm where shorter)."""
    insertion_depth: tuple[float, float] = (0.02, 0.045)
    """How deep the profile goes into the socket, m."""
    slot_probability: float = 0.5
    """Probability of T-slots along the profile's four faces."""
    bolt_diameter: tuple[float, float] = (0.004, 0.008)
    """Shank diameter, m (capped so that its hole fits in the profile and the socket)."""
    bolt_height: tuple[float, float] = (0.35, 0.65)
    """Bolt axis above the profile's bottom, fraction of the insertion depth."""
    wall: tuple[float, float] = (0.008, 0.015)
    """Socket block wall around the socket, m."""
    engagement: tuple[float, float] = (0.3, 0.6)
    """How far the bolt's tip goes into the far wall, fraction of the wall."""
    profile_clearance: float = 0.25e-3
    """Profile to socket, m (fixed; `--clearance-mm` sets it)."""
    bolt_clearance: float = 0.5e-3
    """Bolt to block and profile, m (fixed)."""

    @property
    def clearance(self) -> float:
        """The first step's clearance (the profile's), m: what a dataset lists as its own."""
        return self.profile_clearance

    @property
    def finest_clearance(self) -> float:
        """The finest clearance of the steps, m: it sets the physics' timestep."""
        return min(self.profile_clearance, self.bolt_clearance)

    def with_clearance(self, clearance: float) -> ProfileBoltSampler:
        """This config with the first step's (the profile's) clearance set, m."""
        return replace(self, profile_clearance=clearance)

    def validate(self) -> ProfileBoltSampler:
        """Ranges are two finite numbers, low <= high, and both corners build."""
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, tuple) and not (
                len(v) == 2 and all(math.isfinite(x) for x in v) and v[0] <= v[1]
            ):
                raise ParamError(
                    f"sampler range {f.name} = {v} must be two finite numbers, low <= high"
                )
        if not 0.0 <= self.slot_probability <= 1.0:
            raise ParamError(f"slot_probability = {self.slot_probability} must be in [0, 1]")
        for corner in (0, 1):
            probe = replace(
                self,
                **{f.name: (getattr(self, f.name)[corner],) * 2 for f in fields(self)
                   if isinstance(getattr(self, f.name), tuple)},
            )  # fmt: skip
            try:
                probe.sample(0).validate()
            except ParamError as e:
                raise ParamError(f"sampler range reaches an unbuildable assembly: {e}") from e
        return self

    def to_json(self) -> dict:
        return config_to_json(self)

    @staticmethod
    def from_json(d: dict) -> ProfileBoltSampler:
        return config_from_json(ProfileBoltSampler, d, "profile-bolt sampler").validate()

    def sample(self, seed: int) -> ProfileBoltParams:
        """The parameters of `seed` (numpy's PCG64, drawn in a fixed order). The profile
        length is at least the insertion depth plus 5 mm, and the bolt's diameter at most
        what the profile and the insertion depth hold, so every draw builds."""
        rng = np.random.default_rng(seed)

        def u(lo_hi: tuple[float, float]) -> float:
            return float(rng.uniform(*lo_hi))

        side = u(self.profile_side)
        depth = u(self.insertion_depth)
        length = max(u(self.profile_length), depth + 0.005)
        slots = bool(rng.random() < self.slot_probability)
        height = u(self.bolt_height)
        room = min(side - 2 * MIN_WALL, 2 * (min(height, 1 - height) * depth - MIN_WALL))
        diameter = min(u(self.bolt_diameter), room - 2 * self.bolt_clearance)
        return ProfileBoltParams(
            profile_side=side,
            profile_length=length,
            insertion_depth=depth,
            slots=slots,
            bolt_diameter=max(diameter, 0.004),
            bolt_height=height,
            wall=u(self.wall),
            engagement=u(self.engagement),
            profile_clearance=self.profile_clearance,
            bolt_clearance=self.bolt_clearance,
        )


FAMILY = Family(
    name="profile-bolt",
    summary="a square profile into a socket at 0.25 mm, then a bolt from the side through "
    "the block and the profile",
    sampler=ProfileBoltSampler,
    params=ProfileBoltParams,
    build=build_profile_bolt,
)
"""The family (assetgen.families.interface); its modules take the assembly layout."""
