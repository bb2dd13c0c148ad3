"""`assetgen sample`: generate modules into a dataset folder, from a spec name or from
--n/--seed/--out, and print the generation's summary."""

from __future__ import annotations

import argparse
from pathlib import Path

from assetgen.core.preflight import Bound, count

NUMBERS = {
    "n": count("ask for at least 1 module"),
    "seed": Bound(low=0, hint="seeds are non-negative integers"),
    "workers": count("give at least 1 process, or leave it out (all cores)"),
    "peg_chamfer_deg": Bound(low=5, high=60, hint="give the chamfer 5 to 60 deg from the sides"),
    "hole_chamfer_deg": Bound(low=5, high=60, hint="give the chamfer 5 to 60 deg from the sides"),
}
"""The bounds of sample's numeric flags (assetgen.core.preflight); --clearance-mm is the
sampler config's clearance, which validates it (finite, positive) before anything is
written. --n has no bound of memory: the generation streams its plan."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    """`assetgen sample`, beside the code it drives."""
    s = sub.add_parser("sample", help="generate modules into a dataset folder")
    s.add_argument("--n", type=int, help="number of modules")
    s.add_argument("--seed", type=int, default=0, help="first module seed (default 0)")
    s.add_argument("--out", help="dataset folder to write")
    s.add_argument("--dataset", help="a spec name from datasets/ (train, test) or a dataset folder")
    s.add_argument(
        "--family",
        default="peg-in-hole",
        help="what to generate: peg-in-hole (Table I, default), profile (non-convex pegs), "
        "multi-peg (2-4 pegs on one carrier) or profile-bolt (a profile into a socket, then a "
        "bolt from the side); `assetgen families`",
    )
    s.add_argument(
        "--clearance-mm",
        type=float,
        help="clearance in mm (default: peg-in-hole 1.0; profile-bolt's profile 0.25)",
    )
    s.add_argument(
        "--print-offset",
        type=float,
        metavar="MM",
        help="move the printed files' (STL, 3MF) hole faces out by MM, your printer's hole error "
        "(`assetgen gauge`); the simulation files keep the exact clearance",
    )
    s.add_argument(
        "--peg-chamfer",
        metavar="MM[,MM]",
        help="chamfer the pegs' tips (peg-in-hole, multi-peg): this long along the axis, or "
        "drawn from LOW,HIGH, in mm; the hole and its clearance stay the unchamfered peg's",
    )
    s.add_argument(
        "--peg-chamfer-deg",
        type=float,
        default=45.0,
        metavar="DEG",
        help="the chamfer's angle from the side faces (default 45)",
    )
    s.add_argument(
        "--hole-chamfer",
        metavar="MM[,MM]",
        help="chamfer the holes' entrances (peg-in-hole, multi-peg): this deep below the "
        "surface, or drawn from LOW,HIGH, in mm; below it the hole keeps the exact clearance",
    )
    s.add_argument(
        "--hole-chamfer-deg",
        type=float,
        default=45.0,
        metavar="DEG",
        help="the entrance chamfer's angle from the hole's side faces (default 45)",
    )
    s.add_argument("--formats", help="comma-separated simulation formats (default: all)")
    s.add_argument("--workers", type=int, default=None, help="processes (default: all cores)")
    s.add_argument("--overwrite", action="store_true", help="replace a dataset of another spec")
    s.add_argument(
        "--ray",
        nargs="?",
        const="",
        metavar="ADDRESS",
        help="run the modules as Ray tasks: on the cluster at ADDRESS (HOST:PORT, "
        "ray://HOST:PORT or auto), or without it on a local Ray instance; --out must be a "
        "folder every node sees (extra [cluster])",
    )
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.table import Table

    from assetgen.core.console_output import print_error
    from assetgen.core.preflight import check_numbers
    from assetgen.dataset.generate import check_formats, generate
    from assetgen.dataset.spec import DatasetError
    from assetgen.params.module_params import ParamError

    try:  # every input before anything is written: flags, spec, formats, the folder
        check_numbers(args, NUMBERS)
        root, spec = sample_spec(args)
        check_formats(spec.formats)
        spec.validate()
        check_writable(root)
        s = generate(
            root,
            spec,
            workers=args.workers,
            overwrite=args.overwrite,
            progress=not args.quiet,
            ray=args.ray,
        )
    except (DatasetError, ParamError, ValueError) as e:
        return print_error(str(e))
    except OSError as e:
        return print_error(
            f"cannot write the dataset: {e}; choose another --out folder or free space"
        )
    console = Console(stderr=False)
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


def sample_spec(args: argparse.Namespace):
    """(dataset folder, DatasetSpec) that `args` ask for; DatasetError for the user."""
    from assetgen.dataset.families import family
    from assetgen.dataset.spec import DatasetError, DatasetSpec, resolve
    from assetgen.formats.registry import available_formats

    if args.dataset:
        if args.out or args.n is not None:
            raise DatasetError("give either --dataset or --n/--seed/--out, not both")
        root, spec = resolve(args.dataset)
        if spec is None:
            from assetgen.dataset.reader import Dataset

            spec = Dataset(root).spec
        return root, _printed(spec, args)
    if args.out is None or args.n is None:
        raise DatasetError("give --n N --out DIR (and optionally --seed S), or --dataset NAME")
    try:
        fam = family(args.family)
    except ValueError as e:
        raise DatasetError(str(e)) from None
    config = fam.sampler()
    if args.clearance_mm is not None:  # the family's first step's clearance
        config = config.with_clearance(args.clearance_mm / 1000.0)
    for part in ("peg", "hole"):
        if getattr(args, f"{part}_chamfer", None) is not None:
            config = _chamfered(config, args, fam.name, part)
    formats = tuple(args.formats.split(",")) if args.formats else available_formats()
    spec = DatasetSpec(
        name=Path(args.out).name,
        seed_start=args.seed,
        count=args.n,
        config=config,
        formats=formats,
        family=fam.name,
    )
    return Path(args.out), _printed(spec, args)


def _chamfered(config, args: argparse.Namespace, name: str, part: str):
    """The sampler config with --{part}-chamfer (mm) and --{part}-chamfer-deg set (part: peg
    or hole); DatasetError for a family without it, or a length that is not one or two
    numbers in mm."""
    import math
    from dataclasses import replace

    from assetgen.dataset.spec import DatasetError

    flag, text = f"--{part}-chamfer", getattr(args, f"{part}_chamfer")
    if not hasattr(config, f"{part}_chamfer"):
        raise DatasetError(
            f"{flag}: the {name} family has no {part} chamfer; peg-in-hole (Table I) has"
        )
    try:
        mm = [float(x) for x in text.split(",")]
    except ValueError:
        mm = []
    if len(mm) == 1:
        mm *= 2
    if len(mm) != 2 or not all(math.isfinite(x) and 0 < x <= 50 for x in mm) or mm[0] > mm[1]:
        raise DatasetError(
            f"{flag} {text}: give a length in mm, or LOW,HIGH with 0 < LOW <= HIGH <= 50 "
            f"(e.g. {flag} 1 or {flag} 0.5,2)"
        )
    angle = math.radians(getattr(args, f"{part}_chamfer_deg"))
    lengths = (mm[0] / 1e3, mm[1] / 1e3)
    return replace(config, **{f"{part}_chamfer": lengths, f"{part}_chamfer_angle": (angle,) * 2})


def _printed(spec, args: argparse.Namespace):
    """The spec with --print-offset (mm) set, where given (DatasetSpec.validate bounds it)."""
    from dataclasses import replace

    offset = getattr(args, "print_offset", None)
    return spec if offset is None else replace(spec, print_offset=offset / 1000.0)


def check_writable(root: Path) -> None:
    """DatasetError when the first existing folder of `root`'s path is not writable."""
    import os

    from assetgen.dataset.spec import DatasetError

    probe = root
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise DatasetError(
            f"cannot write the dataset to {root}: {probe} is a file, not a folder; choose "
            "another --out folder"
        )
    if not os.access(probe, os.W_OK):
        raise DatasetError(f"cannot write to {probe}: choose a folder you can write to (--out)")
