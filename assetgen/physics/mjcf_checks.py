"""Physics checks of an exported module (`peg_in_hole.xml`): does MuJoCo keep the peg out of
the walls, and does a peg pushed down the hole reach the floor?

    drop_test(xml)       peg above the entrance, pushed down the hole axis (weight + 5 N)
    side_push_test(xml)  seated peg pushed sideways (5 N) in 8 directions across the axis

Both read only the MJCF (sites `entrance` and `bottom`, body `peg`, numeric `clearance`),
work in the hole's own frame (a tilted hole is pushed along its own axis), change nothing
on disk, and are deterministic. Penetrations are MuJoCo's own contact distances.

How the force is applied matters more than one would think. MuJoCo only finds a contact once
the surfaces overlap: a peg flying into a wall under the full force is up to a step's travel
inside it before any contact acts (at 5 ms steps 0.6 - 1 mm), and a contact lost for one step
(a peg rocking onto one edge, or bouncing in a V between two walls) costs the same again. That
measures the timestep, not the contact (the contact stress benchmark, sim/bench/stress/,
measures those impacts). So the push is guarded (see `_push`): while the peg touches nothing
its speed is limited (`speed`, default 1 cm/s sideways, 10 cm/s down the hole); in contact
the force ramps up to its full value over RAMP_TIME, and the run ends once the peg has rested
under the full force for `rest_time` s. `speed=None` gives the free,
unguarded push for comparison. By default the peg's orientation is held (rotational inertia
x 1e6), as the task's controller holds it; see the functions for why.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from assetgen.formats.mjcf import CLEARANCE_NUMERIC, PEG_BODY, PEG_GEOM, PEG_JOINT

REST_SPEED = 1e-3
"""A peg moving slower than this (m/s, its frame's origin) counts as at rest: far below a
chattering contact (~10 mm/s and up), above the slow creep of MuJoCo's soft friction along
a wall (~0.1 mm/s with friction 1 and impratio 1)."""
REST_ANGULAR_SPEED = 1e-2
"""... and turning slower than this (rad/s)."""
REST_TIME = 0.2
"""s: a push is at rest once the peg has rested under the full force this long."""
RAMP_TIME = 0.05
"""s: in contact, the force ramps to its full value over this time."""
SEATED_LIFT = 1e-6
"""m above the floor at which `side_push_test` measures the seated peg's free travel: far
below any tolerance of interest, enough for every distance to the floor to be positive."""


@dataclass
class _Scene:
    """A loaded module: model, data and the frames the checks work in."""

    model: mujoco.MjModel
    data: mujoco.MjData
    body: int
    geom: int  # the part's first geom (a Table I peg has one)
    geoms: np.ndarray  # every geom of the part (an assembly's part: its convex pieces)
    qpos: int  # address of the free joint in qpos (7: pos, quat w x y z)
    dof: int  # address of the free joint in qvel (6: linear world, angular local)
    bottom_pos: np.ndarray  # (3,) m, module frame
    bottom_rot: np.ndarray  # (3, 3) columns: hole x, y, z (out of the hole)
    bottom_quat: np.ndarray  # (4,) w x y z
    depth: float  # m, along the axis from the floor to the entrance point
    clearance: float  # m

    def reset(self, axial: float) -> None:
        """Peg aligned with the hole, its frame `axial` m above the bottom frame on the axis,
        at rest, with no applied force."""
        d = self.data
        mujoco.mj_resetData(self.model, d)
        d.qpos[self.qpos : self.qpos + 3] = self.bottom_pos + axial * self.bottom_rot[:, 2]
        d.qpos[self.qpos + 3 : self.qpos + 7] = self.bottom_quat
        mujoco.mj_forward(self.model, d)

    def peg_pos(self) -> np.ndarray:
        return self.data.qpos[self.qpos : self.qpos + 3].copy()

    def penetration(self) -> float:
        """Deepest overlap (m, >= 0) of the peg with any piece, from the current contacts."""
        c = self.data.contact
        n = self.data.ncon
        if n == 0:
            return 0.0
        mine = np.isin(c.geom1[:n], self.geoms) | np.isin(c.geom2[:n], self.geoms)
        return float(max(0.0, -c.dist[:n][mine].min())) if mine.any() else 0.0

    def touching(self) -> bool:
        """Whether the current contacts (margin 0: overlaps only) include the peg."""
        n = self.data.ncon
        c = self.data.contact
        if not n:
            return False
        return bool((np.isin(c.geom1[:n], self.geoms) | np.isin(c.geom2[:n], self.geoms)).any())

    def speeds(self) -> tuple[float, float]:
        v = self.data.qvel[self.dof : self.dof + 6]
        return float(np.linalg.norm(v[:3])), float(np.linalg.norm(v[3:]))


def _load(xml_path: Path, part: str | None = None, timestep: float | None = None) -> _Scene:
    """A Table I module's MJCF (part None), or step `part` of an assembly's MJCF: that part
    moves; the parts of earlier steps are fixed where they were inserted (their free joints
    removed); the parts of later steps are not there yet (their contacts off). `timestep`
    replaces the file's physics step (s)."""
    if part is None:
        model = mujoco.MjModel.from_xml_path(str(xml_path))
        names = (PEG_BODY, PEG_JOINT, "bottom", "entrance", CLEARANCE_NUMERIC)
    else:
        spec = mujoco.MjSpec.from_file(str(xml_path))
        text = spec.text("steps")
        order = text.data.split() if text is not None else []
        if part not in order:
            raise ValueError(f"{xml_path}: no step moves a part {part!r}; the steps: {order}")
        k = order.index(part)
        for earlier in order[:k]:
            spec.delete(spec.joint(f"{earlier}_free"))  # fixed where it was inserted
        model = spec.compile()
        for later in order[k + 1 :]:
            g = model.geom_bodyid == model.body(later).id
            model.geom_contype[g] = 0
            model.geom_conaffinity[g] = 0
        names = (part, f"{part}_free", f"bottom_{part}", f"entrance_{part}", f"clearance_{part}")
    if timestep is not None:
        if not 0 < timestep <= model.opt.timestep:
            raise ValueError(f"timestep = {timestep!r} s: give a step in (0, the file's)")
        model.opt.timestep = timestep
    body_name, joint_name, bottom_name, entrance_name, clearance_name = names
    data = mujoco.MjData(model)
    body = model.body(body_name).id
    joint = model.joint(joint_name)
    bottom = model.site(bottom_name)
    entrance = model.site(entrance_name)
    mujoco.mj_kinematics(model, data)
    rot = data.site_xmat[bottom.id].reshape(3, 3).copy()
    pos = data.site_xpos[bottom.id].copy()
    depth = float((data.site_xpos[entrance.id] - pos) @ rot[:, 2])
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, rot.ravel())
    clearance = float(model.numeric(clearance_name).data[0])
    if part is None:
        geoms = np.array([model.geom(PEG_GEOM).id])
    else:
        geoms = np.flatnonzero(model.geom_bodyid == body)
    return _Scene(
        model,
        data,
        body,
        int(geoms[0]),
        geoms,
        int(joint.qposadr[0]),
        int(joint.dofadr[0]),
        pos,
        rot,
        quat,
        depth,
        clearance,
    )


