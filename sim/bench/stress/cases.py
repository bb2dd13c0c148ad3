"""The contact stress benchmark's cases: the runs of a module, the same on every engine.

StressConfig (what the benchmark runs), Run (one open-loop run: a model variant, its start
state and its commands), HoleGeometry (a module's hole, from the peg and the clearance),
module_runs (every run of one module) and press_as_force (the friction runs' command under
an engine's actuator gain).

Cases, all in the hole's frame (`bottom`), each peg with the simulator's velocity actuators:

- push: from the design pose (the clearance on every side), full speed (0.25 m/s) toward a
  side face, a corner or one of `even` evenly spread directions, pressing down the axis at
  `press_speed`, for `push_time`; with and without a full-speed twist about the axis (90
  deg/s); at the force a full command presses with (9.1 N) and at twice it (the command
  ramps to twice full speed once the peg is at the wall, so the impact is the same).
- impact: a full-speed descent onto the floor; onto the entrance rim (the peg's bottom face
  half over the plate); a peg tilted by `tilt` dropped onto the entrance.
- friction: the peg upright on the plate, pressed down with `friction_press` N, driven
  sideways at `friction_speed`: the actuators' steady forces give the effective sliding
  coefficient against the configured one.
- rebound: actuators off, the peg thrown at full speed onto the floor and at the walls:
  the largest speed away from the surface over the speed in.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from assetgen.core.mesh import Mesh
from assetgen.core.rotations import matrix_to_quat, quat_to_matrix, rotvec_to_quat
from sim.assets.loading import ModuleAsset


@dataclass(frozen=True)
class StressConfig:
    """What the benchmark runs. Units: m, s, N."""

    push_time: float = 1.5
    """Length of a push, s."""
    window: float = 0.25
    """The last seconds of a run, over which rest is judged."""
    speed: float = 0.25
    """Full command, m/s (the task's max_lin_vel)."""
    twist_speed: float = math.pi / 2
    """Full twist command, rad/s (the task's max_ang_vel)."""
    press_speed: float = 0.02
    """Command down the hole axis during the pushes, m/s."""
    even: int = 8
    """Evenly spread push directions (besides every face and every corner)."""
    max_faces: int = 8
    """At most this many face (and corner) directions a module: a 32-gon's are thinned to
    every 4th, evenly around it."""
    twists: tuple[bool, ...] = (False, True)
    """Pushes without and with the full-speed twist."""
    doubles: tuple[bool, ...] = (False, True)
    """Pushes at the force of a full command and at twice it."""
    double_ramp: tuple[float, float] = (0.3, 0.6)
    """The twice-the-force pushes ramp their command from full to twice full between these
    times, s: the peg is already at the wall."""
    impact_time: float = 0.75
    """Length of an impact run, s."""
    drop_height: float = 0.003
    """The impact runs start with the peg's lowest point this high above what it hits, m."""
    tilt: float = math.radians(10.0)
    """Tilt of the dropped peg, rad."""
    rim_directions: int = 4
    """Rim impacts and tilted drops: this many evenly spread directions each."""
    friction_values: tuple[float, ...] = (0.1, 0.5, 1.0)
    """Configured sliding coefficients the friction runs test."""
    friction_press: float = 1.0
    """Normal force of the friction runs, N."""
    friction_speed: float = 0.05
    """Sideways command of the friction runs, m/s (the peg slides slower: friction holds)."""
    friction_time: tuple[float, float] = (0.15, 0.45)
    """The friction runs average the steady sliding between these times, s."""
    rebound_time: float = 0.1
    """Length of a rebound run, s."""
    rebound_window: float = 0.02
    """The rebound is the largest speed away from the surface within this long after the
    first contact, s (then a free peg may meet another wall)."""
    rest_speed: float = 1e-3
    """At rest: mean speed over the window at most this, m/s ..."""
    rest_motion: float = 1e-5
    """... and peak-to-peak motion over the window at most this, m."""
    floor_pass: float = 0.0025
    """A peg frame origin this far below the hole floor has gone through it, m (half the
    floor's thickness)."""
    cases: tuple[str, ...] = ("push", "impact", "friction", "rebound")
    """Which case families to run."""


@dataclass
class Run:
    """One open-loop run: a model variant, its start state and its commands."""

    kind: str
    """push, impact, friction or rebound."""
    label: str
    """What it is, e.g. `face 2, x2, twist`."""
    variant: str
    """Model variant: `base`, `mu=0.5` (peg friction) or `free` (actuators off)."""
    qpos: np.ndarray
    """(7,) start pose (position, quaternion w x y z) in the module frame."""
    qvel: np.ndarray
    """(6,) start velocity (linear in the module frame, angular in the peg frame)."""
    ctrl: Callable[[np.ndarray], np.ndarray]
    """Times (n,) s -> commands (n, 6): linear m/s and angular rad/s, module frame."""
    duration: float
    info: dict = field(default_factory=dict)
    """Case data the figures need (push direction, friction coefficient, ...)."""


# ----------------------------------------------------------------------------- geometry


def _cross_section(peg: Mesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Side planes of the peg (peg frame) and its bottom corners: (normals (k, 3), offsets
    (k,), bottom vertices (m, 3)). A side plane is n . x <= d. The sides reach the peg's top
    (a chamfer's faces around the tip do not: the hole is the unchamfered peg's)."""
    v, f = peg.vertices, peg.faces
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    side = (np.abs(n[:, 2]) < 0.999) & (tri[:, :, 2].max(axis=1) > v[:, 2].max() - 1e-9)
    d = np.einsum("ij,ij->i", n[side], tri[side, 0])
    planes = np.unique(np.round(np.column_stack([n[side], d]), 9), axis=0)
    bottom = v[v[:, 2] < 1e-9]
    return planes[:, :3], planes[:, 3], bottom


def _outline(asset: ModuleAsset) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """_cross_section's (normals, offsets, bottom corners) of the peg the hole takes. A peg of
    convex pieces (an assembly family's part) is read off the pieces whose bottom faces lie
    on the tip, z = 0: those that touch form one peg (a carrier's pegs stand apart), the one
    nearest the peg frame's origin is the hole's, and its outline is the convex hull of
    their bottom faces (a non-convex section's hole is judged by its hull)."""
    if not asset.peg_pieces:
        return _cross_section(asset.peg)
    from scipy.spatial import ConvexHull

    tips = [p.vertices[p.vertices[:, 2] < 1e-9, :2] for p in asset.peg_pieces]
    tips = [t for t in tips if len(t) >= 3]
    hulls = [t[ConvexHull(t).vertices] for t in tips]  # each counter-clockwise
    n = len(hulls)
    group = list(range(n))

    def root(i: int) -> int:
        while group[i] != i:
            i = group[i]
        return i

    for i in range(n):
        for j in range(i):
            if _touch(hulls[i], hulls[j]):
                group[root(i)] = root(j)
    members: dict[int, list[int]] = {}
    for i in range(n):
        members.setdefault(root(i), []).append(i)
    near = min(members.values(), key=lambda g: min(_distance_out(hulls[i]) for i in g))
    points = np.vstack([hulls[i] for i in near])
    corners = points[ConvexHull(points).vertices]  # counter-clockwise
    normal, offsets = _edge_lines(corners)
    normals = np.column_stack([normal, np.zeros(len(normal))])
    return normals, offsets, np.column_stack([corners, np.zeros(len(corners))])


def _edge_lines(polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A counter-clockwise convex polygon's edges as lines n . x <= d (unit outward n)."""
    edge = np.roll(polygon, -1, axis=0) - polygon
    normal = np.column_stack([edge[:, 1], -edge[:, 0]])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return normal, np.einsum("ij,ij->i", normal, polygon)


def _distance_out(polygon: np.ndarray) -> float:
    """How far the origin lies outside a counter-clockwise convex polygon (<= 0: inside)."""
    return float((-_edge_lines(polygon)[1]).max())


def _touch(a: np.ndarray, b: np.ndarray, tol: float = 1e-6) -> bool:
    """Whether two counter-clockwise convex polygons overlap or touch: no edge of either
    separates them by more than `tol`."""
    for p, q in ((a, b), (b, a)):
        normal, d = _edge_lines(p)
        gap = (q @ normal.T - d).min(axis=0)
        if (gap > tol).any():
            return False
    return True


def _thin(angles: np.ndarray, most: int) -> np.ndarray:
    """At most `most` of the sorted angles, evenly spread."""
    a = np.sort(np.mod(angles, 2 * np.pi))
    if len(a) <= most:
        return a
    return a[:: -(-len(a) // most)]


@dataclass(frozen=True)
class HoleGeometry:
    """A module's hole in its bottom frame, from the peg and the clearance."""

    rot: np.ndarray  # (3, 3) bottom frame axes in the module frame
    pos: np.ndarray  # (3,) bottom frame origin
    normals: np.ndarray  # (k, 3) hole side planes in the bottom frame: n . x <= d
    offsets: np.ndarray  # (k,)
    faces: np.ndarray  # angles (rad, bottom frame) toward the side faces
    corners: np.ndarray  # angles toward the bottom corners
    bottom: np.ndarray  # (m, 3) peg bottom vertices (peg frame)
    vertices: np.ndarray  # (p, 3) every peg vertex (peg frame)
    com: np.ndarray  # (3,) the peg's centre of mass (peg frame)
    clearance: float
    footprint: float = math.inf  # the module's half-width in x and y (module frame), m

    @classmethod
    def of(cls, asset: ModuleAsset, most: int) -> HoleGeometry:
        c = asset.clearance
        normals, offsets, bottom = _outline(asset)
        # the design pose is the bottom frame moved up the axis by c; the hole is every
        # side plane of the peg there, moved out by c
        hole_d = offsets + c + normals[:, 2] * c
        faces = np.arctan2(normals[:, 1], normals[:, 0])
        corners = np.arctan2(bottom[:, 1], bottom[:, 0])
        return cls(
            asset.bottom[:3, :3].copy(),
            asset.bottom[:3, 3].copy(),
            normals,
            hole_d,
            _thin(faces, most),
            _thin(corners, most),
            bottom,
            asset.peg.vertices,
            asset.peg_com,
            c,
            max((float(np.abs(p.vertices[:, :2]).max()) for p in asset.pieces), default=math.inf),
        )

    def direction(self, angle: float) -> np.ndarray:
        """Unit vector (module frame) in the hole's cross-section at `angle` (bottom frame)."""
        return self.rot @ np.array([math.cos(angle), math.sin(angle), 0.0])

    @property
    def axis(self) -> np.ndarray:
        return self.rot[:, 2]

    def edge(self, point: np.ndarray, angle: float) -> float:
        """Distance (m) from `point` (module frame, inside the hole) to the hole's side
        planes along the cross-section direction at `angle`."""
        p0 = (point - self.pos) @ self.rot
        w = np.array([math.cos(angle), math.sin(angle), 0.0])
        nw = self.normals @ w
        ahead = nw > 1e-12
        return float(((self.offsets[ahead] - self.normals[ahead] @ p0) / nw[ahead]).min())

    def design_pose(self) -> np.ndarray:
        """(7,) the design pose: the bottom frame moved up the axis by the clearance."""
        return np.concatenate([self.pos + self.clearance * self.axis, matrix_to_quat(self.rot)])

    def outside(self, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For peg frame origins (..., 3) in the module frame: how far each lies beyond the
        hole's side planes (m, > 0: outside the cross-section) and below its floor."""
        local = (pos - self.pos) @ self.rot
        beyond = (local @ self.normals.T - self.offsets).max(axis=-1)
        return beyond, -local[..., 2]


# ----------------------------------------------------------------------------- the runs


def _hold(vec: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    return lambda t: np.broadcast_to(vec, (len(t), 6)).copy()


def _lowest_lift(geo: HoleGeometry, rot: np.ndarray, pos: np.ndarray, gap: float) -> np.ndarray:
    """`pos` moved along module z so the peg's lowest point is `gap` above the plate top."""
    z = (geo.vertices @ rot.T + pos)[:, 2].min()
    return pos + np.array([0.0, 0.0, gap - z])


def module_runs(asset: ModuleAsset, cfg: StressConfig) -> tuple[list[Run], HoleGeometry]:
    """Every run of one module (see the module docstring)."""
    geo = HoleGeometry.of(asset, cfg.max_faces)
    design = geo.design_pose()
    axis = geo.axis
    zero = np.zeros(6)
    runs: list[Run] = []
    if "push" in cfg.cases:
        dirs = (
            [("face", a) for a in geo.faces]
            + [("corner", a) for a in geo.corners]
            + [("even", a) for a in np.arange(cfg.even) * 2 * np.pi / cfg.even]
        )
        lo, hi = cfg.double_ramp
        for k, (what, angle) in enumerate(dirs):
            u = geo.direction(angle)
            for twist in cfg.twists:
                for double in cfg.doubles:
                    lin = cfg.speed * u
                    ang = cfg.twist_speed * axis if twist else np.zeros(3)
                    press = -cfg.press_speed * axis

                    def ctrl(t, lin=lin, ang=ang, press=press, double=double):
                        s = 1.0 + double * np.clip((t - lo) / (hi - lo), 0.0, 1.0)
                        out = np.empty((len(t), 6))
                        out[:, :3] = s[:, None] * lin + press
                        out[:, 3:] = ang
                        return out

                    runs.append(
                        Run(
                            "push",
                            f"{what} {k}{' x2' if double else ''}{' twist' if twist else ''}",
                            "base",
                            design,
                            zero,
                            ctrl,
                            cfg.push_time,
                            {"twist": twist, "double": double, "direction": what},
                        )
                    )
    if "impact" in cfg.cases:
        down = np.concatenate([-cfg.speed * axis, np.zeros(3)])
        start = design.copy()
        start[:3] += cfg.drop_height * axis
        runs.append(Run("impact", "floor", "base", start, down, _hold(down), cfg.impact_time, {}))
        entrance = asset.entrance[:3, 3]
        for j in range(cfg.rim_directions):
            angle = 2 * np.pi * j / cfg.rim_directions
            u = geo.direction(angle)
            # the hole's edge along u at the entrance, plus the clearance: the peg frame's
            # origin over the plate, its bottom face half over the hole
            pos = entrance + (geo.edge(entrance, angle) + geo.clearance) * u
            pos = _lowest_lift(geo, geo.rot, pos, cfg.drop_height)
            quat = matrix_to_quat(geo.rot)
            runs.append(
                Run(
                    "impact",
                    f"rim {j}",
                    "base",
                    np.concatenate([pos, quat]),
                    down,
                    _hold(down),
                    cfg.impact_time,
                    {"outside": True},
                )
            )
            tilt_axis = geo.direction(angle + np.pi / 2)
            rot = quat_to_matrix(rotvec_to_quat((cfg.tilt * tilt_axis)[None]))[0] @ geo.rot
            pos = _lowest_lift(geo, rot, entrance.copy(), cfg.drop_height)
            runs.append(
                Run(
                    "impact",
                    f"tilted {j}",
                    "base",
                    np.concatenate([pos, matrix_to_quat(rot)]),
                    down,
                    _hold(down),
                    cfg.impact_time,
                    {},
                )
            )
    if "friction" in cfg.cases:
        e = asset.entrance[:3, 3]
        sx = 1.0 if e[0] >= 0 else -1.0
        sy = 1.0 if e[1] >= 0 else -1.0
        # the plate's corner across from the hole, sliding along the other diagonal
        pos = np.array([-0.045 * sx, -0.045 * sy, 0.0])
        slide = np.array([sx, -sy, 0.0]) / math.sqrt(2.0)
        pos = _lowest_lift(geo, np.eye(3), pos, 1e-5)
        for mu in cfg.friction_values:
            runs.append(
                Run(
                    "friction",
                    f"mu {mu:g}",
                    f"mu={mu!r}",
                    np.concatenate([pos, [1.0, 0.0, 0.0, 0.0]]),
                    zero,
                    None,  # set once the actuator gain is known (run_module)
                    cfg.friction_time[1],
                    {"mu": mu, "slide": slide},
                )
            )
    if "rebound" in cfg.cases:
        start = design.copy()
        start[:3] += cfg.drop_height * axis
        throws = [("floor", start, -axis)] + [
            (f"wall {k}", design, geo.direction(a)) for k, a in enumerate(geo.faces[:4])
        ]
        for label, q0, u in throws:
            runs.append(
                Run(
                    "rebound",
                    label,
                    "free",
                    q0,
                    np.concatenate([cfg.speed * u, np.zeros(3)]),
                    _hold(zero),
                    cfg.rebound_time,
                    {"into": u},
                )
            )
    return runs, geo


def press_as_force(runs: list[Run], cfg: StressConfig, kv: float) -> None:
    """The friction runs press with a force, cfg.friction_press: their command is the one
    that gives it under the actuators' gain kv (every engine's runner sets it so)."""
    for r in runs:
        if r.kind == "friction":
            lin = cfg.friction_speed * r.info["slide"] - np.array([0, 0, cfg.friction_press / kv])
            r.ctrl = _hold(np.concatenate([lin, np.zeros(3)]))
