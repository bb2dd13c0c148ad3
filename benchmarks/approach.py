"""Where a policy's time to success goes, beside a scripted expert's: one episode on each of a
dataset's first modules for both, and for each successful episode the control step at which
the peg first comes within R mm of the hole's axis (R = 50, 20, 10, 5, 2), first stands
within 3° of it, and succeeds.

    python -m benchmarks.approach RUN_DIR [--dataset train] [--modules 64]
                                  [--expert scripted-direct] [--json out.json]

Medians over the episodes that succeeded (each agent its own). The offset is the peg frame's
origin (the centre of its bottom face) from the hole's axis, in the bottom frame, from the
true pose; "height" beside it is that origin's height above the entrance (mm) at that step.
Tune on the train split only.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.module_episodes import Act, ModuleEpisodes, Reset, checkpoint_policy

RADII_MM = (50.0, 20.0, 10.0, 5.0, 2.0)
TILT_DEG = 3.0


def trace(
    act: Act,
    dataset: str,
    modules: int,
    seed: int = 0,
    stack: int = 1,
    reset: Reset | None = None,
) -> dict[str, np.ndarray]:
    """One episode per module under `act` (observations, stacked `stack` deep, to actions;
    `reset(mask)` restarts a recurrent policy's state); per control step and env (NaN once
    the episode has ended): the offset from the axis (mm), the height above the entrance (mm)
    and the tilt (degrees); and each env's success step (NaN: no success)."""
    episodes = ModuleEpisodes(act, dataset, modules, seed, stack, reset)
    env, n = episodes.env, episodes.env.num_envs
    offset, height, tilt = (np.full((episodes.steps, n), np.nan) for _ in range(3))
    for t, _ in episodes:
        peg = env.peg_poses()
        rel = env.bottom_inv @ peg
        live = ~episodes.ended
        offset[t, live] = np.hypot(rel[live, 0, 3], rel[live, 1, 3]) * 1e3
        height[t, live] = (env.entrance_inv @ peg)[live, 2, 3] * 1e3
        tilt[t, live] = np.degrees(np.arccos(np.clip(rel[live, 2, 2], -1.0, 1.0)))
    success = np.where(episodes.success, episodes.end_step + 1, np.nan)
    return {"offset_mm": offset, "height_mm": height, "tilt_deg": tilt, "success": success}


def _first(mask: np.ndarray) -> np.ndarray:
    """Per env (column), the first step where mask holds (NaN: never)."""
    hit = mask.any(0)
    return np.where(hit, mask.argmax(0), np.nan)


def milestones(tr: dict[str, np.ndarray]) -> dict[str, float | int]:
    """Medians over the successful episodes: the steps at which the offset first falls under
    each radius (and the height there), the tilt under TILT_DEG, and success."""
    ok = ~np.isnan(tr["success"])
    out: dict[str, float | int] = {"episodes": len(ok), "successes": int(ok.sum())}
    if not ok.any():
        return out
    cols = np.flatnonzero(ok)
    for r in RADII_MM:
        at = _first(tr["offset_mm"][:, cols] < r)
        h = [tr["height_mm"][int(s), c] for s, c in zip(at, cols, strict=True) if not np.isnan(s)]
        out[f"step_within_{r:g}mm"] = float(np.nanmedian(at))
        out[f"height_at_{r:g}mm"] = float(np.median(h)) if h else float("nan")
    turned = _first(tr["tilt_deg"][:, cols] < TILT_DEG)
    out[f"step_tilt_under_{TILT_DEG:g}deg"] = float(np.nanmedian(turned))
    out["step_success"] = float(np.median(tr["success"][cols]))
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("checkpoint", help="a run folder or checkpoint")
    p.add_argument("--dataset", default="train")
    p.add_argument("--modules", type=int, default=64)
    p.add_argument("--expert", default="scripted-direct", help="the scripted agent beside it")
    p.add_argument("--json", type=Path)
    args = p.parse_args(argv)
    from sim.task.expert import EXPERTS

    if args.modules < 1:
        p.error(f"--modules {args.modules}: give at least 1")
    if args.expert not in EXPERTS:
        p.error(f"--expert {args.expert!r}: give one of {', '.join(EXPERTS)}")
    act, stack, reset = checkpoint_policy(args.checkpoint)
    policy = milestones(trace(act, args.dataset, args.modules, stack=stack, reset=reset))
    expert = milestones(trace(EXPERTS[args.expert], args.dataset, args.modules))
    res = {"checkpoint": args.checkpoint, "dataset": args.dataset, "policy": policy,
           args.expert: expert}  # fmt: skip
    print(f"{'median control step (0.02 s)':<32} {'policy':>8} {args.expert:>16}")
    for key in [k for k in expert if k in policy]:
        print(f"{key:<32} {policy[key]:>8.4g} {expert[key]:>16.4g}")
    if args.json:
        from assetgen.core.atomic_file import write_json

        write_json(args.json, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
