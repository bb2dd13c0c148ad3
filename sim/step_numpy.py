"""The per-step arithmetic of sim/step_kernel.py on numpy arrays: same functions, same
signatures, same results (tests/test_sim_kernel.py holds the two together).

The env runs these where numba is not installed (a machine whose Python numba does not
support yet, or a GPU box the wheels are not carried to) and when asked
(`PegInHoleVecEnv(kernels="numpy")`, `assetgen bench sim --kernels numpy`). They are the
step in plain numpy: about a hundred array calls, built from the task functions of
sim/task.py.
"""

from __future__ import annotations

import numpy as np

from sim import task as T

NAME = "numpy"
"""How sim.step_impl names this implementation."""


def command(
    actions: np.ndarray,
    e: np.ndarray,
    noisy: bool,
    scale: np.ndarray,
    noise_std: np.ndarray,
    velocity: np.ndarray,
) -> None:
    """velocity = clip(actions, -1, 1) * scale (+ e * noise_std when noisy)."""
    np.multiply(np.clip(actions, -1.0, 1.0), scale, out=velocity)
    if noisy:
        velocity += e * noise_std


def scatter(
    state: np.ndarray,
    offset: np.ndarray,
    flat: np.ndarray,
    velocity: np.ndarray,
    shard_flat: np.ndarray,
    ctrl: np.ndarray,
) -> None:
    """Env states into the shard states and velocities into the shards' controls (shards,
    substeps, 6 x slots), held over the substeps; phantom slots keep zero."""
    shard_flat[flat] = state + offset
    first = np.zeros((ctrl.shape[0], ctrl.shape[2]))
    first.reshape(-1)[: velocity.size] = velocity.reshape(-1)
    ctrl[:] = first[:, None, :]


def gather(
    shard_flat: np.ndarray,
    flat: np.ndarray,
    offset: np.ndarray,
    t0: np.ndarray,
    shard_of: np.ndarray,
    params: np.ndarray,
    state: np.ndarray,
    unstable: np.ndarray,
) -> None:
    """Env states from the shard states, and the unstable flags (see step_kernel.gather)."""
    step, dt, speed = params.tolist()
    np.subtract(shard_flat.take(flat), offset, out=state)
    stalled = np.abs(shard_flat[flat[:, 0]] - t0[shard_of] - step) > 0.5 * dt
    v = state[:, 8:14]
    limit = speed * speed
    runaway = (np.einsum("ni,ni->n", v[:, :3], v[:, :3]) > limit) | (
        np.einsum("ni,ni->n", v[:, 3:], v[:, 3:]) > 100.0 * limit
    )
    # NaN compares False: the finiteness test catches those
    unstable[:] = ~np.isfinite(state).all(axis=1) | stalled | runaway


def _observe(
    pos: np.ndarray,
    quat: np.ndarray,
    rows: np.ndarray,
    origin: np.ndarray,
    e: np.ndarray,
    noisy: bool,
    pos_std: float,
    rot_std: float,
) -> np.ndarray:
    if noisy:
        pos, quat = T.perturb(pos, quat, e, pos_std, rot_std)
    return T.observe_rows(pos, quat, rows, origin)


def observe(
    state: np.ndarray,
    idx: np.ndarray,
    rows: np.ndarray,
    origin: np.ndarray,
    e: np.ndarray,
    noisy: bool,
    pos_std: float,
    rot_std: float,
    out: np.ndarray,
) -> None:
    """Observations of envs idx into out (k, 18) float32 (see step_kernel.observe)."""
    s = state[idx]
    out[:] = _observe(s[:, 1:4], s[:, 4:8], rows[idx], origin[idx], e, noisy, pos_std, rot_std)


def score(
    state: np.ndarray,
    unstable: np.ndarray,
    e: np.ndarray,
    noisy: bool,
    rows: np.ndarray,
    origin: np.ndarray,
    bottom_pos: np.ndarray,
    bottom_quat_conj: np.ndarray,
    bottom: np.ndarray,
    vertices: np.ndarray,
    hole_radius: np.ndarray,
    reach: np.ndarray,
    d0: np.ndarray,
    c_prev: np.ndarray,
    returns: np.ndarray,
    last_obs: np.ndarray,
    params: np.ndarray,
    obs: np.ndarray,
    reward: np.ndarray,
    success: np.ndarray,
    failure: np.ndarray,
) -> None:
    """Observation, reward, success and failure of every env after its physics step;
    returns and c_prev updated in place (see step_kernel.score, and params there)."""
    # Python floats, as TaskConfig holds them (a float64 scalar would make the float32
    # position noise float64 under numpy 2 promotion)
    w_t, w_r, radius, depth, fail_r, pos_std, rot_std = params.tolist()
    pos, quat = state[:, 1:4], state[:, 4:8]
    if unstable.any():
        # a placeholder pose for the arithmetic (reward 0, the last observation kept)
        pos, quat = pos.copy(), quat.copy()
        pos[unstable] = 0.0
        quat[unstable] = (1.0, 0.0, 0.0, 0.0)
    c = T.progress(T.seat_distance(pos, quat, bottom_pos, bottom_quat_conj, w_t, w_r), d0)
    r = c - c_prev
    ok = T.succeeded(pos, bottom_pos, radius) & ~unstable
    bad = T.failed(pos, quat, vertices, bottom, hole_radius, depth, reach) & ~ok & ~unstable
    # c_T - c_{T-1} + (1 - c_T) = 1 - (return so far): a success's rewards sum to 1.0
    r[ok] = 1.0 - returns[ok]
    r[bad] = fail_r
    r[unstable] = 0.0
    returns += r
    c_prev[:] = c
    reward[:] = r
    success[:] = ok
    failure[:] = bad
    obs[:] = _observe(pos, quat, rows, origin, e, noisy, pos_std, rot_std)
    obs[unstable] = last_obs[unstable]
