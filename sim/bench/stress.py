"""The contact stress benchmark: how hard and how still MuJoCo's contacts are for a module.

    assetgen bench contacts DATASET [--limit N] [--set FIELD=VALUE ...] [--source sim|mjcf]

Each module is stepped open loop (the commands are fixed in advance) through `mujoco.rollout` in
C threads, one model per module: the simulator's own model of it (sim.engines.mujoco.scene,
under the given PhysicsConfig) or its exported `peg_in_hole.xml` (the physics the file carries).
A contact sensor on the peg reads MuJoCo's own contact distance at every physics step.

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

Figures of a push or impact: transient penetration (the deepest over the run), depth at rest
(the deepest over the last `window`), not at rest (over the last `window`, the peg frame's
mean speed above `rest_speed` or its peak-to-peak motion above `rest_motion`), and pass-through
(the peg frame's origin leaves the hole's cross-section below the mounting surface, or sinks
more than `floor_pass` below the hole floor).
"""

from __future__ import annotations

import copy
import math
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import mujoco
import numpy as np
from mujoco import rollout

from assetgen.core.mesh import Mesh
from assetgen.core.mujoco_config import LEGACY_PHYSICS, PHYSICS_VERSION, physics_for
from assetgen.core.recorded_path import recorded_path
from assetgen.core.rotations import matrix_to_quat, quat_to_matrix, rotvec_to_quat
from sim.assets.loading import ModuleAsset
from sim.engines.mujoco.scene import build_spec
from sim.engines.registry import get_engine
from sim.task.config import PhysicsConfig, TaskConfig

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS


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
    (k,), bottom vertices (m, 3)). A side plane is n . x <= d."""
    v, f = peg.vertices, peg.faces
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    side = np.abs(n[:, 2]) < 0.999
    d = np.einsum("ij,ij->i", n[side], tri[side, 0])
    planes = np.unique(np.round(np.column_stack([n[side], d]), 9), axis=0)
    bottom = v[v[:, 2] < 1e-9]
    return planes[:, :3], planes[:, 3], bottom


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

    @classmethod
    def of(cls, asset: ModuleAsset, most: int) -> HoleGeometry:
        c = asset.clearance
        normals, offsets, bottom = _cross_section(asset.peg)
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


# ----------------------------------------------------------------------------- models


def _add_contact_sensor(spec: mujoco.MjSpec, body: str) -> None:
    """The deepest contact of `body` each step: sensordata (found, dist)."""
    s = spec.add_sensor()
    s.name = "peg_contact"
    s.type = mujoco.mjtSensor.mjSENS_CONTACT
    s.objtype = mujoco.mjtObj.mjOBJ_BODY
    s.objname = body
    fields = (mujoco.mjtConDataField.mjCONDATA_FOUND, mujoco.mjtConDataField.mjCONDATA_DIST)
    s.intprm[0] = sum(1 << int(f) for f in fields)
    s.intprm[1] = 1  # reduce: the contact of least distance
    s.intprm[2] = 1  # one contact


def module_model(
    asset: ModuleAsset, physics: PhysicsConfig, task: TaskConfig, mjcf: str | None = None
) -> mujoco.MjModel:
    """The module's model with the contact sensor: the simulator's (sim.engines.mujoco.scene) under
    `physics`, or the exported file `mjcf` as it is (its own physics)."""
    if mjcf is None:
        spec = build_spec(
            [asset], physics, max_lin_vel=task.max_lin_vel, max_ang_vel=task.max_ang_vel
        )
    else:
        spec = mujoco.MjSpec.from_file(mjcf)
    _add_contact_sensor(spec, "peg")
    return spec.compile()


def _variant(base: mujoco.MjModel, name: str) -> mujoco.MjModel:
    if name == "base":
        return base
    m = copy.copy(base)
    if name == "free":
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_ACTUATION)
    elif name.startswith("mu="):
        peg = m.body("peg")
        m.geom_friction[peg.geomadr[0] : peg.geomadr[0] + peg.geomnum[0], 0] = float(name[3:])
    else:
        raise ValueError(f"unknown model variant {name!r}")
    return m


# ----------------------------------------------------------------------------- running


def press_as_force(runs: list[Run], cfg: StressConfig, kv: float) -> None:
    """The friction runs press with a force, cfg.friction_press: their command is the one
    that gives it under the actuators' gain kv (every engine's runner sets it so)."""
    for r in runs:
        if r.kind == "friction":
            lin = cfg.friction_speed * r.info["slide"] - np.array([0, 0, cfg.friction_press / kv])
            r.ctrl = _hold(np.concatenate([lin, np.zeros(3)]))


def run_module(
    asset: ModuleAsset,
    model: mujoco.MjModel,
    cfg: StressConfig,
    pool: rollout.Rollout,
    nthread: int,
) -> list[dict]:
    """Every run of one module; one record (its figures) a run."""
    runs, geo = module_runs(asset, cfg)
    h = model.opt.timestep
    kv = float(model.actuator_gainprm[0, 0])
    press_as_force(runs, cfg, kv)
    scratch = mujoco.MjData(model)
    nstate = mujoco.mj_stateSize(model, STATE_SPEC)
    joint = model.body("peg").jntadr[0]
    qadr, vadr = model.jnt_qposadr[joint], model.jnt_dofadr[joint]
    records: list[dict] = []
    groups: dict[tuple[str, int], list[Run]] = {}
    for r in runs:
        groups.setdefault((r.variant, round(r.duration / h)), []).append(r)
    datas = [mujoco.MjData(model) for _ in range(nthread)]
    for (variant, nstep), group in groups.items():
        m = _variant(model, variant)
        state0 = np.empty((len(group), nstate))
        ctrl = np.empty((len(group), nstep, model.nu))
        times = np.arange(nstep) * h
        for i, r in enumerate(group):
            mujoco.mj_resetData(m, scratch)
            scratch.qpos[qadr : qadr + 7] = r.qpos
            scratch.qvel[vadr : vadr + 6] = r.qvel
            mujoco.mj_getState(m, scratch, state0[i], STATE_SPEC)
            ctrl[i] = r.ctrl(times)
        state = np.empty((len(group), nstep, nstate))
        sensor = np.empty((len(group), nstep, model.nsensordata))
        pool.rollout(
            [m] * len(group),
            datas,
            state0,
            ctrl,
            nstep=nstep,
            state=state,
            sensordata=sensor,
            skip_checks=True,
        )
        lin = 1 + model.nq + vadr
        records += run_figures(
            group,
            state[:, :, 1 + qadr : 4 + qadr],
            state[:, :, 4 + qadr : 8 + qadr],
            state[:, :, lin : lin + 3],
            state[:, :, lin + 3 : lin + 6],
            sensor,
            geo,
            cfg,
            h,
            kv,
        )
    return [{"module": asset.id, **r} for r in records]


def run_figures(
    runs: list[Run],
    pos: np.ndarray,
    quat: np.ndarray,
    vel: np.ndarray,
    ang: np.ndarray,
    sensor: np.ndarray,
    geo: HoleGeometry,
    cfg: StressConfig,
    h: float,
    kv: float,
) -> list[dict]:
    """Each run's figures from its trajectory: peg frame positions (runs, steps, 3) and
    orientations (runs, steps, 4), its linear (module frame) and angular (peg frame)
    velocities, the contact sensor (found, dist) per step."""
    pen = np.where(sensor[:, :, 0] > 0, -sensor[:, :, 1], 0.0).clip(0.0)
    w = max(1, round(cfg.window / h))
    beyond, below = geo.outside(pos)
    out = []
    for i, r in enumerate(runs):
        rec = {"kind": r.kind, "label": r.label}
        if r.kind in ("push", "impact"):
            last = pos[i, -w:]
            speed = float(np.linalg.norm(vel[i, -w:], axis=1).mean())
            motion = float(np.linalg.norm(np.ptp(last, axis=0)))
            # a peg still settling moves one way (a slow tilt of the velocity-controlled peg
            # until a second wall stops it), along a line or an arc, and may stop within the
            # window; a chattering one goes back and forth: its path, sampled every 10 ms,
            # is longer than its net move
            coarse = last[:: max(1, round(0.01 / h))]
            path = float(np.linalg.norm(np.diff(coarse, axis=0), axis=1).sum())
            wobble_motion = path - float(np.linalg.norm(coarse[-1] - coarse[0]))
            through = ((beyond[i] > 0) & (pos[i, :, 2] < -geo.clearance)) | (
                below[i] > cfg.floor_pass
            )
            rec |= {
                "penetration": float(pen[i].max()),
                "rest_depth": float(pen[i, -w:].max()),
                "rest_speed": speed,
                "rest_motion": motion,
                "moving": bool(speed > cfg.rest_speed or motion > cfg.rest_motion),
                "wobble_motion": wobble_motion,
                "turning": float(np.linalg.norm(ang[i, -w:], axis=1).mean()),
                "passed_through": bool(through.any()),
                "twist": bool(r.info.get("twist", False)),
                "double": bool(r.info.get("double", False)),
            }
        elif r.kind == "friction":
            a, b = (round(t / h) for t in cfg.friction_time)
            slide = r.info["slide"]
            v_cmd = cfg.friction_speed
            f_t = kv * (v_cmd - vel[i, a:b] @ slide)
            f_n = cfg.friction_press + kv * vel[i, a:b, 2]
            rec |= {
                "mu": r.info["mu"],
                "mu_effective": float(f_t.mean() / f_n.mean()),
                "slide_speed": float((vel[i, a:b] @ slide).mean()),
                "penetration": float(pen[i].max()),
            }
        else:
            # the centre of mass's velocity: a peg knocked into a spin moves its frame's
            # origin without bouncing
            rot = quat_to_matrix(quat[i])
            spin = np.einsum("nij,nj->ni", rot, ang[i])
            com = vel[i] + np.cross(spin, rot @ geo.com)
            away = -(com @ r.info["into"])
            # the first impact only: a free peg then rattles about its hole, and a knock off
            # another wall is not this one's rebound
            hit = np.flatnonzero(pen[i] > 0)
            k0 = int(hit[0]) if len(hit) else len(away)
            first = away[k0 : k0 + max(1, round(cfg.rebound_window / h))]
            rec |= {"restitution": float(max(0.0, first.max(initial=0.0)) / cfg.speed)}
        out.append(rec)
    return out


def stress(
    assets: list[ModuleAsset],
    physics: PhysicsConfig,
    cfg: StressConfig = StressConfig(),
    *,
    task: TaskConfig | None = None,
    mjcf: list[str] | None = None,
    nthread: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[dict]:
    """Every run of every module: one record a run (see `run_module`). `mjcf`: the modules'
    exported files, to run those instead of the simulator's models."""
    task = task or TaskConfig(physics=physics)
    nthread = max(1, nthread or os.cpu_count() or 1)
    records: list[dict] = []
    with rollout.Rollout(nthread=nthread if nthread > 1 else 0) as pool:
        for k, asset in enumerate(assets):
            model = module_model(asset, physics, task, None if mjcf is None else mjcf[k])
            records += run_module(asset, model, cfg, pool, nthread)
            if progress is not None:
                progress(k + 1, len(assets))
    return records


