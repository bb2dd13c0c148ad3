"""`assetgen bench assets`: full-pipeline modules per second and the cached re-run time."""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from assetgen.core.preflight import count

NUMBERS = {
    "n": count("give at least 1 module"),
    "workers": count("give at least 1 process, or leave it out (one a core)"),
}
"""The bounds of `bench assets`' numeric flags (assetgen.core.preflight)."""


def add_parser(bench: argparse._SubParsersAction) -> None:
    """`assetgen bench assets`, beside the code it drives."""
    p = bench.add_parser("assets", help="modules per second of the whole generator")
    p.add_argument("--n", type=int, default=256, help="modules (default 256)")
    p.add_argument("--workers", type=int, default=None, help="processes (default: one a core)")
    p.add_argument("--dir", type=Path, default=None, help="scratch folder (default: cwd)")
    p.add_argument(
        "--family",
        default="peg-in-hole",
        help="the families to time, comma-separated, one after the other in this run "
        "(default: peg-in-hole, Table I; e.g. peg-in-hole,profile,multi-peg)",
    )
    p.add_argument("--json", action="store_true", help="print the figures as JSON last")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from assetgen.core.console_output import print_error, print_figures
    from assetgen.core.preflight import check_numbers

    try:
        check_numbers(args, NUMBERS)  # before the scratch folder is made
        from assetgen.dataset.families import family

        names = [family(f.strip()).name for f in args.family.split(",")]  # all, before any run
        results = {f: bench_assets(args.n, args.workers, args.dir, f) for f in names}
    except ValueError as e:
        return print_error(str(e))
    for name, result in results.items():
        print_figures(f"bench assets ({name})", result, args.json)
    if len(results) > 1:  # the same sitting: each family's time a module against the first's
        first = next(iter(results.values()))["modules_per_s"]
        for name, result in results.items():
            print(f"{name}: {result['modules_per_s']:.1f} modules/s, "
                  f"{first / result['modules_per_s']:.2f}x {names[0]}'s time a module")  # fmt: skip
    return 0


def bench_assets(
    n: int = 256, workers: int | None = None, where: Path | None = None, fam: str = "peg-in-hole"
) -> dict:
    """Generate `n` modules (all formats, all checks) into a temporary folder, then re-run.

    The folder is made under `where` (default: the current directory, where datasets go;
    /tmp can sit on another file system; the pipeline writes six files a module); `where` is
    made if missing.
    Returns modules_per_s, seconds and cached_rerun_s among others, and step_ms: the
    wall milliseconds per module of each pipeline step (summed over the workers, so they add
    up to about workers x seconds / modules), which shows which step a regression is in.
    fam: the family generated (its sampler's defaults).
    """
    from assetgen.dataset.families import family
    from assetgen.dataset.generate import generate
    from assetgen.dataset.spec import DatasetSpec
    from assetgen.formats.registry import available_formats

    if n < 1:
        raise ValueError(f"--n {n}: give at least 1 module to time")
    workers = workers or os.cpu_count() or 1
    if where is not None:
        try:
            Path(where).mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise ValueError(f"--dir {where}: cannot make the folder ({e.strerror})") from None
    writer = family(fam)
    spec = DatasetSpec("bench", 0, n, writer.sampler(), available_formats(), family=writer.name)
    with tempfile.TemporaryDirectory(dir=where or Path.cwd(), prefix=".bench-") as tmp:
        root = Path(tmp) / "bench"
        t0 = time.perf_counter()
        s = generate(root, spec, workers=workers, progress=False)
        first = time.perf_counter() - t0
        t0 = time.perf_counter()
        generate(root, spec, workers=workers, progress=False)
        cached = time.perf_counter() - t0
    done = max(s.generated + len(s.failures), 1)
    step_ms = {k: 1e3 * v / done for k, v in s.step_seconds.items()}
    return {
        "modules": n,
        "workers": workers,
        "failed": len(s.failures),
        "seconds": first,
        "modules_per_s": n / first,
        "cached_rerun_s": cached,
        "family": writer.name,
        "formats": ",".join(spec.formats),
        "step_ms": step_ms,
        "step_ms_total": sum(step_ms.values()),
    }
