"""The contact stress benchmark's figures: from a run's trajectory to its record
(run_figures), the records of one clearance to a summary (summarize), the contact targets a
summary meets (TARGETS, targets) and a summary's rows as the command prints them
(format_summary).

Figures of a push or impact: transient penetration (the deepest over the run), depth at rest
(the deepest over the last `window`), not at rest (over the last `window`, the peg frame's
mean speed above `rest_speed` or its peak-to-peak motion above `rest_motion`), and pass-through
(the peg frame's origin leaves the hole's cross-section below the mounting surface, or sinks
more than `floor_pass` below the hole floor).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from assetgen.core.rotations import quat_to_matrix
from sim.bench.stress.cases import HoleGeometry, Run, StressConfig


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
            # through a wall: beyond the hole's sides and below the surface, inside the
            # module's footprint; through the floor: below it, inside the hole's sides (a peg
            # that climbed out of its hole and left over the plate's edge, or lies beyond the
            # far reach of the tilted floor's plane, went through nothing)
            over = (np.abs(pos[i, :, :2]) <= geo.footprint).all(axis=-1)
            through = ((beyond[i] > 0) & (pos[i, :, 2] < -geo.clearance) & over) | (
                (below[i] > cfg.floor_pass) & (beyond[i] <= 0)
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
                "left_hole": bool(((beyond[i] > 0) & (pos[i, :, 2] > 0)).any()),
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
        "kinds": sorted({r["kind"] for r in records}),
        "modules": len({r["module"] for r in records}),
        "clearance": clearance,
        "pushes": len(pushes),
        "impacts": len(impacts),
        "passed_through": sum(r["passed_through"] for r in hits),
        "left_hole": sum(r.get("left_hole", False) for r in pushes),
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


HITS = ("push", "impact")
"""The case families whose runs press the peg into the hole (penetration, depth at rest)."""
TARGET_KINDS: dict[str, tuple[str, ...]] = {
    "every straight push at rest": ("push",),
    "99 % of twisting pushes at rest": ("push",),
    "friction within 5 %": ("friction",),
    "rebound e <= 0.1": ("rebound",),
}
"""The case families whose runs test a target (the rest: pushes or impacts, HITS)."""


def _tested(needs: tuple[str, ...], kinds) -> bool:
    return kinds is None or any(k in kinds for k in needs)


def targets(summary: dict) -> dict[str, bool]:
    """Which targets a summary meets, of those its runs test (a summary without `kinds`, from
    before the field: every target)."""
    kinds = summary.get("kinds")
    return {
        name: bool(test(summary))
        for name, test in TARGETS.items()
        if _tested(TARGET_KINDS.get(name, HITS), kinds)
    }


_PUSH, _IMPACT = ("push",), ("impact",)
_ROWS = (
    ("pass-throughs", "passed_through", None, HITS),
    ("pushes that climbed out of the hole", "left_hole", None, _PUSH),
    ("transient penetration, worst", "penetration_worst", "mm", HITS),
    ("transient penetration, p99", "penetration_p99", "mm", HITS),
    ("  pushes: worst / p99", ("push_penetration_worst", "push_penetration_p99"), "mm", _PUSH),
    (
        "  impacts: worst / p99",
        ("impact_penetration_worst", "impact_penetration_p99"),
        "mm",
        _IMPACT,
    ),
    ("runs deeper than the clearance", "deeper_than_clearance", None, HITS),
    ("depth at rest, worst / p99", ("rest_depth_worst", "rest_depth_p99"), "mm", HITS),
    ("straight pushes not at rest", ("straight_not_at_rest", "straight_pushes"), "of", _PUSH),
    ("twisting pushes not at rest", ("twisting_not_at_rest", "twisting_pushes"), "of", _PUSH),
    ("  of them still turning", "twisting_turning", None, _PUSH),
    (
        "pushes chattering: straight / twisting",
        ("straight_chattering", "twisting_chattering"),
        "/",
        _PUSH,
    ),
    ("impacts not at rest", ("impacts_not_at_rest", "impacts"), "of", _IMPACT),
    ("effective / configured friction", "friction", "ratio", ("friction",)),
    ("rebound e (actuators off), worst", "rebound_worst", "e", ("rebound",)),
)
"""(figure, summary key(s), unit, the case families whose runs give it)."""


def format_summary(s: dict) -> list[tuple[str, str]]:
    """(figure, value) rows of a summary, lengths in mm and as a fraction of the clearance."""
    c = s["clearance"]
    rows = []
    kinds = s.get("kinds")
    for name, key, unit, needs in _ROWS:
        if not _tested(needs, kinds):
            continue  # a case family not run
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
