"""The arm's kinematics at the policy rate: the peg site's Jacobian, differential inverse
kinematics with a nullspace posture, and placing the peg at a pose.

Written here rather than taken from an IK library (mink, for one) because the controller
solves one small problem per env at every policy step, for a batch of envs at once: a
damped least-squares step is a batched 6 x 6 solve in numpy, where a QP solver per env
would cost more than the physics it steers.
"""

from __future__ import annotations

import mujoco
import numpy as np

from sim.engines.mujoco.scene import PEG_SITE
from sim.robots.panda.model import HOME, JOINTS, VELOCITY_LIMITS, ArmSettings

LIMIT_MARGIN = 0.2
"""A start pose is taken only with every joint this far from its limits, rad."""


def peg_jacobian(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
    """(6, 7) the peg site's Jacobian (linear over angular, module frame) at d's positions
    (kinematics must be current: mj_kinematics and mj_comPos)."""
    jac = np.zeros((6, m.nv))
    mujoco.mj_jacSite(m, d, jac[:3], jac[3:], m.site(PEG_SITE).id)
    return jac[:, :7]


def joint_velocity(
    jac: np.ndarray,
    twist: np.ndarray,
    q: np.ndarray,
    settings: ArmSettings,
    lo: np.ndarray,
    hi: np.ndarray,
    dt: float,
) -> np.ndarray:
    """(n, 7) joint velocities that move the peg site at `twist` (n, 6: linear m/s, angular
    rad/s, module frame) for Jacobians jac (n, 6, 7) at joints q (n, 7): damped least
    squares, plus a drift to HOME in the nullspace. A joint that would come within
    LIMIT_MARGIN / 2 of its limit (lo, hi: (7,)) within `dt` s is locked and the rest
    solve the task without it (twice at most); the result is scaled down as a whole where a
    joint would pass its velocity limit, so the direction of motion is kept."""
    n = len(q)
    free = np.ones((n, 7))
    band = 0.5 * LIMIT_MARGIN
    for _ in range(3):
        j = jac * free[:, None, :]
        jjt = j @ np.swapaxes(j, 1, 2) + settings.damping**2 * np.eye(6)
        pinv = np.swapaxes(j, 1, 2) @ np.linalg.inv(jjt)  # (n, 7, 6)
        qd = np.einsum("nij,nj->ni", pinv, twist)
        drift = settings.nullspace_gain * (HOME - q) * free
        qd += drift - np.einsum("nij,nj->ni", pinv @ j, drift)
        ahead = q + qd * dt
        hits = ((ahead < lo + band) & (qd < 0)) | ((ahead > hi - band) & (qd > 0))
        hits &= free > 0
        if not hits.any():
            break
        free[hits] = 0.0
    qd *= free
    over = np.max(np.abs(qd) / VELOCITY_LIMITS, axis=1)
    return qd / np.maximum(over, 1.0)[:, None]


def _quat_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """(3,) the rotation vector that turns `current` into `target` (module frame)."""
    err = np.zeros(3)
    conj = np.zeros(4)
    mujoco.mju_negQuat(conj, current)
    dq = np.zeros(4)
    mujoco.mju_mulQuat(dq, target, conj)
    mujoco.mju_quat2Vel(err, dq, 1.0)
    return err


def place_peg(
    m: mujoco.MjModel,
    d: mujoco.MjData,
    pos: np.ndarray,
    quat: np.ndarray,
    q0: np.ndarray | None = None,
    *,
    iterations: int = 200,
    tol: float = 1e-5,
) -> tuple[np.ndarray, float, list[str]]:
    """Joint positions (7,) that put the peg frame at pos (3,), quat (4,) in the module frame,
    by damped Gauss-Newton from q0 (default HOME) within the joint limits; d's qpos is left
    at them. Returns them, the remaining error (m + rad) and the joints that sit at a limit."""
    site = m.site(PEG_SITE).id
    lo, hi = m.jnt_range[:7, 0], m.jnt_range[:7, 1]
    q = np.array(HOME if q0 is None else q0, dtype=float)
    d.qpos[:7] = q
    err = np.inf
    jac = np.zeros((6, m.nv))
    for _ in range(iterations):
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        cur = np.zeros(4)
        mujoco.mju_mat2Quat(cur, d.site_xmat[site])
        e = np.concatenate([pos - d.site_xpos[site], _quat_error(quat, cur)])
        err = float(np.linalg.norm(e))
        if err < tol:
            break
        mujoco.mj_jacSite(m, d, jac[:3], jac[3:], site)
        j = jac[:, :7]
        step = j.T @ np.linalg.solve(j @ j.T + 1e-4 * np.eye(6), e)
        q = np.clip(q + step, lo, hi)
        d.qpos[:7] = q
    at_limit = [JOINTS[i] for i in np.flatnonzero((q <= lo + 1e-3) | (q >= hi - 1e-3))]
    return q, err, at_limit


def _peg_pose(m: mujoco.MjModel, d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
    """The peg frame's position (3,) and quaternion (4,) at d's joints (module frame)."""
    mujoco.mj_kinematics(m, d)
    site = m.site(PEG_SITE).id
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, d.site_xmat[site])
    return d.site_xpos[site].copy(), quat


def carry(
    m: mujoco.MjModel,
    d: mujoco.MjData,
    q: np.ndarray,
    pos: np.ndarray,
    quat: np.ndarray,
    *,
    step_lin: float = 0.01,
    step_rot: float = 0.05,
    tol: float = 1e-4,
    margin: float = LIMIT_MARGIN,
    collide: bool = True,
) -> tuple[np.ndarray | None, list[str]]:
    """Carry the peg from where joints q (7,) hold it to pos (3,), quat (4,), along the straight
    line and the shortest turn, in steps of at most `step_lin` m and `step_rot` rad, each a
    few damped Gauss-Newton iterations from the last joints: the joints move continuously, so
    the result is a posture the arm reaches from q along that path, not merely one that
    holds the pose. Returns the joints at the end (d's qpos is left at them), or None where
    the path ends off the pose (error over `tol`), or where a joint comes within margin / 2
    of its limit on the way or ends within `margin` of it, or (with `collide`) where the arm or
    the peg touches the module on the way; then also the joints (or the body) that did."""
    lo, hi = m.jnt_range[:7, 0], m.jnt_range[:7, 1]
    d.qpos[:7] = q
    p0, q0 = _peg_pose(m, d)
    turn = _quat_error(quat, q0)
    n = max(1, int(np.ceil(max(np.linalg.norm(pos - p0) / step_lin,
                               np.linalg.norm(turn) / step_rot))))  # fmt: skip
    q = np.array(q, dtype=float)
    near = np.zeros(7, dtype=bool)
    rot = np.zeros(4)
    for k in range(1, n + 1):
        f = k / n
        mujoco.mju_axisAngle2Quat(rot, turn / max(np.linalg.norm(turn), 1e-12),
                                  f * np.linalg.norm(turn))  # fmt: skip
        target_q = np.zeros(4)
        mujoco.mju_mulQuat(target_q, rot, q0)
        q, err, _ = place_peg(m, d, p0 + f * (pos - p0), target_q, q,
                              iterations=50 if k == n else 4, tol=tol)  # fmt: skip
        near |= (q - lo < 0.5 * margin) | (hi - q < 0.5 * margin)
        if collide and (k % 4 == 0 or k == n):
            touching = _touches(m, d)
            if touching:
                return None, [f"the {touching} touching the module"]
    near |= (q - lo < margin) | (hi - q < margin)
    if err < tol and not near.any():
        return q, []
    return None, [JOINTS[i] for i in np.flatnonzero(near)] or ["its reach"]


def _touches(m: mujoco.MjModel, d: mujoco.MjData) -> str | None:
    """The name of a body of the arm or the peg that touches the module at d's joints, or
    None (the module's pieces are the world body's)."""
    mujoco.mj_kinematics(m, d)
    mujoco.mj_collision(m, d)
    for c in d.contact[: d.ncon]:
        if c.dist < 0.0:
            body = max(m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2])
            return m.body(body).name
    return None


