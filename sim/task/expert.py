"""A scripted expert that uses only the 18-D observation: align with the hole axis above the
entrance, then insert along it.

What it reads from an observation (peg pose in the entrance frame E and the bottom frame B,
both from the same noisy estimate of the peg pose P):
    T_BE = T_BP T_EP^-1 = T_B^-1 T_E   exactly: the estimation error cancels, so the hole's
                                       geometry (axis direction, depth) is known exactly;
    T_BP  the noisy peg pose relative to the seat; T_EP's z: the noisy height above the
          mounting surface.
Actions are in the module frame; the entrance frame's orientation is the module frame's
(its z is the mounting surface's normal, which is the module's z: the generator writes the
identity quaternion for every entrance), so entrance-frame vectors are used as they are.

Phases, decided per step from the observation alone (no memory):
    1. misaligned orientation and low: rise (nothing of the module is above the mounting
       surface, so a peg whose every point is above it cannot collide; a peg is at most
       15 cm long, so turning about the bottom-face centre at 16 cm is safe; with
       `tilt_safe_height`, the height that the rest of the turn needs instead);
    2. turn to the hole's orientation while moving above the entrance on the hole axis;
    3. once the lateral error is under 1.5 mm and the tilt under 3 deg, descend along the
       axis at a speed that falls linearly to zero at those errors (half speed at least once
       inside the hole, whose walls guide the peg), to the seat; the default configuration
       touches down on the entrance softly (`touch_speed`).
The thresholds and gains above are the default configuration's; FAST and DIRECT change them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from assetgen.core.rotations import matrix_to_rotvec, rot6d_to_matrix


@dataclass(frozen=True)
class ExpertConfig:
    """Gains and thresholds of the scripted expert (SI units)."""

    safe_height: float = 0.16
    """Height of the bottom-face centre above the surface at which any turn is safe, m."""
    standoff: float = 0.01
    """Height above the entrance (along the hole axis) where the peg aligns, m."""
    pos_gain: float = 6.0
    """Linear velocity per metre of position error, 1/s."""
    rot_gain: float = 5.0
    """Angular velocity per radian of orientation error, 1/s."""
    turn_angle: float = np.radians(12.0)
    """Orientation error above which the peg keeps high (phase 1-2), rad."""
    insert_speed: float = 0.12
    """Descent speed along the hole axis once aligned, m/s."""
    lateral_tol: float = 0.0015
    """Lateral error at which the descent speed above the entrance falls to zero, m."""
    angle_tol: float = np.radians(3.0)
    """Orientation error at which the descent speed above the entrance falls to zero, rad."""
    max_lin_vel: float = 0.25
    """Velocity of action 1.0 (the task's scale), m/s."""
    max_ang_vel: float = np.radians(90.0)
    """Angular velocity of action 1.0, rad/s."""
    box_limits: bool = False
    """Limit each velocity component to the action scale (the action space is a box)
    instead of the vector's norm: diagonal moves and turns about tilted axes go faster."""
    descend_while_turning: bool = False
    """While turning (phase 2), descend towards the safe height instead of holding the
    height: every turn above it is still safe, and the descent overlaps the turn."""
    tilt_safe_height: bool = False
    """Replace the fixed `safe_height` by the height the peg needs for the rest of its turn:
    the lowest point of any peg of the sampler's ranges (`peg_radius`, `peg_length`) below
    the bottom-face centre, at the worst orientation of the remaining turn, plus
    `safe_margin`. A peg whose axis points up reaches at most `peg_radius` below that centre,
    so most turns can run 3-5 cm above the surface instead of 16 cm."""
    peg_radius: float = 0.03
    """Largest distance of a peg point from the peg's axis, m (Table I circumradius)."""
    peg_length: float = 0.15
    """Longest peg, m (Table I)."""
    depth_fraction_min: float = 0.4
    """Shallowest hole as a fraction of its peg's length (Table I): the observed hole depth
    bounds this module's peg length by depth / depth_fraction_min (0: use `peg_length`)."""
    inside_speed: float = 0.5
    """Fraction of `insert_speed` kept at least once the peg is inside the hole."""
    safe_margin: float = 0.015
    """Clearance kept under the peg's lowest point while turning, m."""
    seat_overshoot: float = 0.0
    """Depth below the seat at which the inserting peg's axial target lies, m: the descent
    does not slow to zero at the seat (the hole's floor stops the peg), so it reaches the
    success radius at speed."""
    touch_speed: float | None = 0.002
    """Soft touch-down (None: off): outside the hole the descent is capped at `pos_gain`
    times the height above the entrance plus this speed, and the peg counts as inside only
    once below the entrance plane. A velocity-servoed peg that meets the entrance's edge at speed
    presses on it, and friction then holds it a fraction of a millimetre off the axis, more
    than a 0.25 mm clearance allows; arriving at this speed, the lateral correction slides it
    over the edge instead, m/s."""


FAST = ExpertConfig(
    touch_speed=None,
    pos_gain=10.0,
    rot_gain=10.0,
    turn_angle=np.radians(20.0),
    insert_speed=0.25,
    lateral_tol=0.003,
    angle_tol=np.radians(5.7),
    descend_while_turning=True,
)
"""The fast expert (`--agent scripted-fast`, `--demos scripted-fast`): the same phases and
the same safe height, with stiffer gains, a descent that overlaps the turn, looser
alignment tolerances (the hole's walls guide the rest) and insertion at the full speed of
the action scale. Chosen on the train split only (one attempt per module): 100 % success,
median 2.30 s against the default's 3.48 s."""


DIRECT = replace(
    FAST,
    pos_gain=15.0,
    rot_gain=15.0,
    lateral_tol=0.005,
    angle_tol=np.radians(8.0),
    box_limits=True,
    tilt_safe_height=True,
    inside_speed=1.0,
    seat_overshoot=0.01,
)
"""The direct expert (`--agent scripted-direct`): FAST with the command scaled per component
(the action space is a box) and a turning height that follows the peg's tilt
(`tilt_safe_height`), so the descent runs while the peg turns; stiffer gains, looser
alignment tolerances (5 mm, 8 deg), full speed inside the hole and an axial target 1 cm below
the seat. Chosen on the train split only: 100 %, median 1.40 s."""


def fast_expert_action(obs: np.ndarray) -> np.ndarray:
    """expert_action with the FAST gains."""
    return expert_action(obs, FAST)


def direct_expert_action(obs: np.ndarray) -> np.ndarray:
    """expert_action with the DIRECT configuration."""
    return expert_action(obs, DIRECT)


def default_expert_action(obs: np.ndarray) -> np.ndarray:
    """expert_action with the default configuration."""
    return expert_action(obs)


EXPERTS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "scripted": default_expert_action,
    "scripted-fast": fast_expert_action,
    "scripted-direct": direct_expert_action,
}
"""The built-in experts by their command-line names (`--agent`, `--demos`): the command line
reads them here when it builds its parser, so this module imports numpy and
assetgen.core only (no engine, no compiled kernel)."""


