"""The per-step arithmetic of the env and of BatchSim, compiled (numba): one loop over the
envs per stage instead of about a hundred numpy calls on (num_envs, ...) arrays.

The env's own work runs on one thread between the rollout calls, so every microsecond of it
counts against the physics. The noise draws stay on numpy's Generator, so that seeded
streams and exact resume do not depend on the compiled code. Splitting the batch to score
one part while the next steps (the rollout releases the GIL) gained nothing measurable on 2
cores, so the step stays serial. Written by hand because no library fuses it: MuJoCo's
sensors could give the clean observation, but not the estimation noise, the quaternion form
of the seat distance or the failure test.

This is the only implementation: the task functions of sim/task/rules.py define the same
quantities on numpy arrays, and tests/test_sim_kernel.py holds the kernels to them on random
batches that reach every branch. Inputs travel in named tuples (numba reads their fields by
name), built by name from the configs, so no call depends on an order of arguments.

    command  actions -> commanded velocities (clip, scale, command noise)
    scatter  env states and velocities -> shard states and controls (BatchSim's layout)
    gather   shard states -> env states, and the unstable flags
    score    env states -> observation, reward, success, failure (PegInHoleVecEnv.step)
    observe  the observation of chosen envs (resets)

Layouts (n envs): state (n, 14) = [time, pos (3), quat w x y z (4), qvel (6)] as in
`BatchSim.state`; frame rows (n, 6, 3) and origins (n, 6) as in `task.ObsFrames`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from sim.task.config import PhysicsConfig, TaskConfig


class StepParams(NamedTuple):
    """The task's constants that score and observe read, taken by name from a TaskConfig
    (see its fields)."""

    dist_pos_weight: float
    dist_rot_weight: float
    dist_axis_weight: float
    success_radius: float
    failure_depth: float
    failure_reward: float
    obs_pos_noise: float
    obs_rot_noise: float
    noise: bool

    @classmethod
    def of(cls, cfg: TaskConfig) -> StepParams:
        # Python floats, whatever the config holds, so one compiled signature serves all
        values = {f: float(getattr(cfg, f)) for f in cls._fields if f != "noise"}
        return cls(noise=bool(cfg.noise), **values)


class Frames(NamedTuple):
    """Per-env constants of the module each env holds (n envs)."""

    rows: np.ndarray
    """(n, 6, 3) the observation frames' rows (task.ObsFrames.rows)."""
    origin: np.ndarray
    """(n, 6) the frames' origins in them (task.ObsFrames.origin_in)."""
    bottom_pos: np.ndarray
    """(n, 3) the seat's position (task.ObsFrames.bottom_pos)."""
    bottom_quat_conj: np.ndarray
    """(n, 4) the conjugate of the seat's orientation."""
    bottom: np.ndarray
    """(n, 4, 4) the hole's bottom frame (failure test)."""
    vertices: np.ndarray
    """(n, V, 3) the peg's vertices in the peg frame."""
    hole_radius: np.ndarray
    """(n,) below the surface, a vertex farther than this from the hole's axis fails."""
    reach: np.ndarray
    """(n,) the farthest peg vertex from the peg frame's origin."""


class Episode(NamedTuple):
    """Per-env episode state that score reads and updates in place."""

    d0: np.ndarray
    """(n,) the seat distance at the episode's start."""
    c_prev: np.ndarray
    """(n,) the last step's progress (updated)."""
    returns: np.ndarray
    """(n,) the return so far (updated)."""
    last_obs: np.ndarray
    """(n, 18) float32 the last observation (kept by unstable envs)."""


class Outcome(NamedTuple):
    """What score writes: one control step's result per env."""

    obs: np.ndarray
    """(n, 18) float32."""
    reward: np.ndarray
    """(n,) float64."""
    success: np.ndarray
    """(n,) bool."""
    failure: np.ndarray
    """(n,) bool."""


class Layout(NamedTuple):
    """Where each env's state lives in BatchSim's shard states."""

    flat: np.ndarray
    """(n, 14) int: index of each state entry in the flattened shard states."""
    offset: np.ndarray
    """(n, 14): env state = shard state - offset (the env's place in its shard)."""
    shard_of: np.ndarray
    """(n,) int: each env's shard."""