# ----------------------------------------------------------------------------- summary


def _pct(x: np.ndarray, q: float) -> float:
    return float(np.percentile(x, q)) if len(x) else float("nan")


def _chatters(r: dict, cfg: StressConfig = StressConfig()) -> bool:
    """A run chatters when, over the window, its path (sampled every 10 ms) is longer than
    its net move by more than the rest motion: it goes back and forth. A run not at rest
    that does not chatter is still settling one way."""
    return bool(r["wobble_motion"] > cfg.rest_motion)


def summarize(records: list[dict], clearance: float) -> dict:
    """The benchmark's figures over every record of one clearance (lengths in m)."""
    pushes = [r for r in records if r["kind"] == "push"]
    impacts = [r for r in records if r["kind"] == "impact"]
    hits = pushes + impacts
    pen = np.array([r["penetration"] for r in hits])
    # depth at rest: of the runs that came to rest (a peg still sliding is in transit)
    rest = np.array([r["rest_depth"] for r in hits if not r["moving"]])
    straight = [r for r in pushes if not r["twist"]]
    twisting = [r for r in pushes if r["twist"]]
    out: dict = {
        "modules": len({r["module"] for r in records}),
        "clearance": clearance,
        "pushes": len(pushes),
        "impacts": len(impacts),
        "passed_through": sum(r["passed_through"] for r in hits),
        "penetration_worst": float(pen.max()) if len(pen) else float("nan"),
        "penetration_p99": _pct(pen, 99),
        "push_penetration_worst": max((r["penetration"] for r in pushes), default=float("nan")),
        "push_penetration_p99": _pct(np.array([r["penetration"] for r in pushes]), 99),
        "impact_penetration_worst": max((r["penetration"] for r in impacts), default=float("nan")),
        "impact_penetration_p99": _pct(np.array([r["penetration"] for r in impacts]), 99),
        "deeper_than_clearance": int((pen > clearance).sum()),
        "rest_depth_worst": float(rest.max()) if len(rest) else float("nan"),
        "rest_depth_p99": _pct(rest, 99),
        "straight_pushes": len(straight),
        "straight_not_at_rest": sum(r["moving"] for r in straight),
        "twisting_pushes": len(twisting),
        "twisting_not_at_rest": sum(r["moving"] for r in twisting),
        "twisting_turning": sum(r["turning"] > 0.05 for r in twisting),
        "straight_chattering": sum(_chatters(r) for r in straight),
        "twisting_chattering": sum(_chatters(r) for r in twisting),
        "impacts_not_at_rest": sum(r["moving"] for r in impacts),
    }
    for mu in sorted({r["mu"] for r in records if r["kind"] == "friction"}):
        ratio = np.array([r["mu_effective"] / r["mu"] for r in records if r.get("mu") == mu])
        out[f"friction_{mu:g}_min"] = float(ratio.min())
        out[f"friction_{mu:g}_max"] = float(ratio.max())
    rebound = [r["restitution"] for r in records if r["kind"] == "rebound"]
    out["rebound_worst"] = max(rebound, default=float("nan"))
    return out


