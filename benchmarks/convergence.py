"""Does the task's outcome depend on the physics step? The scripted experts under the
project's physics and under the same physics at half (or a quarter of) its timestep.

    python -m benchmarks.convergence [--dataset test] [--agents scripted,scripted-direct]
                                     [--attempts 2] [--modules N] [--factors 2] [--json F]

Each run is the evaluation protocol (noise on, full spawn ranges) on the dataset's first
`--modules` modules (all by default), the same seed and spawns. A factor f divides the
timestep by f and multiplies the substeps by f (the control period stays 20 ms); every
physical constant (the contact's time constant and damping, the controller) stays, so only
the discretisation changes. Prints success and median time to success per agent and step,
and their changes against the project's step.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

from assetgen.core.atomic_file import write_json
from assetgen.core.mujoco_config import physics_for
from assetgen.core.recorded_path import recorded_path
from assetgen.dataset.reader import Dataset
from evaluation.protocol import evaluate
from sim.assets.loading import dataset_root, load_dataset
from sim.env import PegInHoleVecEnv, eval_config
from sim.task.expert import EXPERTS


def run(dataset: str, agents: list[str], attempts: int, modules: int | None, factors: list[int]):
    root = dataset_root(dataset)
    ids = Dataset(root).ids[:modules] if modules else None
    assets = load_dataset(root, ids)
    base = physics_for(min(a.clearance for a in assets))
    rows = []
    for agent in agents:
        for f in [1, *factors]:
            physics = replace(base, timestep=base.timestep / f, substeps=base.substeps * f)
            env = PegInHoleVecEnv(assets, len(assets), replace(eval_config(), physics=physics))
            r = evaluate(EXPERTS[agent], env, attempts, seed=0)
            env.close()
            rows.append(
                {
                    "agent": agent,
                    "timestep": physics.timestep,
                    "episodes": r["episodes"],
                    "success_rate": r["success_rate"],
                    "median_time_to_success_s": r["median_time_to_success_s"],
                    "failure_rate": r.get("failure_rate", float("nan")),
                    "truncation_rate": r["truncation_rate"],
                    "seconds": r["seconds"],
                }
            )
    for row in rows:
        ref = next(x for x in rows if x["agent"] == row["agent"])
        row["success_change_points"] = 100 * (row["success_rate"] - ref["success_rate"])
        row["median_change"] = (
            row["median_time_to_success_s"] / ref["median_time_to_success_s"] - 1.0
        )
    return {
        "dataset": recorded_path(root),
        "modules": len(assets),
        "attempts": attempts,
        "rows": rows,
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dataset", default="test")
    p.add_argument("--agents", default="scripted,scripted-direct")
    p.add_argument("--attempts", type=int, default=2)
    p.add_argument("--modules", type=int, default=None)
    p.add_argument("--factors", default="2", help="timestep divisors besides 1, e.g. 2,4")
    p.add_argument("--json", default=None)
    a = p.parse_args()
    res = run(
        a.dataset,
        a.agents.split(","),
        a.attempts,
        a.modules,
        [int(x) for x in a.factors.split(",")],
    )
    for r in res["rows"]:
        print(
            f"{r['agent']:<16} {r['timestep'] * 1e3:6.3f} ms  {r['episodes']:6d} episodes  "
            f"success {100 * r['success_rate']:6.2f} % ({r['success_change_points']:+.2f})  "
            f"median {r['median_time_to_success_s']:.3f} s ({100 * r['median_change']:+.1f} %)  "
            f"{r['seconds']:.0f} s"
        )
    if a.json:
        write_json(a.json, res)
    print(json.dumps({k: v for k, v in res.items() if k != "rows"} | {"rows": len(res["rows"])}))


if __name__ == "__main__":
    main()
