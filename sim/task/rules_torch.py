"""The per-step task arithmetic of sim/task/kernel.py on torch tensors, for an engine whose
states live on a GPU (MuJoCo Warp): command, observe, score and the unstable test run where
the states are, so a torch agent's actions and observations need no trip through the host.

The same quantities as the compiled kernels, batched instead of looped; tests/test_task_torch.py
holds each function to its kernel on the kernels' own random batches (every branch: success,
failure outside the hole, pegs inside it, unstable rows). The noise draws come in as
arguments, as for the kernels, so a caller picks the generator (torch's on the device).
Tensors are float64 unless stated: Warp's float32 states are promoted before scoring, so
the arithmetic itself adds no float32 error. torch is imported here only.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import torch

from sim.task import kernel as K
from sim.task.config import TaskConfig


@dataclass(frozen=True)
class TorchFrames:
    """K.Frames as tensors on one device (see its fields; n envs)."""

    rows: torch.Tensor
    """(n, 6, 3) the observation frames' rows."""
    origin: torch.Tensor
    """(n, 6) the frames' origins in them."""
    bottom_pos: torch.Tensor
    """(n, 3) the seat's position."""
    bottom_quat_conj: torch.Tensor
    """(n, 4) the conjugate of the seat's orientation."""
    bottom: torch.Tensor
    """(n, 4, 4) the hole's bottom frame."""
    vertices: torch.Tensor
    """(n, V, 3) the peg's vertices in the peg frame."""
    hole_radius: torch.Tensor
    """(n,) the hole's radius for the failure test."""
    reach: torch.Tensor
    """(n,) the farthest peg vertex from the peg frame's origin."""

    @classmethod
    def of(cls, frames: K.Frames, device: str | torch.device) -> TorchFrames:
        """The kernels' frames (numpy) on `device`, as float64."""
        return cls(
            **{
                f.name: torch.as_tensor(
                    np.asarray(getattr(frames, f.name), dtype=np.float64), device=device
                )
                for f in fields(cls)
            }
        )


def command(
    actions: torch.Tensor,
    e: torch.Tensor | None,
    scale: torch.Tensor,
    noise_std: torch.Tensor,
) -> torch.Tensor:
    """The commanded velocities (n, 6): clip(actions, -1, 1) * scale, plus e * noise_std
    when e (n, 6) float32 standard normal draws is given (K.command)."""
    v = actions.to(torch.float64).clamp(-1.0, 1.0) * scale
    return v if e is None else v + e.to(torch.float64) * noise_std


def _perturb(
    pos: torch.Tensor, quat: torch.Tensor, e: torch.Tensor, params: K.StepParams
) -> tuple[torch.Tensor, torch.Tensor]:
    """The estimated pose: the position error in float32 (pos_std * e) then promoted, and
    the rotation-vector error turned in first (module frame), as K._observe_one."""
    pos = pos + (e[:, :3] * np.float32(params.obs_pos_noise)).to(torch.float64)
    v = params.obs_rot_noise * e[:, 3:].to(torch.float64)
    angle = v.norm(dim=1)
    safe = torch.where(angle > 1e-12, angle, torch.ones_like(angle))
    s = torch.where(angle > 1e-12, torch.sin(0.5 * safe) / safe, torch.full_like(angle, 0.5))
    aw, ax, ay, az = torch.cos(0.5 * angle), v[:, 0] * s, v[:, 1] * s, v[:, 2] * s
    w, x, y, z = quat.unbind(1)
    quat = torch.stack(
        [
            aw * w - ax * x - ay * y - az * z,
            aw * x + ax * w + ay * z - az * y,
            aw * y - ax * z + ay * w + az * x,
            aw * z + ax * y - ay * x + az * w,
        ],
        dim=1,
    )
    return pos, quat


def _observe_clean(
    pos: torch.Tensor, quat: torch.Tensor, rows: torch.Tensor, origin: torch.Tensor
) -> torch.Tensor:
    """(n, 18) float32: the position and rotation columns 1, 2 in both frames."""
    w, x, y, z = quat.unbind(1)
    c1 = torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)], 1)
    c2 = torch.stack([2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)], 1)
    p = torch.einsum("nrc,nc->nr", rows, pos) - origin
    r1 = torch.einsum("nrc,nc->nr", rows, c1)
    r2 = torch.einsum("nrc,nc->nr", rows, c2)
    out = torch.cat([p[:, :3], r1[:, :3], r2[:, :3], p[:, 3:], r1[:, 3:], r2[:, 3:]], dim=1)
    return out.to(torch.float32)