TARGETS: dict[str, Callable[[dict], bool]] = {
    "no pass-through": lambda s: s["passed_through"] == 0,
    "penetration p99 <= 25 % (1, 0.5 mm) / 50 % (0.25 mm) of the clearance": lambda s: (
        s["penetration_p99"] <= (0.5 if s["clearance"] < 0.4e-3 else 0.25) * s["clearance"]
    ),
    "worst penetration <= 50 % (1, 0.5 mm) / 100 % (0.25 mm) of the clearance": lambda s: (
        s["penetration_worst"] <= (1.0 if s["clearance"] < 0.4e-3 else 0.5) * s["clearance"]
    ),
    "depth at rest <= 5 % of the clearance": lambda s: (
        s["rest_depth_worst"] <= 0.05 * s["clearance"]
    ),
    "every straight push at rest": lambda s: s["straight_not_at_rest"] == 0,
    "99 % of twisting pushes at rest": lambda s: (
        s["twisting_not_at_rest"] <= 0.01 * s["twisting_pushes"]
    ),
    "friction within 5 %": lambda s: all(
        0.95 <= v <= 1.05 for k, v in s.items() if k.startswith("friction_")
    ),
    "rebound e <= 0.1": lambda s: not s["rebound_worst"] > 0.1,
}
"""The contact targets, each a test of a summary."""