def _push(
    s: _Scene,
    force: np.ndarray,
    *,
    speed: float | None,
    max_steps: int,
    rest_steps: int,
    ramp: int = 10,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """Push the peg's COM with `force` (3,) N, guarded by `speed`, until it rests.

    At 200 Hz a 5 N force moves an unsupported 0.2 kg peg ~0.6 mm in a single step, so a
    force applied in full before the walls hold the peg measures the timestep, not the
    contacts. Each step therefore first finds the contacts of the current state (mj_step1)
    and sets the force's magnitude: not touching, what brings the COM's speed along the
    force to `speed` m/s in one step (a speed limiter); touching and slower than `speed`,
    the previous magnitude plus 1/`ramp` of the full one (so a contact found on one edge
    only does not tip the peg over before the others touch); touching but faster (sliding
    along a wall), half the previous magnitude. At rest against the walls that is the full
    force. With speed None the full force acts from the start.

    Stops once the full force has acted for `rest_steps` steps in a row with the peg at rest
    (REST_SPEED, REST_ANGULAR_SPEED), or after `max_steps`. Returns the peg frame's
    positions (n, 3) m after each step, the penetration (n,) m of the state each step
    started from, and whether it came to rest (then the last `rest_steps` are the rest).
    """
    m, d = s.model, s.data
    mass = float(m.body_subtreemass[s.body])
    full = float(np.linalg.norm(force))
    u = force / full if full > 0 else np.zeros(3)
    pos = np.zeros((max_steps, 3))
    pen = np.zeros(max_steps)
    level = full if speed is None else 0.0
    quiet = 0
    damping = None
    for k in range(max_steps):
        mujoco.mj_step1(m, d)
        pen[k] = s.penetration()
        if damping is None:
            damping = _linear_damping(s, u)
        if speed is not None:
            # free joint: qvel[:3] is the velocity of the body frame's origin (world frame);
            # the COM's adds the rotation's share (qvel[3:] is in the body frame)
            rot = d.xmat[s.body].reshape(3, 3)
            spin = np.cross(d.qvel[s.dof + 3 : s.dof + 6], m.body_ipos[s.body])
            v = d.qvel[s.dof : s.dof + 3] + rot @ spin
            if not s.touching():
                # implicit damping c (the file's velocity actuators at command 0):
                # m (v' - v) = h (F - c v'), so v' = speed needs F = m (speed - v) / h + c speed
                level = float(
                    np.clip(mass * (speed - v @ u) / m.opt.timestep + damping * speed, 0.0, full)
                )
            elif np.linalg.norm(v) <= speed:
                level = min(full, level + full / ramp)
            else:
                level *= 0.5
        d.xfrc_applied[s.body, :3] = level * u  # xfrc_applied acts at the COM
        mujoco.mj_step2(m, d)
        pos[k] = d.qpos[s.qpos : s.qpos + 3]
        lin, ang = s.speeds()
        quiet = quiet + 1 if level == full and lin < REST_SPEED and ang < REST_ANGULAR_SPEED else 0
        if quiet >= rest_steps:
            return pos[: k + 1], pen[: k + 1], True
    return pos, pen, False


def _steps(model: mujoco.MjModel, seconds: float) -> int:
    """Physics steps of `model` in `seconds` (at least one)."""
    return max(1, round(seconds / model.opt.timestep))


def _linear_damping(s: _Scene, u: np.ndarray) -> float:
    """Damping (N s/m) of the file's actuators against a translation of the peg along unit
    `u` at their current commands' bias: sum over velocity actuators (affine bias
    -kv x velocity) of kv (moment . u)^2. 0 for a file without actuators. Needs the
    transmission of the current state (mj_step1 or mj_forward)."""
    m, d = s.model, s.data
    if m.nu == 0:
        return 0.0
    moment = np.zeros((m.nu, m.nv))
    mujoco.mju_sparse2dense(
        moment, d.actuator_moment, d.moment_rownnz, d.moment_rowadr, d.moment_colind
    )
    kv = np.where(
        m.actuator_biastype == mujoco.mjtBias.mjBIAS_AFFINE, -m.actuator_biasprm[:, 2], 0.0
    )
    along = moment[:, s.dof : s.dof + 3] @ u
    return float(np.sum(kv * along**2))


def _free_travel(
    s: _Scene, u: np.ndarray, limit: float, march: float = 5e-4, tol: float = 1e-7
) -> float:
    """How far (m) the peg, from its current pose, translates along unit `u` before it
    touches a piece (MuJoCo's own convex distances); `limit` if it never does within it.

    Marches in `march` steps (thinner than any wall, so none is jumped over), then bisects
    the step where the first contact appears down to `tol`.
    """
    m, d = s.model, s.data
    start = d.qpos[s.qpos : s.qpos + 3].copy()
    mine = set(s.geoms.tolist())
    pieces = np.array([g for g in range(m.ngeom) if g not in mine and m.geom_conaffinity[g]])
    fromto = np.zeros(6)
    # only the pairs whose bounding spheres come within `march` of each other somewhere on
    # the path (an assembly's part has a dozen pieces and its scene hundreds)
    mujoco.mj_kinematics(m, d)
    centre = d.geom_xpos[pieces]  # (P, 3), static
    part = d.geom_xpos[s.geoms]  # (G, 3) at t = 0
    rel = centre[None, :, :] - part[:, None, :]  # (G, P, 3)
    along = np.clip(rel @ u, 0.0, limit)
    gap = np.linalg.norm(rel - along[..., None] * u, axis=2)
    reach = m.geom_rbound[s.geoms][:, None] + m.geom_rbound[pieces][None, :] + march
    near_a, near_b = np.nonzero(gap <= reach)
    pairs = [(int(s.geoms[a]), int(pieces[b])) for a, b in zip(near_a, near_b, strict=True)]

    def clear(t: float) -> bool:
        d.qpos[s.qpos : s.qpos + 3] = start + t * u
        mujoco.mj_kinematics(m, d)
        return all(mujoco.mj_geomDistance(m, d, a, g, march, fromto) > 0 for a, g in pairs)

    lo = 0.0
    result = limit
    while lo < limit:
        hi = min(lo + march, limit)
        if clear(hi):
            lo = hi
            continue
        while hi - lo > tol:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if clear(mid) else (lo, mid)
        result = lo
        break
    d.qpos[s.qpos : s.qpos + 3] = start
    mujoco.mj_kinematics(m, d)
    return result


def drop_test(
    xml_path: Path,
    *,
    duration: float | None = None,
    push: float = 5.0,
    gravity: float = 9.81,
    start_height: float = 0.005,
    speed: float | None = 0.1,
    hold_orientation: bool = True,
    rest_time: float = REST_TIME,
    part: str | None = None,
    timestep: float | None = None,
) -> dict:
    """Push a peg down its hole and let it come to rest on the floor (`part`: an assembly's
    moving part, in its step; `timestep`: a finer physics step than the file's; see
    `_load`).

    The peg starts aligned with the hole axis, its bottom face `start_height` m above the
    entrance (along the axis), at rest, and is pushed down the axis (the bottom frame's -z,
    so a tilted hole is tested along its own axis) by its weight under `gravity` m/s^2 plus
    `push` N, both at the COM; while it touches nothing it moves at `speed` m/s at most
    (module docstring; None: free fall). It runs until it has rested under the full force
    for `rest_time` s, `duration` s at most (None: the descent at `speed` plus 1 s). With
    `hold_orientation` the peg's rotational inertia is scaled by 1e6, as the task's
    controller holds the orientation: a free peg landing on one edge first pivots, and on
    a frictionless floor the lateral momentum of that pivot never dies away.

    Returns (lengths m, angles rad, times s):
      rest_distance      |peg frame origin - bottom frame origin| at the end
      axial_offset       that offset along the hole axis (negative: into the floor)
      lateral_offset     that offset across the axis
      tilt               angle between the peg's axis and the hole's axis at the end
      max_penetration    deepest contact overlap at the end (at rest if settled)
      max_penetration_transient  deepest contact overlap over the whole run
      reached_floor      settled with |axial_offset| < clearance / 2
      settled            it came to rest under the full force within `steps`
      steps              physics steps simulated
      seconds            wall time (load + simulation)
    """
    t0 = time.perf_counter()
    s = _load(xml_path, part, timestep)
    m, d = s.model, s.data
    axis = s.bottom_rot[:, 2]
    m.opt.gravity[:] = 0.0  # gravity is applied as the force m g at the COM: the same
    if hold_orientation:
        m.body_inertia[s.body] *= 1e6
    weight = float(m.body_subtreemass[s.body]) * gravity
    s.reset(s.depth + start_height)
    if duration is None:
        duration = 1.0 + (s.depth + start_height - s.clearance) / (speed or 0.25)
    _, pen, settled = _push(
        s, -(weight + push) * axis, speed=speed, max_steps=_steps(m, duration),
        rest_steps=_steps(m, rest_time), ramp=_steps(m, RAMP_TIME),
    )  # fmt: skip
    mujoco.mj_forward(m, d)  # contacts of the final state
    pen_end = s.penetration()
    offset = s.peg_pos() - s.bottom_pos
    axial = float(offset @ axis)
    peg_axis = d.xmat[s.body].reshape(3, 3)[:, 2]
    return {
        "rest_distance": float(np.linalg.norm(offset)),
        "axial_offset": axial,
        "lateral_offset": float(np.linalg.norm(offset - axial * axis)),
        "tilt": float(np.arccos(np.clip(peg_axis @ axis, -1.0, 1.0))),
        "max_penetration": pen_end,
        "max_penetration_transient": float(max(pen.max(), pen_end)),
        "reached_floor": bool(settled and abs(axial) < s.clearance / 2),
        "settled": bool(settled),
        "steps": len(pen),
        "seconds": time.perf_counter() - t0,
    }


def side_push_test(
    xml_path: Path,
    *,
    force: float = 5.0,
    directions: int | Sequence[float] = 8,
    duration: float = 2.0,
    insertion: float = 1.0,
    axial_force: float = 0.0,
    gravity: float = 0.0,
    speed: float | None = 0.01,
    hold_orientation: bool = True,
    rest_time: float = REST_TIME,
    part: str | None = None,
    timestep: float | None = None,
) -> dict:
    """Push the inserted peg sideways against the walls, in several directions (`part`: an
    assembly's moving part, in its step; `timestep`: a finer physics step than the file's;
    see `_load`).

    For each of `directions` directions evenly spread across the hole axis (the bottom
    frame's x-y plane, starting at its x), or each of the angles `directions` (rad from the
    bottom frame's x, e.g. `side_face_angles`, `corner_angles`), the peg starts aligned with
    the hole at rest, `insertion` of the way from the entrance to its design pose (1: the
    design pose, clearance on every face; 0.5: mid-depth), and a constant `force` N pushes it
    that way, plus `axial_force` N and the peg's weight under `gravity` m/s^2 down the axis
    (both 0: the task's weightless peg floating in the hole), all at the COM; while it
    touches nothing it moves at `speed` m/s at most (module docstring; None: a free impact).
    Each push runs until the peg has rested under the full force for `rest_time` s,
    `duration` s at most. MuJoCo's own gravity is off (the weight is part of the push).

    With `hold_orientation` (default) the peg's rotational inertia is scaled by 1e6, so it
    translates only, as the task's controller holds the orientation: a free weightless peg
    whose COM is above a wall's top edge (tilted holes, tall pegs) would otherwise tip over
    that edge and the test would measure its tumbling. A translating peg can only go where
    the walls let it: from its start, along the direction of its final displacement, MuJoCo's
    own distance query gives the free travel, and `overshoot` is how far beyond it the peg
    ended. Against a face that is the penetration (micrometres); wedged into a corner of
    half-angle b it is the penetration / sin(b) (a 22 deg corner of a squashed triangle: 30 um
    into each wall, 0.13 mm overshoot). A push that is not along a face normal slides along
    the wall it meets towards a corner, and a tapered peg may rise along its sloped walls
    (with low friction and no `axial_force` it can climb out): both are allowed motions.

    Returns (lengths m, times s):
      max_lateral          largest displacement of the peg frame's origin across the axis,
                           from its start, over every step and direction
      max_lateral_at_rest  the same at the end of each push (at rest if settled)
      max_overshoot        largest `overshoot` (see above), over the directions
      max_penetration      deepest contact overlap over every step and direction
      max_penetration_at_rest  the same at the end of each push
      passed_through       max_overshoot or max_penetration (transients included) larger
                           than the clearance: a wall did not stop the peg
      settled              every push came to rest within `steps`
      lateral              per direction, the largest displacement across the axis
      lateral_at_rest      per direction, the final displacement across the axis
      axial_at_rest        per direction, the final displacement along the axis (+: out)
      overshoot            per direction, as above
      free_travel          per direction, the free travel along the push direction (the
                           clearance towards a face, more towards a corner)
      angles               per direction, its angle (rad) from the bottom frame's x
      along                per direction, the largest displacement along the push
      along_at_rest        per direction, the final displacement along the push
      jitter               per direction, the size (m) of the box the peg frame's origin
                           moved in over the last `rest_time` s (contact chatter
                           where a push does not settle; ~0 at rest)
      seated_free_travel   per direction, the free travel along the push from the seated
                           pose (frame on the bottom frame, 1 um above the floor): where a
                           peg held down on the floor can go (towards a face: at most the
                           clearance, less for a tapered peg whose walls close in below)
      clearance            the module's clearance
      steps                physics steps simulated, all directions
      seconds              wall time (load + all the pushes)
    """
    if not 0.0 <= insertion <= 1.0:
        raise ValueError(f"insertion = {insertion!r}; expected a fraction in [0, 1]")
    t0 = time.perf_counter()
    s = _load(xml_path, part, timestep)
    m = s.model
    s.model.opt.gravity[:] = 0.0
    if hold_orientation:
        s.model.body_inertia[s.body] *= 1e6
    x, y, axis = s.bottom_rot.T
    down = axial_force + float(s.model.body_subtreemass[s.body]) * gravity
    start_axial = s.clearance + (1.0 - insertion) * (s.depth - s.clearance)
    names = ("lateral", "lateral_at_rest", "axial_at_rest", "overshoot", "free_travel")
    names += ("along", "along_at_rest", "seated_free_travel", "jitter")
    out: dict[str, list] = {k: [] for k in names}
    if isinstance(directions, int):
        angles = [2.0 * np.pi * k / directions for k in range(directions)]
    else:
        angles = [float(a) for a in directions]
    rest_pen, all_pen = [], []
    settled, total = True, 0
    rest_steps = _steps(m, rest_time)
    for angle in angles:
        u = np.cos(angle) * x + np.sin(angle) * y
        # 1 um above the floor: a pose touching the floor has no free travel at all
        s.reset(SEATED_LIFT)
        out["seated_free_travel"].append(_free_travel(s, u, limit=s.clearance + 0.01))
        s.reset(start_axial)
        start = s.peg_pos()
        out["free_travel"].append(_free_travel(s, u, limit=s.clearance + 0.01))
        pos, pen, ok = _push(
            s,
            force * u - down * axis,
            speed=speed,
            max_steps=_steps(m, duration),
            rest_steps=rest_steps,
            ramp=_steps(m, RAMP_TIME),
        )
        mujoco.mj_forward(s.model, s.data)
        rest_pen.append(s.penetration())
        all_pen.append(max(float(pen.max()), rest_pen[-1]))
        delta = pos - start
        lat = np.linalg.norm(delta - np.outer(delta @ axis, axis), axis=1)
        out["lateral"].append(float(lat.max()))
        out["lateral_at_rest"].append(float(lat[-1]))
        out["axial_at_rest"].append(float(delta[-1] @ axis))
        out["along"].append(float((delta @ u).max()))
        out["along_at_rest"].append(float(delta[-1] @ u))
        last = pos[-rest_steps:]
        out["jitter"].append(float(np.linalg.norm(last.max(axis=0) - last.min(axis=0))))
        end_move = delta[-1]
        moved = float(np.linalg.norm(end_move))
        if moved > 1e-9:
            end = s.peg_pos()
            s.reset(start_axial)  # back to the start pose for the distance query
            free = _free_travel(s, end_move / moved, limit=moved + 0.01)
            s.data.qpos[s.qpos : s.qpos + 3] = end
            out["overshoot"].append(moved - free)
        else:
            out["overshoot"].append(0.0)
        settled = settled and ok
        total += len(pen)
    overshoot = max(out["overshoot"])
    return {
        "max_lateral": max(out["lateral"]),
        "max_lateral_at_rest": max(out["lateral_at_rest"]),
        "max_overshoot": overshoot,
        "max_penetration": max(all_pen),
        "max_penetration_at_rest": max(rest_pen),
        "passed_through": bool(max(overshoot, max(all_pen)) > s.clearance),
        "settled": settled,
        **out,
        "angles": angles,
        "clearance": s.clearance,
        "steps": total,
        "seconds": time.perf_counter() - t0,
    }


def side_face_angles(xml_path: Path, *, tol: float = 1e-3) -> list[float]:
    """Angles (rad from the bottom frame's x, in its x-y plane, sorted in [-pi, pi)) of the
    in-plane directions of the peg's side face normals, one per face, read from the peg mesh
    in the MJCF with the peg seated. The hole's side faces are those faces moved out by the
    clearance, so these are the directions that push the peg squarely against a hole wall.

    Faces whose normal is within ~25 deg of the axis (the bottom and the top) are left out;
    side faces of a tapered peg lean by at most ~17 deg (Table I: 25 % taper). Triangles of
    one face agree within `tol` rad.
    """
    s = _load(xml_path)
    m, d = s.model, s.data
    s.reset(0.0)
    mesh = int(m.geom_dataid[s.geom])
    v0, nv = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
    f0, nf = int(m.mesh_faceadr[mesh]), int(m.mesh_facenum[mesh])
    vert = m.mesh_vert[v0 : v0 + nv].astype(float)
    tri = vert[m.mesh_face[f0 : f0 + nf]]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    # mesh frame -> world -> bottom frame (MuJoCo recentres and realigns a mesh on its COM)
    local = normals @ d.geom_xmat[s.geom].reshape(3, 3).T @ s.bottom_rot
    side = local[np.abs(local[:, 2]) < 0.9]
    angles = np.sort(np.arctan2(side[:, 1], side[:, 0]))
    keep: list[float] = []
    for a in angles:
        if not keep or a - keep[-1] > tol:
            keep.append(float(a))
    if len(keep) > 1 and keep[0] + 2.0 * np.pi - keep[-1] <= tol:
        keep.pop()  # one face split across the -pi / pi seam
    return keep


def corner_angles(face_angles: Sequence[float]) -> list[float]:
    """Angles midway between consecutive face directions (sorted, as `side_face_angles`):
    towards the hole's corners. With the same clearance on both faces, the corner of the
    peg's free space between two faces lies on the bisector of their normals, c / cos(half
    the angle between the normals) from the design pose."""
    a = np.asarray(face_angles, float)
    nxt = np.roll(a, -1)
    nxt[-1] += 2.0 * np.pi
    mid = 0.5 * (a + nxt)
    return [float(np.arctan2(np.sin(t), np.cos(t))) for t in mid]