def _split(obs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(n, 18) -> peg position/rotation in E and in B: (n, 3), (n, 3, 3), (n, 3), (n, 3, 3)."""
    return obs[:, :3], rot6d_to_matrix(obs[:, 3:9]), obs[:, 9:12], rot6d_to_matrix(obs[:, 12:18])


def _clip_norm(v: np.ndarray, limit: float) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v * np.minimum(1.0, limit / np.maximum(n, 1e-12))


def _limit(v: np.ndarray, limit: float, box: bool) -> np.ndarray:
    """v scaled so its norm (box: each component's size) is at most limit, direction kept."""
    if not box:
        return _clip_norm(v, limit)
    m = np.abs(v).max(axis=-1, keepdims=True)
    return v * np.minimum(1.0, limit / np.maximum(m, 1e-12))


def _turn_reach(
    r_ep: np.ndarray, rotvec: np.ndarray, depth: np.ndarray, cfg: ExpertConfig, samples: int = 9
) -> np.ndarray:
    """(n,) how far below the bottom-face centre any peg of the sampler's ranges can reach at
    the worst orientation of the remaining turn (the controller turns about the fixed axis of
    `rotvec`, in E, so the peg's axis sweeps a circular arc), m."""
    angle = np.linalg.norm(rotvec, axis=1, keepdims=True)
    k = rotvec / np.maximum(angle, 1e-12)  # (n, 3) turn axis in E
    a0 = r_ep[:, :, 2]  # peg axis in E
    kxa = np.cross(k, a0)
    ka = np.sum(k * a0, axis=1, keepdims=True)
    th = angle * np.linspace(0.0, 1.0, samples)[None, :]  # (n, s) angles along the turn
    # Rodrigues, z components only: the axis' height component at each angle
    cz = a0[:, 2:3] * np.cos(th) + kxa[:, 2:3] * np.sin(th) + ka * k[:, 2:3] * (1.0 - np.cos(th))
    cz = np.clip(cz, -1.0, 1.0)
    length = np.full(len(r_ep), cfg.peg_length)
    if cfg.depth_fraction_min > 0:
        length = np.minimum(length, depth / cfg.depth_fraction_min)
    reach = cfg.peg_radius * np.sqrt(1.0 - cz**2) + length[:, None] * np.maximum(-cz, 0.0)
    return reach.max(axis=1)


def expert_action(obs: np.ndarray, cfg: ExpertConfig = ExpertConfig()) -> np.ndarray:
    """(n, 18) observations -> (n, 6) actions in [-1, 1]."""
    obs = np.asarray(obs, dtype=np.float64)
    t_ep, r_ep, t_bp, r_bp = _split(obs)
    r_eb = r_ep @ np.swapaxes(r_bp, 1, 2)  # bottom frame's orientation in E (exact)
    t_eb = t_ep - np.einsum("nij,nj->ni", r_eb, t_bp)  # bottom origin in E (exact)
    axis = r_eb[:, :, 2]  # hole axis in E, pointing out of the hole
    depth = -t_eb[:, 2] / axis[:, 2]  # axial distance bottom -> entrance plane

    # orientation error: rotate the peg onto the bottom frame, w = k * rotvec(R_EB R_EP^T)
    rotvec = matrix_to_rotvec(r_eb @ np.swapaxes(r_ep, 1, 2))
    angle = np.linalg.norm(rotvec, axis=1)
    omega = cfg.rot_gain * rotvec
    omega = _limit(omega, cfg.max_ang_vel, cfg.box_limits)

    lateral_b = t_bp.copy()
    lateral_b[:, 2] = 0.0
    lateral = np.einsum("nij,nj->ni", r_eb, lateral_b)  # lateral offset from the axis, in E
    lat_err = np.linalg.norm(lateral_b, axis=1)
    axial = t_bp[:, 2]  # height above the seat along the axis
    height = t_ep[:, 2]  # height above the mounting surface

    # axial target: the standoff while misaligned, the seat once aligned
    align = np.clip(1.0 - lat_err / cfg.lateral_tol, 0.0, 1.0) * np.clip(
        1.0 - angle / cfg.angle_tol, 0.0, 1.0
    )
    if cfg.touch_speed is None:
        inside = axial < depth + 0.002  # already in the hole: the walls guide, keep going
        descent = np.where(inside, np.maximum(align, cfg.inside_speed), align) * cfg.insert_speed
    else:
        inside = axial < depth
        approach = cfg.pos_gain * np.maximum(axial - depth, 0.0) + cfg.touch_speed
        descent = np.where(
            inside,
            np.maximum(align, cfg.inside_speed) * cfg.insert_speed,
            np.minimum(align * cfg.insert_speed, approach),
        )
    to_standoff = cfg.pos_gain * (depth + cfg.standoff - axial)
    v_axial = np.where(
        (align > 0) | inside,
        -np.minimum(descent, cfg.pos_gain * np.maximum(axial + cfg.seat_overshoot, 0.0)),
        to_standoff,
    )
    v = -cfg.pos_gain * lateral + v_axial[:, None] * axis

    # turning: stay (or get) high until the orientation is nearly right
    turning = angle > cfg.turn_angle
    safe = (
        _turn_reach(r_ep, rotvec, depth, cfg) + cfg.safe_margin
        if cfg.tilt_safe_height
        else np.full(len(obs), cfg.safe_height)
    )
    low = height < safe
    rise = turning & low
    v_rise = np.zeros_like(v)
    v_rise[:, 2] = cfg.pos_gain * (safe + 0.01 - height)
    v = np.where(rise[:, None], v_rise, v)
    # the lateral move at height is safe; no descent while turning
    floor = cfg.pos_gain * (safe - height) if cfg.descend_while_turning else 0.0
    v[:, 2] = np.where(turning & ~rise, np.maximum(v[:, 2], floor), v[:, 2])
    omega = np.where((rise & (height < safe - 0.01))[:, None], 0.0, omega)

    v = _limit(v, cfg.max_lin_vel, cfg.box_limits)
    act = np.concatenate([v / cfg.max_lin_vel, omega / cfg.max_ang_vel], axis=1)
    return np.clip(act, -1.0, 1.0)