def targets(summary: dict) -> dict[str, bool]:
    """Which targets a summary meets."""
    return {name: bool(test(summary)) for name, test in TARGETS.items()}


# ----------------------------------------------------------------------------- the command

_ROWS = (
    ("pass-throughs", "passed_through", None),
    ("transient penetration, worst", "penetration_worst", "mm"),
    ("transient penetration, p99", "penetration_p99", "mm"),
    ("  pushes: worst / p99", ("push_penetration_worst", "push_penetration_p99"), "mm"),
    ("  impacts: worst / p99", ("impact_penetration_worst", "impact_penetration_p99"), "mm"),
    ("runs deeper than the clearance", "deeper_than_clearance", None),
    ("depth at rest, worst / p99", ("rest_depth_worst", "rest_depth_p99"), "mm"),
    ("straight pushes not at rest", ("straight_not_at_rest", "straight_pushes"), "of"),
    ("twisting pushes not at rest", ("twisting_not_at_rest", "twisting_pushes"), "of"),
    ("  of them still turning", "twisting_turning", None),
    ("pushes chattering: straight / twisting", ("straight_chattering", "twisting_chattering"), "/"),
    ("impacts not at rest", ("impacts_not_at_rest", "impacts"), "of"),
    ("effective / configured friction", "friction", "ratio"),
    ("rebound e (actuators off), worst", "rebound_worst", "e"),
)


