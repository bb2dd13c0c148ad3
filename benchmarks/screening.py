"""Screen a teacher-free candidate on the train split and file it for the screening page.

    python -m benchmarks.screening RUN_DIR --as NAME [--threads 1]

A candidate is one seed of a recipe, chosen on the train split only. Its screening is:

    assetgen eval --checkpoint RUN_DIR --dataset train --modules 256 --attempts 2 \\
        [--stochastic] --out RUN_DIR/screen_train_{det,sto}.json
    python -m benchmarks.jams RUN_DIR --modules 64 --json RUN_DIR/jams_train.json

(each skipped when its file is there and holds the checkpoint's present training state:
a run resumed since is evaluated again), then the run's config.json and metrics.csv, both
evaluations and the jams go to docs/results/runs/screening/NAME, where `python -m
benchmarks.results_pages` makes the screening page: one row and one learning curve per
candidate. One seed is a draw, not a result: the page says where to look.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from benchmarks.table3 import RESULTS, RUN_FILES, file_run
from rl.checkpoint import read_counters

MODULES, ATTEMPTS, JAM_MODULES = 256, 2, 64
"""The first 256 train modules × 2 attempts; the jams on the first 64."""
SCREENS = {
    "screen_train_det.json": ("eval_train.json", ()),
    "screen_train_sto.json": ("eval_train_sampled.json", ("--stochastic",)),
}
"""Evaluation file in the run -> (name filed, `assetgen eval` flags)."""
JAMS = "jams_train.json"


def screen(run: Path, name: str, threads: int = 1, results: Path = RESULTS,
           dataset: str = "train") -> Path:  # fmt: skip
    """Evaluate what is missing, then file the run; returns the filed folder."""
    from benchmarks import jams
    from cli import main as assetgen

    if not (run / "checkpoint.safetensors").is_file():
        raise SystemExit(f"{run}: no checkpoint.safetensors; give a run folder of assetgen train")
    steps = read_counters(run).get("env_steps")

    def current(name: str) -> bool:
        """Whether run/name is there and of the checkpoint's present training state."""
        f = run / name
        return f.is_file() and json.loads(f.read_text()).get("trained_env_steps") == steps

    for src, (_, flags) in SCREENS.items():
        if not current(src):
            argv = ["eval", "--checkpoint", str(run), "--dataset", dataset, "--modules",
                    str(MODULES), "--attempts", str(ATTEMPTS), "--threads", str(threads),
                    *flags, "--out", str(run / src)]  # fmt: skip
            print("assetgen " + " ".join(argv), flush=True)
            if assetgen(argv):
                raise SystemExit(f"assetgen eval of {run} failed")
    if not current(JAMS):
        jams.main([str(run), "--dataset", dataset, "--modules", str(JAM_MODULES),
                   "--json", str(run / JAMS)])  # fmt: skip
    filed = results / "runs" / "screening" / name
    files = {f: f for f in RUN_FILES} | {s: d for s, (d, _) in SCREENS.items()} | {JAMS: JAMS}
    file_run(run, filed, files)
    return filed


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path, help="the candidate's run folder (assetgen train --out)")
    ap.add_argument("--as", dest="name", required=True, help="its name on the screening page")
    ap.add_argument("--threads", type=int, default=1, help="torch threads of the evaluations")
    ap.add_argument("--results", type=Path, default=RESULTS, help="where results are filed")
    ap.add_argument("--dataset", default="train", help="the split it is screened on")
    args = ap.parse_args(argv)
    if not args.name or "/" in args.name or args.name.startswith("."):
        ap.error(f"--as {args.name!r}: give a plain folder name, e.g. ppo-std0.1-120min")
    screen(args.run, args.name, args.threads, args.results, args.dataset)
    return 0


if __name__ == "__main__":
    sys.exit(main())