def reach(
    m: mujoco.MjModel,
    d: mujoco.MjData,
    pos: np.ndarray,
    quat: np.ndarray,
    rng: np.random.Generator,
    *,
    tries: int = 8,
    tol: float = 1e-4,
    margin: float = LIMIT_MARGIN,
) -> tuple[np.ndarray | None, list[str]]:
    """place_peg from HOME, then from `tries - 1` postures drawn around it; of the solutions
    that reach the pose within `tol` with every joint at least `margin` rad from its limits
    (an arm posed at a limit cannot follow every command from there), the one closest to
    HOME (elbow up over the module: far postures reach down past the plate). Returns its
    joints (None if none qualifies; d's qpos is then the closest attempt) and, for None,
    the joints at or near a limit (what stops the arm)."""
    lo, hi = m.jnt_range[:7, 0], m.jnt_range[:7, 1]
    best: tuple[float, np.ndarray] | None = None
    closest: tuple[float, float, np.ndarray] | None = None  # (error, -room, joints)
    for k in range(tries):
        q0 = HOME if k == 0 else np.clip(HOME + rng.normal(0.0, 0.3 * k**0.5, 7), lo, hi)
        q, err, _ = place_peg(m, d, pos, quat, q0)
        room = float(np.min(np.minimum(q - lo, hi - q)))
        if closest is None or (err, -room) < closest[:2]:
            closest = (err, -room, q)
        if err < tol and room >= margin:
            away = float(np.linalg.norm(q - HOME))
            if best is None or away < best[0]:
                best = (away, q)
            if away < 1.0:  # near home: no need to look further
                break
    if best is not None:
        d.qpos[:7] = best[1]
        return best[1], []
    assert closest is not None
    q = closest[2]
    d.qpos[:7] = q
    near = np.flatnonzero((q - lo < margin) | (hi - q < margin))
    return None, [JOINTS[i] for i in near]
