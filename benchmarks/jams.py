"""Where a policy's unfinished episodes end: one episode on each of a dataset's first modules,
and for every episode the step limit cuts short (a jam), the peg's place relative to the seat
and what the policy commands over its last second.

    python -m benchmarks.jams RUN_DIR [--dataset train] [--modules 64] [--stochastic]
                              [--robot panda [--robot-set FIELD=VALUE ...]] [--json out.json]

Printed per jam: the peg's offset from the hole's axis (mm, in the bottom frame), how deep
its frame's origin (the centre of its bottom face) is below the hole's entrance (mm; < 0:
above the plate), its tilt from the axis (degrees), how far it moved over the last 50
control steps (peak to peak, mm), and the mean clipped action over those steps (x, y, z in
[-1, 1]; z < 0 presses down). A peg beside the hole with z at -1 and small x, y is pressed
onto the plate harder than its lateral command can slide it: friction holds it. `--robot`
plays the episodes through a robot holding the peg (the modules it refuses are left out);
`--robot-set` changes a field of its settings (the registry's entry: the Panda's
ArmSettings, e.g. max_force=20).
Tune on the train split only.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.module_episodes import ModuleEpisodes, checkpoint_policy


def run(
    checkpoint: str,
    dataset: str,
    modules: int,
    stochastic: bool,
    seed: int = 0,
    robot: str | None = None,
    robot_settings: object = None,
) -> dict[str, object]:
    """One episode per module; the jams' figures (see module doc)."""
    from rl.checkpoint import read_counters

    act, stack, reset = checkpoint_policy(checkpoint, not stochastic, seed)
    episodes = ModuleEpisodes(act, dataset, modules, seed, stack, reset, robot, robot_settings)
    env, n, tail = episodes.env, episodes.env.num_envs, 50
    pos = np.zeros((tail, n, 3))
    below = tilt = np.zeros(n)
    acts = np.zeros((tail, n, env.act_dim))
    for t, a in episodes:
        if t >= episodes.steps - tail:
            i = t - episodes.steps + tail
            peg = env.peg_poses()
            rel = env.bottom_inv @ peg
            pos[i] = rel[:, :3, 3] * 1e3
            acts[i] = np.clip(a, -1.0, 1.0)
            if i == tail - 1:  # depth and tilt where the episode was cut
                below = -(env.entrance_inv @ peg)[:, 2, 3] * 1e3
                tilt = np.degrees(np.arccos(np.clip(rel[:, 2, 2], -1.0, 1.0)))
    rows = [
        {
            "module": env.module_ids[env.env_module[i]],
            "offset_mm": float(np.hypot(*pos[-1, i, :2])),
            "below_entrance_mm": float(below[i]),
            "tilt_deg": float(tilt[i]),
            "moved_mm": float(np.ptp(pos[:, i], axis=0).max()),
            "action_xyz": acts[:, i, :3].mean(0).round(3).tolist(),
        }
        for i in np.flatnonzero(episodes.jammed())
    ]
    return {
        "checkpoint": checkpoint,
        "trained_env_steps": read_counters(checkpoint).get("env_steps"),
        "dataset": dataset,
        "modules": n,
        "policy": "stochastic" if stochastic else "deterministic",
        "successes": int(episodes.success.sum()),
        "jams": rows,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("checkpoint", help="a run folder or checkpoint")
    p.add_argument("--dataset", default="train")
    p.add_argument("--modules", type=int, default=64)
    p.add_argument("--stochastic", action="store_true")
    p.add_argument("--robot", default=None, help="a robot holds the peg (e.g. panda)")
    p.add_argument(
        "--robot-set",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="with --robot panda: a field of its ArmSettings (repeatable)",
    )
    p.add_argument("--json", type=Path)
    args = p.parse_args(argv)
    if args.modules < 1:
        p.error(f"--modules {args.modules}: give at least 1")
    settings = None
    if args.robot_set:
        if args.robot is None:
            p.error("--robot-set: give --robot panda as well")
        from assetgen.core.overrides import parse_overrides
        from sim.robots.registry import get_robot

        try:
            cls = get_robot(args.robot).load("settings")
            settings = cls(**parse_overrides(cls, args.robot_set, "--robot-set")).validate()
        except ValueError as e:
            p.error(str(e))
    res = run(args.checkpoint, args.dataset, args.modules, args.stochastic, robot=args.robot,
              robot_settings=settings)  # fmt: skip
    jams = res["jams"]
    print(
        f"{res['modules']} modules, {res['policy']} policy: {res['successes']} successes, "
        f"{len(jams)} jams (step limit reached)"
    )
    print(f"{'module':>8} {'off mm':>7} {'in mm':>7} {'tilt':>6} {'moved':>6}  action x y z")
    for r in jams:
        ax, ay, az = r["action_xyz"]
        print(
            f"{r['module']:>8} {r['offset_mm']:7.1f} {r['below_entrance_mm']:7.1f} "
            f"{r['tilt_deg']:6.1f} {r['moved_mm']:6.2f}  {ax:+.2f} {ay:+.2f} {az:+.2f}"
        )
    if jams:
        a = np.array([r["action_xyz"] for r in jams])
        print(
            f"median over jams: offset {np.median([r['offset_mm'] for r in jams]):.1f} mm, "
            f"|x, y| action {np.median(np.hypot(a[:, 0], a[:, 1])):.2f}, z action "
            f"{np.median(a[:, 2]):+.2f}"
        )
    if args.json:
        from assetgen.core.atomic_file import write_json

        write_json(args.json, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