def observe(
    pos: torch.Tensor,
    quat: torch.Tensor,
    rows: torch.Tensor,
    origin: torch.Tensor,
    e: torch.Tensor,
    params: K.StepParams,
) -> torch.Tensor:
    """(k, 18) float32 observations of k envs at poses pos (k, 3), quat (k, 4) w x y z,
    their frames' rows (k, 6, 3) and origins (k, 6), and estimation draws e (k, 6) float32
    (ignored unless params.noise): K.observe."""
    if params.noise:
        pos, quat = _perturb(pos, quat, e, params)
    return _observe_clean(pos, quat, rows, origin)


def _failed(
    pos: torch.Tensor, quat: torch.Tensor, frames: TorchFrames, depth: float
) -> torch.Tensor:
    """(n,) bool: a peg vertex deeper than `depth` below the surface and outside the hole's
    radius (K._failed_one: the height test with the quaternion as it is, the radial test
    with it normalised)."""
    w, x, y, z = quat.unbind(1)
    r2 = torch.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], 1)
    low = torch.einsum("nvc,nc->nv", frames.vertices, r2).amin(1) + pos[:, 2]
    q = quat / quat.norm(dim=1, keepdim=True)
    w, x, y, z = q.unbind(1)
    m = torch.stack(
        [
            torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], 1),
            torch.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], 1),
            torch.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], 1),
        ],
        dim=1,
    )
    p = torch.einsum("nac,nvc->nva", m, frames.vertices) + pos[:, None, :]
    rel = p - frames.bottom[:, None, :3, 3]
    axis = frames.bottom[:, None, :3, 2]
    along = (rel * axis).sum(-1, keepdim=True)
    radial2 = (rel - along * axis).pow(2).sum(-1)
    outside = (p[..., 2] < -depth) & (radial2 > frames.hole_radius[:, None] ** 2)
    return (low < -depth) & outside.any(1)


def seat_distance(
    pos: torch.Tensor,
    quat: torch.Tensor,
    bottom_pos: torch.Tensor,
    bottom_quat_conj: torch.Tensor,
    params: K.StepParams,
) -> torch.Tensor:
    """(n,) the weighted distance of poses pos (n, 3), quat (n, 4) to the seat
    (task.seat_distance)."""
    d = pos - bottom_pos
    aw, ax, ay, az = bottom_quat_conj.unbind(1)
    w, x, y, z = quat.unbind(1)
    vx = aw * x + w * ax + (ay * z - az * y)
    vy = aw * y + w * ay + (az * x - ax * z)
    vz = aw * z + w * az + (ax * y - ay * x)
    return params.dist_pos_weight * (d * d).sum(1).sqrt() + params.dist_rot_weight * torch.sqrt(
        8.0 * (vx * vx + vy * vy + vz * vz)
    )


def quat_mul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """(n, 4) Hamilton products a b of quaternions w x y z."""
    aw, ax, ay, az = a.unbind(-1)
    bw, bx, by, bz = b.unbind(-1)
    return torch.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        dim=-1,
    )