def format_summary(s: dict) -> list[tuple[str, str]]:
    """(figure, value) rows of a summary, lengths in mm and as a fraction of the clearance."""
    c = s["clearance"]
    rows = []
    for name, key, unit in _ROWS:
        if unit == "mm":
            keys = key if isinstance(key, tuple) else (key,)
            text = " / ".join(f"{s[k] * 1e3:.3f} mm ({s[k] / c:.0%})" for k in keys)
        elif unit == "/":
            text = f"{s[key[0]]} / {s[key[1]]}"
        elif unit == "of":
            text = f"{s[key[0]]} of {s[key[1]]}"
        elif unit == "ratio":
            text = ", ".join(
                f"mu {k.split('_')[1]}: {s[k]:.3f}-{s[k.replace('_min', '_max')]:.3f}"
                for k in s
                if k.startswith("friction_") and k.endswith("_min")
            )
        elif unit == "e":
            text = f"{s[key]:.3f}"
        else:
            text = str(s[key])
        rows.append((name, text))
    return rows


def stress_on_mujoco(
    assets: list[ModuleAsset],
    cfg: StressConfig,
    task: TaskConfig,
    settings: PhysicsConfig | None = None,
    progress: Callable[[int, int], None] | None = None,
    *,
    mjcf: list[str] | None = None,
    nthread: int | None = None,
) -> list[dict]:
    """`stress` in the registry's runner signature (sim/engines/registry.py): the physics is
    the task's (settings: unused)."""
    return stress(assets, task.physics, cfg, mjcf=mjcf, nthread=nthread, progress=progress)


