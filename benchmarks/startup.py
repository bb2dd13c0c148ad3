"""How long the command line takes to start: `assetgen --help`, run as a fresh process, here
and (optionally) in another checkout, taken in turns so that a busy machine hits both alike.

    python -m benchmarks.startup [--other PATH] [--runs 30]

Prints the median and the fastest run for each checkout. Every command builds the same
parser first, so this is the floor of every `assetgen` command's time.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent
CODE = "import sys; sys.argv = ['assetgen', '--help']; import cli; cli.main()"


def startup_times(trees: dict[str, Path], runs: int) -> dict[str, list[float]]:
    """Seconds of `runs` starts of `assetgen --help` in each checkout, in turns."""
    cmd = [sys.executable, "-c", CODE]
    for tree in trees.values():  # warm the file cache
        subprocess.run(cmd, cwd=tree, capture_output=True, check=True)
    times: dict[str, list[float]] = {name: [] for name in trees}
    for _ in range(runs):
        for name, tree in trees.items():
            t0 = time.perf_counter()
            subprocess.run(cmd, cwd=tree, capture_output=True, check=True)
            times[name].append(time.perf_counter() - t0)
    return times


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--other", type=Path, help="another checkout to time in turns with this one")
    p.add_argument("--runs", type=int, default=30, help="starts per checkout (default 30)")
    args = p.parse_args(argv)
    if args.runs < 1:
        p.error(f"--runs {args.runs}: give at least 1")
    trees = {"this checkout": HERE}
    if args.other is not None:
        if not (args.other / "cli.py").is_file():
            p.error(f"--other {args.other}: no cli.py there; give a checkout of this project")
        trees[str(args.other)] = args.other
    for name, t in startup_times(trees, args.runs).items():
        print(f"{name}: median {1e3 * statistics.median(t):.0f} ms, fastest {1e3 * min(t):.0f} ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
