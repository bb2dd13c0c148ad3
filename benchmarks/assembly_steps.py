"""The scripted expert on each step of profile-bolt assemblies, step by step (not yet the
sequence: each step starts with the earlier parts at their design poses).

    python -m benchmarks.assembly_steps [--n 3] [--seed 0] [--steps 2000] [--clearance-mm 0.25]

Generates `--n` assemblies from `--seed` into a temporary folder, then runs two envs per
assembly and step for `--steps` control steps with the scripted expert (the Table I one,
unchanged), the task's full spawn ranges and noise. Prints per step the finished episodes
by outcome and the median time to success, and, last, one JSON line.
"""

from __future__ import annotations

import argparse
import collections
import json
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from assetgen.dataset.assembly_writer import write_assembly
from assetgen.families.profile_bolt import ProfileBoltSampler, build_profile_bolt
from sim.assets.assembly import load_stage
from sim.env import PegInHoleVecEnv
from sim.task.config import EVAL_CONFIG
from sim.task.expert import EXPERTS


def run(n: int, seed: int, steps: int, clearance: float) -> dict:
    sampler = replace(ProfileBoltSampler(), profile_clearance=clearance)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for s in range(seed, seed + n):
            params = sampler.sample(s)
            write_assembly("profile-bolt", params, build_profile_bolt(params), s, root)
        for k, part in enumerate(("profile", "bolt")):
            stages = [load_stage(root / f"{s:06d}", k) for s in range(seed, seed + n)]
            env = PegInHoleVecEnv(stages * 2, num_envs=2 * n, config=EVAL_CONFIG)
            obs, seen, times = env.reset(seed=seed), collections.Counter(), []
            for _ in range(steps):
                obs, _, term, trunc, info = env.step(EXPERTS["scripted"](obs))
                for e in np.flatnonzero(term | trunc):
                    end = "failure" if info["failure"][e] else "truncated"
                    seen["success" if info["success"][e] else end] += 1
                    if info["success"][e]:
                        times.append(float(info["time_to_success"][e]))
            out[part] = {
                "episodes": sum(seen.values()),
                **{k: seen[k] for k in ("success", "failure", "truncated")},
                "median_s": float(np.median(times)) if times else None,
            }
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=3, help="assemblies")
    p.add_argument("--seed", type=int, default=0, help="first assembly seed")
    p.add_argument("--steps", type=int, default=2000, help="control steps per step of the sequence")
    p.add_argument("--clearance-mm", type=float, default=0.25, help="the profile's clearance")
    a = p.parse_args()
    res = run(a.n, a.seed, a.steps, a.clearance_mm / 1000.0)
    for part, r in res.items():
        median = f"{r['median_s']:.2f} s" if r["median_s"] is not None else "-"
        print(
            f"{part:8s} {r['success']} of {r['episodes']} succeeded "
            f"({r['failure']} failed, {r['truncated']} truncated), median {median}"
        )
    print(json.dumps(res))


if __name__ == "__main__":
    main()