def sample_spawn(
    gen: torch.Generator,
    entrance_pos: torch.Tensor,
    entrance_quat: torch.Tensor,
    vertices: torch.Tensor,
    scale: float,
    cfg: TaskConfig,
    min_clearance: float = 0.001,
) -> tuple[torch.Tensor, torch.Tensor]:
    """task.sample_spawn on tensors, its draws from `gen`: spawn positions (n, 3) and unit
    quaternions (n, 4) about entrances entrance_pos (n, 3), entrance_quat (n, 4), raised
    where a peg vertex (n, V, 3) would lie less than `min_clearance` above the surface."""
    n, dev = len(entrance_pos), entrance_pos.device
    u = torch.rand((n, 4), generator=gen, device=dev, dtype=torch.float64)
    offset = torch.zeros((n, 4), device=dev, dtype=torch.float64)
    offset[:, 1:3] = (2.0 * u[:, :2] - 1.0) * cfg.spawn_xy * scale
    lo, hi = cfg.spawn_z
    offset[:, 3] = (lo + (hi - lo) * u[:, 2]) * scale
    angle = u[:, 3] * cfg.spawn_max_angle * scale
    axis = torch.randn((n, 3), generator=gen, device=dev, dtype=torch.float64)
    axis = axis / axis.norm(dim=1, keepdim=True)
    turn = torch.cat([torch.cos(0.5 * angle)[:, None], axis * torch.sin(0.5 * angle)[:, None]], 1)
    quat = quat_mul(entrance_quat, turn)
    conj = entrance_quat * torch.tensor([1.0, -1.0, -1.0, -1.0], dtype=torch.float64, device=dev)
    pos = entrance_pos + quat_mul(quat_mul(entrance_quat, offset), conj)[:, 1:]
    w, x, y, z = quat.unbind(1)
    row2 = torch.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], 1)
    low = torch.einsum("nvi,ni->nv", vertices, row2).amin(1) + pos[:, 2]
    pos = pos.clone()
    pos[:, 2] += (min_clearance - low).clamp(min=0.0)
    return pos, quat


@dataclass
class TorchEpisode:
    """K.Episode as tensors: what score reads and updates in place."""

    d0: torch.Tensor
    """(n,) the seat distance at the episode's start."""
    c_prev: torch.Tensor
    """(n,) the last step's progress (updated)."""
    returns: torch.Tensor
    """(n,) the return so far (updated)."""
    last_obs: torch.Tensor
    """(n, 18) float32 the last observation (kept by unstable envs)."""


def score(
    pos: torch.Tensor,
    quat: torch.Tensor,
    unstable: torch.Tensor,
    e: torch.Tensor,
    frames: TorchFrames,
    episode: TorchEpisode,
    params: K.StepParams,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """One control step's (obs (n, 18) float32, reward, success, failure) after its physics,
    with episode.returns and episode.c_prev updated in place (K.score). An unstable env
    scores as a peg at the origin with the identity orientation (reward 0, neither success
    nor failure) and keeps its last observation."""
    bad_physics = unstable[:, None]
    pos = torch.where(bad_physics, torch.zeros_like(pos), pos.to(torch.float64))
    ident = torch.tensor([1.0, 0.0, 0.0, 0.0], dtype=torch.float64, device=pos.device)
    quat = torch.where(bad_physics, ident, quat.to(torch.float64))
    d = pos - frames.bottom_pos
    d2 = (d * d).sum(1)
    dist = seat_distance(pos, quat, frames.bottom_pos, frames.bottom_quat_conj, params)
    c = 1.0 - torch.sqrt(dist / episode.d0)
    ok = (d2 < params.success_radius**2) & ~unstable
    low = pos[:, 2] - frames.reach < -params.failure_depth
    bad = ~ok & ~unstable & low & _failed(pos, quat, frames, params.failure_depth)
    # c_T - c_{T-1} + (1 - c_T) = 1 - (return so far): a success's rewards sum to 1.0
    r = c - episode.c_prev
    r = torch.where(ok, 1.0 - episode.returns, r)
    r = torch.where(bad, torch.full_like(r, params.failure_reward), r)
    r = torch.where(unstable, torch.zeros_like(r), r)
    episode.returns += r
    episode.c_prev.copy_(c)
    obs = observe(pos, quat, frames.rows, frames.origin, e, params)
    obs = torch.where(bad_physics, episode.last_obs, obs)
    return obs, r, ok, bad


def check_unstable(state: torch.Tensor, checks: K.Checks) -> torch.Tensor:
    """(n,) bool for states (n, 14): not finite, or a peg faster than the runaway speed
    (angular: 10x in rad/s), as K.check_unstable."""
    speed2 = checks.runaway_speed**2
    lin = state[:, 8:11].pow(2).sum(1)
    ang = state[:, 11:14].pow(2).sum(1)
    return ~torch.isfinite(state).all(1) | (lin > speed2) | (ang > 100.0 * speed2)
