"""When does a training run take off, and does it stall? Read from run folders' metrics.

    python -m benchmarks.takeoff RUN_DIR [RUN_DIR ...] [--threshold 0.10]
                                 [--stall-steps 1000000] [--json out.json]

A run takes off at the first logged iteration whose training success (over the runner's
window of the last finished episodes, at least 100, all of them ended after the warm-up)
reaches --threshold; it stalls when it has not taken off by --stall-steps env steps. Counted
in env steps, not minutes, so that a recipe bounded by wall-clock time is judged the same on
a slower machine. A run that ended before --stall-steps without taking off is "unfinished",
neither a stall nor a take-off.

Prints one row per run (its variant, seed, env steps and minutes to take-off, its last
training success) and, per variant, the stall rate over the runs that decided.
"""

from __future__ import annotations

import argparse
import json
import math
from collections import Counter
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from assetgen.core.atomic_file import write_json
from rl.report_load import Run, load_run, variant_name


@dataclass(frozen=True)
class Takeoff:
    """One run's take-off. steps and minutes are None where it did not take off."""

    path: str
    variant: str
    seed: int
    steps: int | None
    minutes: float | None
    reached_steps: int
    last_success: float
    verdict: str
    """'took off', 'stalled' (no take-off by the stall steps) or 'unfinished'."""

    @property
    def at(self) -> str:
        """The take-off's env steps ("0.43 M"), or the verdict where there was none."""
        return f"{self.steps / 1e6:.2f} M" if self.steps is not None else self.verdict

    @property
    def minutes_text(self) -> str:
        return f"{self.minutes:.1f}" if self.minutes is not None else "–"


def env_labels(paths: list[str]) -> list[str]:
    """Each run's env options (config.json's env_options: robot, readings, near starts, ...)
    that differ from the value most of the runs given have, as "k=v" words; runs of one
    variant that differ in them are different candidates."""
    opts = [json.loads((Path(p) / "config.json").read_text()).get("env_options", {}) for p in paths]
    keys = sorted({k for o in opts for k in o})
    # the value most runs have is the baseline's, named in none
    usual = {k: Counter(json.dumps(o.get(k)) for o in opts).most_common(1)[0][0] for k in keys}
    return [
        " ".join(f"{k}={o[k]}" for k in keys if k in o and json.dumps(o[k]) != usual[k])
        for o in opts
    ]


def policy_rows(run: Run) -> np.ndarray:
    """(T,) bool: the logged iterations whose success window holds only episodes that ended
    after the warm-up (the uniform-random or teacher's actions of SAC's first warmup_steps),
    a full window of them (the runner's: max(100, envs) episodes). Early windows of a few
    lucky random episodes near the hole are not a take-off."""
    if len(run.episodes) != len(run.env_steps):
        raise ValueError(f"{run.path}/metrics.csv has no episodes column (rl/metrics.py)")
    meta = json.loads((Path(run.path) / "config.json").read_text())
    warmup = int(meta.get("config", {}).get("warmup_steps", 0))
    window = max(100, int(meta.get("num_envs", 1)))
    before = run.episodes[run.env_steps <= warmup]
    return run.episodes >= (before[-1] if len(before) else 0) + window


def takeoff(run: Run, threshold: float, stall_steps: int) -> Takeoff:
    rate = np.nan_to_num(run.success_rate, nan=0.0)
    hit = np.flatnonzero((rate >= threshold) & policy_rows(run))
    reached = int(run.env_steps[-1]) if len(run.env_steps) else 0
    last = float(rate[-1]) if len(rate) else math.nan
    steps = minutes = None
    if len(hit) and run.env_steps[hit[0]] <= stall_steps:
        i = int(hit[0])
        steps = int(run.env_steps[i])
        minutes = float(run.wall_s[i]) / 60.0 if len(run.wall_s) else None
        verdict = "took off"
    elif reached >= stall_steps:
        verdict = "stalled"
    else:
        verdict = "unfinished"
    return Takeoff(str(run.path), run.variant, run.seed, steps, minutes, reached, last, verdict)


def stall_rates(rows: list[Takeoff]) -> dict[str, tuple[int, int]]:
    """variant -> (stalled, runs that decided: took off or stalled)."""
    out: dict[str, tuple[int, int]] = {}
    for r in rows:
        if r.verdict == "unfinished":
            continue
        stalled, decided = out.get(r.variant, (0, 0))
        out[r.variant] = (stalled + (r.verdict == "stalled"), decided + 1)
    return out


def relabel(run: Run, extra: str) -> Run:
    """The run named by its policy (algorithm, --set fields) and `extra`, its env_labels
    words (which hold the training env options load_run names as well)."""
    meta = json.loads((Path(run.path) / "config.json").read_text())
    policy = variant_name(meta["algo"], int(meta.get("stack", 1)), meta.get("demos"),
                          meta.get("overrides"))  # fmt: skip
    return replace(run, variant=f"{policy} {extra}".strip())


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("runs", nargs="+", help="run folders of `assetgen train`")
    p.add_argument("--threshold", type=float, default=0.10, help="training success (0, 1]")
    p.add_argument("--stall-steps", type=int, default=1_000_000, help="env steps")
    p.add_argument("--json", help="write the rows and the stall rates here")
    args = p.parse_args(argv)
    if not 0.0 < args.threshold <= 1.0:
        p.error(f"--threshold {args.threshold}: give a training success in (0, 1]")
    if args.stall_steps < 1:
        p.error(f"--stall-steps {args.stall_steps}: give a positive number of env steps")
    rows = [
        takeoff(relabel(load_run(r), extra), args.threshold, args.stall_steps)
        for r, extra in zip(args.runs, env_labels(args.runs), strict=True)
    ]
    print(f"take-off: training success >= {args.threshold:.0%} by {args.stall_steps:,} env steps")
    print(f"{'run':<40} {'seed':>4} {'take-off':>10} {'minutes':>8} {'reached':>9} {'last':>6}")
    for r in rows:
        name = Path(r.path).name
        print(
            f"{name:<40} {r.seed:>4} {r.at:>10} {r.minutes_text:>8} "
            f"{r.reached_steps / 1e6:>7.2f} M {r.last_success:>6.1%}"
        )
    rates = stall_rates(rows)
    for variant, (stalled, decided) in rates.items():
        print(f"stall rate {stalled} of {decided}: {variant}")
    if args.json:
        write_json(
            args.json,
            {
                "threshold": args.threshold,
                "stall_steps": args.stall_steps,
                "runs": [r.__dict__ for r in rows],
                "stall_rates": {v: {"stalled": s, "runs": d} for v, (s, d) in rates.items()},
            },
        )


if __name__ == "__main__":
    main()