class Checks(NamedTuple):
    """The constants of the unstable test, taken from a PhysicsConfig."""

    control_step: float
    """s, the time one control step must advance a shard."""
    timestep: float
    """s, the physics step (the tolerance is half of it)."""
    runaway_speed: float
    """m/s, a peg faster than this is unstable (angular: 10x in rad/s)."""

    @classmethod
    def of(cls, p: PhysicsConfig) -> Checks:
        return cls(
            control_step=float(p.substeps * p.timestep),
            timestep=float(p.timestep),
            runaway_speed=float(p.runaway_speed),
        )


@njit(cache=True, nogil=True, inline="always")
def _observe_one(
    px: float,
    py: float,
    pz: float,
    w: float,
    x: float,
    y: float,
    z: float,
    i: int,
    rows: np.ndarray,
    origin: np.ndarray,
    e: np.ndarray,
    j: int,
    noisy: bool,
    pos_std: np.float32,
    rot_std: float,
    out: np.ndarray,
) -> None:
    """The 18 observation entries (`task.observe` of `task.perturb`) of env i (frames
    rows[i], origin[i]) at pose p, q into out[j], with estimation draws e[j]."""
    if noisy:
        # as task.perturb: the position error is float32 (pos_std * e), then promoted
        px += pos_std * e[j, 0]
        py += pos_std * e[j, 1]
        pz += pos_std * e[j, 2]
        vx = rot_std * np.float64(e[j, 3])
        vy = rot_std * np.float64(e[j, 4])
        vz = rot_std * np.float64(e[j, 5])
        angle = math.sqrt(vx * vx + vy * vy + vz * vz)
        s = math.sin(0.5 * angle) / angle if angle > 1e-12 else 0.5
        aw, ax, ay, az = math.cos(0.5 * angle), vx * s, vy * s, vz * s
        # the error turn first (module frame): a q
        w, x, y, z = (
            aw * w - ax * x - ay * y - az * z,
            aw * x + ax * w + ay * z - az * y,
            aw * y - ax * z + ay * w + az * x,
            aw * z + ax * y - ay * x + az * w,
        )
    # the position and rotation columns 1 and 2: three module-frame vectors, each into
    # both frames (row r = frame * 3 + component of rows); out is (frame, vector, component)
    c1x, c1y, c1z = 1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)
    c2x, c2y, c2z = 2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)
    for r in range(6):
        a, b, c = rows[i, r, 0], rows[i, r, 1], rows[i, r, 2]
        k = (r // 3) * 9 + r % 3
        out[j, k] = a * px + b * py + c * pz - origin[i, r]
        out[j, k + 3] = a * c1x + b * c1y + c * c1z
        out[j, k + 6] = a * c2x + b * c2y + c * c2z


@njit(cache=True, nogil=True)
def observe(
    state: np.ndarray,
    idx: np.ndarray,
    frames: Frames,
    e: np.ndarray,
    params: StepParams,
    out: np.ndarray,
) -> None:
    """Observations of envs idx (k,) into out (k, 18) float32; e (k, 6) float32 their
    estimation draws (ignored unless params.noise). frames: per env (n, ...)."""
    ps = np.float32(params.obs_pos_noise)
    for j in range(len(idx)):
        i = idx[j]
        s = state[i]
        _observe_one(
            s[1], s[2], s[3], s[4], s[5], s[6], s[7], i, frames.rows, frames.origin, e, j,
            params.noise, ps, params.obs_rot_noise, out,
        )  # fmt: skip


@njit(cache=True, nogil=True)
def _failed_one(
    px: float,
    py: float,
    pz: float,
    w: float,
    x: float,
    y: float,
    z: float,
    vertices: np.ndarray,
    bottom: np.ndarray,
    hole_radius: float,
    depth: float,
) -> bool:
    """`task.failed` for one peg at pose p, q (after its cheap height test): vertices
    (V, 3) in the peg frame, bottom (4, 4)."""
    r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    low = np.inf
    for k in range(len(vertices)):
        h = vertices[k, 0] * r20 + vertices[k, 1] * r21 + vertices[k, 2] * r22 + pz
        low = min(low, h)
    if not low < -depth:
        return False
    # the full rotation of the normalised quaternion, as task.pose
    nq = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / nq, x / nq, y / nq, z / nq
    m = np.empty((3, 3))
    m[0, 0], m[0, 1], m[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    m[1, 0], m[1, 1], m[1, 2] = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    m[2, 0], m[2, 1], m[2, 2] = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    p = np.empty(3)
    pos = (px, py, pz)
    for k in range(len(vertices)):
        for a in range(3):
            p[a] = (
                vertices[k, 0] * m[a, 0] + vertices[k, 1] * m[a, 1] + vertices[k, 2] * m[a, 2]
            ) + pos[a]
        if not p[2] < -depth:
            continue
        rel = p - bottom[:3, 3]
        along = rel[0] * bottom[0, 2] + rel[1] * bottom[1, 2] + rel[2] * bottom[2, 2]
        rad = 0.0
        for a in range(3):
            c = rel[a] - along * bottom[a, 2]
            rad += c * c
        if rad > hole_radius * hole_radius:
            return True
    return False


@njit(cache=True, nogil=True)
def score(
    state: np.ndarray,
    unstable: np.ndarray,
    e: np.ndarray,
    frames: Frames,
    episode: Episode,
    params: StepParams,
    out: Outcome,
) -> None:
    """One control step's outcome for every env, after its physics: observation, reward,
    success and failure into out; episode.returns and episode.c_prev updated in place.
    e (n, 6) float32: this step's estimation draws (ignored unless params.noise).

    An unstable env scores as a peg at the origin with the identity orientation (reward 0,
    neither success nor failure) and keeps its last observation, as PegInHoleVecEnv.step.
    """
    w_t, w_r, radius = params.dist_pos_weight, params.dist_rot_weight, params.success_radius
    w_a = params.dist_axis_weight
    depth, fail_r, noisy = params.failure_depth, params.failure_reward, params.noise
    ps, rot_std = np.float32(params.obs_pos_noise), params.obs_rot_noise
    rows, origin, bottom_pos, bottom_quat_conj = (
        frames.rows, frames.origin, frames.bottom_pos, frames.bottom_quat_conj,
    )  # fmt: skip
    bottom, vertices, hole_radius, reach = (
        frames.bottom, frames.vertices, frames.hole_radius, frames.reach,
    )  # fmt: skip
    d0, c_prev, returns, last_obs = episode.d0, episode.c_prev, episode.returns, episode.last_obs
    obs, reward, success, failure = out.obs, out.reward, out.success, out.failure
    for i in range(state.shape[0]):
        bad_physics = unstable[i]
        if bad_physics:
            px, py, pz, w, x, y, z = 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0
        else:
            s = state[i]
            px, py, pz, w, x, y, z = s[1], s[2], s[3], s[4], s[5], s[6], s[7]
        # seat distance (task.seat_distance) and progress
        dx, dy, dz = px - bottom_pos[i, 0], py - bottom_pos[i, 1], pz - bottom_pos[i, 2]
        d2 = dx * dx + dy * dy + dz * dz
        aw, ax, ay, az = (
            bottom_quat_conj[i, 0], bottom_quat_conj[i, 1], bottom_quat_conj[i, 2],
            bottom_quat_conj[i, 3],
        )  # fmt: skip
        vx = aw * x + w * ax + (ay * z - az * y)
        vy = aw * y + w * ay + (az * x - ax * z)
        vz = aw * z + w * az + (ax * y - ay * x)
        dist = w_t * math.sqrt(d2) + w_r * math.sqrt(8.0 * (vx * vx + vy * vy + vz * vz))
        if w_a > 0.0:  # off the hole's axis (the bottom frame's z: R_b^T's last row)
            along = dx * rows[i, 5, 0] + dy * rows[i, 5, 1] + dz * rows[i, 5, 2]
            dist += w_a * math.sqrt(max(d2 - along * along, 0.0))
        c = 1.0 - math.sqrt(dist / d0[i])
        r = c - c_prev[i]
        ok = d2 < radius * radius and not bad_physics
        # failure only for a peg low enough that a vertex may be below -depth
        bad = (
            not ok
            and not bad_physics
            and pz - reach[i] < -depth
            and _failed_one(px, py, pz, w, x, y, z, vertices[i], bottom[i], hole_radius[i], depth)
        )
        # c_T - c_{T-1} + (1 - c_T) = 1 - (return so far): a success's rewards sum to 1.0
        if ok:
            r = 1.0 - returns[i]
        elif bad:
            r = fail_r
        elif bad_physics:
            r = 0.0
        returns[i] += r
        c_prev[i] = c
        reward[i] = r
        success[i] = ok
        failure[i] = bad
        if bad_physics:
            obs[i] = last_obs[i]
        else:
            _observe_one(px, py, pz, w, x, y, z, i, rows, origin, e, i, noisy, ps, rot_std, obs)


@njit(cache=True, nogil=True, inline="always")
def _runaway(state: np.ndarray, e: int, lim: float, ang_lim: float) -> bool:
    """Env e's peg faster than the runaway speed (squared limits; angular: 10x in rad/s)."""
    lin = state[e, 8] ** 2 + state[e, 9] ** 2 + state[e, 10] ** 2
    ang = state[e, 11] ** 2 + state[e, 12] ** 2 + state[e, 13] ** 2
    return lin > lim or ang > ang_lim


@njit(cache=True, nogil=True)
def check_unstable(state: np.ndarray, checks: Checks, unstable: np.ndarray) -> None:
    """gather's unstable test for an engine that has no shards: a state that is not finite
    or a runaway peg."""
    speed = checks.runaway_speed
    lim, ang_lim = speed * speed, 100.0 * speed * speed
    for e in range(state.shape[0]):
        finite = True
        for c in range(state.shape[1]):
            finite = finite and math.isfinite(state[e, c])
        unstable[e] = not finite or _runaway(state, e, lim, ang_lim)


@njit(cache=True, nogil=True)
def gather(
    shard_flat: np.ndarray,
    layout: Layout,
    t0: np.ndarray,
    checks: Checks,
    state: np.ndarray,
    unstable: np.ndarray,
) -> None:
    """BatchSim's per-env states from its shard states, and their unstable flags.

    state[e, c] = shard_flat[flat[e, c]] - offset[e, c]. An env is unstable when its state
    is not finite, its shard's time did not advance by the control step (MuJoCo stopped
    stepping it after a warning), or its peg is faster than the runaway speed. t0: the
    shards' times before the step.
    """
    flat, offset, shard_of = layout.flat, layout.offset, layout.shard_of
    step, dt, speed = checks.control_step, checks.timestep, checks.runaway_speed
    lim, ang_lim = speed * speed, 100.0 * speed * speed
    for e in range(state.shape[0]):
        finite = True
        for c in range(state.shape[1]):
            x = shard_flat[flat[e, c]] - offset[e, c]
            state[e, c] = x
            finite = finite and math.isfinite(x)
        s = shard_of[e]
        stalled = abs(shard_flat[flat[e, 0]] - t0[s] - step) > 0.5 * dt
        unstable[e] = not finite or stalled or _runaway(state, e, lim, ang_lim)


@njit(cache=True, nogil=True)
def command(
    actions: np.ndarray,
    e: np.ndarray,
    noisy: bool,
    scale: np.ndarray,
    noise_std: np.ndarray,
    velocity: np.ndarray,
) -> None:
    """velocity = clip(actions, -1, 1) * scale (+ e * noise_std, with e float32 standard
    normal draws, when noisy): the commanded velocities, as PegInHoleVecEnv.step."""
    for i in range(actions.shape[0]):
        for k in range(6):
            v = min(max(actions[i, k], -1.0), 1.0) * scale[k]
            if noisy:
                # as numpy: the float32 draw times the float64 std, then added
                v += np.float64(e[i, k]) * noise_std[k]
            velocity[i, k] = v


@njit(cache=True, nogil=True)
def scatter(
    state: np.ndarray,
    layout: Layout,
    velocity: np.ndarray,
    shard_flat: np.ndarray,
    ctrl: np.ndarray,
) -> None:
    """BatchSim's env states into its shard states (shard_flat[flat[e, c]] = state[e, c] +
    offset[e, c]) and the envs' velocities into the shards' controls ctrl (shards, substeps,
    6 x slots), held over the substeps (env e = shard * slots + slot)."""
    flat, offset = layout.flat, layout.offset
    slots = ctrl.shape[2] // 6
    for e in range(state.shape[0]):
        for c in range(state.shape[1]):
            shard_flat[flat[e, c]] = state[e, c] + offset[e, c]
        s, j = e // slots, 6 * (e % slots)
        for t in range(ctrl.shape[1]):
            for k in range(6):
                ctrl[s, t, j + k] = velocity[e, k]
