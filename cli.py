"""The `assetgen` command: parses arguments, calls the packages, prints results."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from rich.console import Console
from rich.table import Table

console = Console(stderr=False)


def _err(msg: str) -> int:
    Console(stderr=True).print(f"[bold red]error:[/] {msg}", highlight=False)
    return 2


# ----------------------------------------------------------------------------- sample


def _sample_spec(args: argparse.Namespace):
    from assetgen.dataset import DatasetError, DatasetSpec, resolve
    from assetgen.exporters import available_formats
    from assetgen.sampler import SamplerConfig

    if args.dataset:
        if args.out or args.n is not None:
            raise DatasetError("give either --dataset or --n/--seed/--out, not both")
        root, spec = resolve(args.dataset)
        if spec is None:
            from assetgen.dataset import Dataset

            spec = Dataset(root).spec
        return root, spec
    if args.out is None or args.n is None:
        raise DatasetError("give --n N --out DIR (and optionally --seed S), or --dataset NAME")
    if args.n < 1:
        raise DatasetError(f"--n {args.n}: ask for at least 1 module")
    if args.seed < 0:
        raise DatasetError(f"--seed {args.seed}: seeds are non-negative integers")
    config = SamplerConfig()
    if args.clearance_mm is not None:
        config = replace(config, clearance=args.clearance_mm / 1000.0)
    formats = tuple(args.formats.split(",")) if args.formats else available_formats()
    spec = DatasetSpec(
        name=Path(args.out).name, seed_start=args.seed, count=args.n, config=config, formats=formats
    )
    return Path(args.out), spec


def cmd_sample(args: argparse.Namespace) -> int:
    from assetgen.dataset import DatasetError, generate
    from assetgen.params import ParamError

    try:
        root, spec = _sample_spec(args)
        _check_writable(root)
        s = generate(
            root, spec, workers=args.workers, overwrite=args.overwrite, progress=not args.quiet
        )
    except (DatasetError, ParamError, ValueError) as e:
        return _err(str(e))
    table = Table(title=f"dataset {root}", show_header=False)
    rate = s.generated / s.seconds if s.seconds > 0 else float("nan")
    for k, v in (
        ("modules", s.total),
        ("generated", s.generated),
        ("cached", s.cached),
        ("failed", len(s.failures)),
        ("clearance min", f"{s.clearance_min_m * 1e3:.6f} mm"),
        ("clearance max", f"{s.clearance_max_m * 1e3:.6f} mm"),
        ("time", f"{s.seconds:.2f} s"),
        ("modules/s", f"{rate:.1f}"),
        ("content hash", s.content_hash[:16]),
    ):
        table.add_row(k, str(v))
    console.print(table)
    for f in s.failures:
        console.print(f"[red]failed[/] seed {f.seed}: {f.reason}", highlight=False)
    return 1 if s.failures else 0


def _check_writable(root: Path) -> None:
    from assetgen.dataset import DatasetError

    probe = root
    while not probe.exists():
        probe = probe.parent
    import os

    if not os.access(probe, os.W_OK):
        raise DatasetError(f"cannot write to {probe}: choose a folder you can write to (--out)")


# ----------------------------------------------------------------------------- main


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="assetgen", description="Procedural peg-in-hole modules, simulation and learning."
    )
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("sample", help="generate modules into a dataset folder")
    s.add_argument("--n", type=int, help="number of modules")
    s.add_argument("--seed", type=int, default=0, help="first module seed (default 0)")
    s.add_argument("--out", help="dataset folder to write")
    s.add_argument("--dataset", help="a spec name from datasets/ (train, test) or a dataset folder")
    s.add_argument("--clearance-mm", type=float, help="clearance in mm (default 1.0)")
    s.add_argument("--formats", help="comma-separated simulation formats (default: all)")
    s.add_argument("--workers", type=int, default=None, help="processes (default: all cores)")
    s.add_argument("--overwrite", action="store_true", help="replace a dataset of another spec")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=cmd_sample)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