def main(args) -> int:
    """`assetgen bench contacts DATASET`: args.dataset, args.limit, args.physics_version (an
    earlier version's settings; default: the project's for the dataset's clearance), args.set
    (overrides of the engine's settings: PhysicsConfig, or the engine's own), args.source (sim
    or mjcf), args.cases, args.threads, args.json (a file), args.sim (a registered engine,
    whose runner sim/engines/registry.py names)."""
    import sys
    from dataclasses import replace

    from assetgen.core.atomic_file import write_json
    from assetgen.core.overrides import parse_overrides
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import resolve
    from sim.assets.loading import load_dataset

    root, _ = resolve(args.dataset)
    ids = Dataset(root).ids
    if args.limit is not None:
        if args.limit < 1:
            raise ValueError(f"--limit {args.limit}: give at least 1 module")
        ids = ids[: args.limit]
    version = getattr(args, "physics_version", None)
    if version is None or version == PHYSICS_VERSION:
        base = None
    elif version in LEGACY_PHYSICS:
        base = replace(PhysicsConfig(), **LEGACY_PHYSICS[version])
    else:
        known = sorted([*LEGACY_PHYSICS, PHYSICS_VERSION])
        raise ValueError(f"--physics-version {version}: the versions are {known}")
    cfg = StressConfig()
    if args.cases:
        cases = tuple(args.cases.split(","))
        bad = sorted(set(cases) - set(cfg.cases))
        if bad:
            raise ValueError(f"--cases: unknown {bad}; valid: {','.join(cfg.cases)}")
        cfg = replace(cfg, cases=cases)
    push_time = getattr(args, "push_time", None)
    if push_time is not None:
        if not push_time > 2 * cfg.window:
            raise ValueError(f"--push-time {push_time}: give more than {2 * cfg.window} s")
        cfg = replace(cfg, push_time=push_time)
    assets = load_dataset(root, ids)
    # the dataset's clearance sets the step (physics_for), unless an older version is asked
    base = base or physics_for(min(a.clearance for a in assets))
    spec = get_engine(getattr(args, "sim", None))
    settings_class = spec.load("settings")
    on_physics = settings_class is PhysicsConfig  # else the engine has settings of its own
    # --set: the engine's settings (PhysicsConfig, or the engine's own)
    on_mujoco = (args.set or []) if on_physics else []
    physics = replace(base, **parse_overrides(PhysicsConfig, on_mujoco)).validate()
    mjcf = None
    if args.source == "mjcf":
        ds = Dataset(root)
        mjcf = [str(ds.module_dir(i) / "peg_in_hole.xml") for i in ids]

    def progress(done: int, total: int) -> None:
        print(f"\r{done}/{total} modules", end="", file=sys.stderr, flush=True)

    if not on_physics and (mjcf is not None or version is not None):
        raise ValueError(f"--sim {spec.name} takes its settings from {settings_class.__name__} "
                         "(--set FIELD=VALUE): drop --source and --physics-version")  # fmt: skip
    if mjcf is not None and not spec.reads_mjcf:
        raise ValueError(f"--sim {spec.name} runs the simulator's models: drop --source mjcf")
    settings = (
        physics if on_physics else settings_class(**parse_overrides(settings_class, args.set or []))
    )
    files = {"mjcf": mjcf, "nthread": args.threads} if spec.reads_mjcf else {}
    t0 = time.perf_counter()
    records = spec.load("stress")(assets, cfg, TaskConfig(physics=physics), settings,
                                  progress=progress, **files)  # fmt: skip
    print(file=sys.stderr)
    seconds = time.perf_counter() - t0
    clearances = sorted({a.clearance for a in assets})
    by = {a.id: a.clearance for a in assets}
    summaries = [summarize([r for r in records if by[r["module"]] == c], c) for c in clearances]
    for s in summaries:
        print(
            f"{root}: {s['modules']} modules, clearance {s['clearance'] * 1e3:g} mm, "
            f"{'exported files' if mjcf else 'simulator models' if spec.reads_mjcf else spec.label}"
            f", {seconds:.0f} s"
        )
        rows = format_summary(s)
        width = max(len(k) for k, _ in rows)
        for k, v in rows:
            print(f"  {k:<{width}}  {v}")
        for name, ok in targets(s).items():
            print(f"  [{'met' if ok else 'MISSED'}] {name}")
    if args.json:
        write_json(
            args.json,
            {
                "dataset": recorded_path(root),
                "source": args.source,
                "engine": spec.name,
                "physics": asdict(settings) if mjcf is None else "the exported files'",
                "physics_version": version or PHYSICS_VERSION,
                "stress": asdict(cfg),
                "seconds": seconds,
                "summaries": [s | {"targets": targets(s)} for s in summaries],
                "runs": records,
            },
        )
    return 0
