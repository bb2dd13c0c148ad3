"""The `assetgen` command: parses arguments, calls the packages, prints results."""

from __future__ import annotations

import argparse
import functools
import sys
from dataclasses import replace
from pathlib import Path

from rich.console import Console
from rich.table import Table

console = Console(stderr=False)

EXPERT_NAMES = ("scripted", "scripted-fast", "scripted-direct")
"""The built-in scripted experts (`--agent`, `--demos`): the keys of sim.task.expert.EXPERTS,
named here so that building the parser imports no simulator."""


def _err(msg: str) -> int:
    from rich.markup import escape

    err = Console(stderr=True)
    err.print(f"[bold red]error:[/] {escape(msg)}", highlight=False, soft_wrap=True)
    return 2


# ----------------------------------------------------------------------------- sample


def _sample_spec(args: argparse.Namespace):
    from assetgen.dataset.families import family
    from assetgen.dataset.spec import DatasetError, DatasetSpec, resolve
    from assetgen.formats.registry import available_formats
    from assetgen.params.sampler import SamplerConfig

    if args.dataset:
        if args.out or args.n is not None:
            raise DatasetError("give either --dataset or --n/--seed/--out, not both")
        root, spec = resolve(args.dataset)
        if spec is None:
            from assetgen.dataset.reader import Dataset

            spec = Dataset(root).spec
        return root, spec
    if args.out is None or args.n is None:
        raise DatasetError("give --n N --out DIR (and optionally --seed S), or --dataset NAME")
    if args.n < 1:
        raise DatasetError(f"--n {args.n}: ask for at least 1 module")
    if args.seed < 0:
        raise DatasetError(f"--seed {args.seed}: seeds are non-negative integers")
    try:
        fam = family(args.family)
    except ValueError as e:
        raise DatasetError(str(e)) from None
    config = fam.sampler()
    if args.clearance_mm is not None:
        # the clearance of the family's first step (Table I's only one; the profile's)
        key = "clearance" if isinstance(config, SamplerConfig) else "profile_clearance"
        config = replace(config, **{key: args.clearance_mm / 1000.0})
    formats = tuple(args.formats.split(",")) if args.formats else available_formats()
    spec = DatasetSpec(
        name=Path(args.out).name,
        seed_start=args.seed,
        count=args.n,
        config=config,
        formats=formats,
        family=fam.name,
    )
    return Path(args.out), spec


def cmd_sample(args: argparse.Namespace) -> int:
    from assetgen.dataset.generate import generate
    from assetgen.dataset.spec import DatasetError
    from assetgen.params.module_params import ParamError

    try:
        root, spec = _sample_spec(args)
        _check_writable(root)
        s = generate(
            root,
            spec,
            workers=args.workers,
            overwrite=args.overwrite,
            progress=not args.quiet,
            ray=args.ray,
        )
    except (DatasetError, ParamError, ValueError) as e:
        return _err(str(e))
    except OSError as e:
        return _err(f"cannot write the dataset: {e}; choose another --out folder or free space")
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
    from assetgen.dataset.spec import DatasetError

    probe = root
    while not probe.exists():
        probe = probe.parent
    import os

    if not os.access(probe, os.W_OK):
        raise DatasetError(f"cannot write to {probe}: choose a folder you can write to (--out)")


def _open_dataset(name: str):
    from assetgen.dataset.spec import resolve

    root, _ = resolve(name)
    return root


def _physics_arguments(ap: argparse.ArgumentParser) -> None:
    # declared once, in the physics stage (which imports MuJoCo only when checks run)
    from assetgen.physics.arguments import add_arguments

    add_arguments(ap)


def cmd_physics(args: argparse.Namespace) -> int:
    from assetgen.dataset.spec import DatasetError, resolve
    from assetgen.physics.report import report

    try:
        root, _ = resolve(args.dataset)
    except DatasetError as e:
        return _err(str(e))
    try:
        return report(root, args.limit, args.json, args.workers, args.timestep)
    except ValueError as e:
        return _err(str(e))


def cmd_check(args: argparse.Namespace) -> int:
    from assetgen.dataset.check import check_dataset, repair
    from assetgen.dataset.spec import DatasetError

    try:
        root = _open_dataset(args.dataset)
        report = check_dataset(root, geometry_checks=not args.hashes_only)
    except DatasetError as e:
        return _err(str(e))
    table = Table(title=f"check {root}", show_header=False)
    table.add_row("modules checked", str(report.checked))
    table.add_row("missing", str(len(report.missing)))
    table.add_row("corrupt", str(len(report.corrupt)))
    table.add_row("stale", str(len(report.stale)))
    table.add_row("manifest", report.manifest_error or "ok")
    console.print(table)
    for mid in report.missing[:20]:
        console.print(f"[yellow]missing[/] {mid}", highlight=False)
    for mid, why in list(report.corrupt.items())[:20]:
        console.print(f"[red]corrupt[/] {mid}: {why}", highlight=False)
    for mid in report.stale[:20]:
        console.print(f"[yellow]stale[/] {mid}: made by another generator version", highlight=False)
    if report.ok:
        return 0
    if not args.repair:
        console.print("run `assetgen check DATASET --repair` to regenerate just these modules")
        return 1
    s = repair(root, report, workers=args.workers, progress=not args.quiet)
    console.print(f"repaired {s.generated} module(s); {len(s.failures)} failed")
    return 1 if s.failures else 0


def cmd_info(args: argparse.Namespace) -> int:
    import numpy as np

    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import DatasetError

    try:
        ds = Dataset(_open_dataset(args.dataset))
    except DatasetError as e:
        return _err(str(e))
    if not len(ds):
        return _err(f"{ds.root} holds no finished modules yet; run `assetgen sample` first")
    params = [r["params"] for r in ds.records.values()]
    table = Table(title=f"{ds.root}: {len(ds)} modules, spec {ds.spec.name!r}")
    for col in ("parameter", "unit", "min", "median", "max"):
        table.add_column(col)
    units = {
        "circumradius": ("mm", 1e3),
        "peg_height": ("mm", 1e3),
        "hole_x": ("mm", 1e3),
        "hole_y": ("mm", 1e3),
        "clearance": ("mm", 1e3),
        "hole_tilt_x": ("deg", 57.29578),
        "hole_tilt_y": ("deg", 57.29578),
        "hole_yaw": ("deg", 57.29578),
        "squash_angle": ("deg", 57.29578),
    }
    for key in params[0]:
        v = np.array([p[key] for p in params], float)
        unit, scale = units.get(key, ("", 1.0))
        v = v * scale
        table.add_row(key, unit, f"{v.min():.3g}", f"{np.median(v):.3g}", f"{v.max():.3g}")
    console.print(table)
    counts = {}
    for p in params:
        counts[p["n_vertices"]] = counts.get(p["n_vertices"], 0) + 1
    console.print(
        "cross-section vertices: " + ", ".join(f"{k}: {counts[k]}" for k in sorted(counts)),
        highlight=False,
    )
    gaps = np.array([r["checks"]["clearance_m"] for r in ds.records.values()]) * 1e3
    console.print(f"measured clearance: {gaps.min():.6f} - {gaps.max():.6f} mm", highlight=False)
    return 0


# ----------------------------------------------------------------------------- main


def build_parser() -> argparse.ArgumentParser:
    from assetgen.bench import add_parser as add_assets_bench
    from assetgen.families.command import add_parser as add_families_parser
    from sim.bench.command import add_parsers as add_sim_benches
    from sim.engines.registry import add_engine_argument

    p = argparse.ArgumentParser(
        prog="assetgen", description="Procedural peg-in-hole modules, simulation and learning."
    )
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("sample", help="generate modules into a dataset folder")
    s.add_argument("--n", type=int, help="number of modules")
    s.add_argument("--seed", type=int, default=0, help="first module seed (default 0)")
    s.add_argument("--out", help="dataset folder to write")
    s.add_argument("--dataset", help="a spec name from datasets/ (train, test) or a dataset folder")
    s.add_argument(
        "--family",
        default="peg-in-hole",
        help="what to generate: peg-in-hole (Table I, default) or profile-bolt (a profile "
        "into a socket, then a bolt from the side)",
    )
    s.add_argument(
        "--clearance-mm",
        type=float,
        help="clearance in mm (default: peg-in-hole 1.0; profile-bolt's profile 0.25)",
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
    s.set_defaults(func=cmd_sample)

    c = sub.add_parser("check", help="re-verify a dataset's files and checks")
    c.add_argument("dataset", help="spec name (train, test) or dataset folder")
    c.add_argument("--repair", action="store_true", help="regenerate missing/corrupt/stale")
    c.add_argument("--hashes-only", action="store_true", help="skip re-running the geometry checks")
    c.add_argument("--workers", type=int, default=None)
    c.add_argument("--quiet", action="store_true")
    c.set_defaults(func=cmd_check)

    ph = sub.add_parser("physics", help="MJCF physics checks (drop, side pushes) per module")
    _physics_arguments(ph)
    ph.set_defaults(func=cmd_physics)

    i = sub.add_parser("info", help="summary of a dataset's parameter distributions")
    i.add_argument("dataset", help="spec name or dataset folder")
    i.set_defaults(func=cmd_info)

    add_families_parser(sub)

    b = sub.add_parser("bench", help="benchmarks (figures printed; --json for one JSON line)")
    targets = b.add_subparsers(dest="what", required=True, metavar="{assets,sim,load,contacts}")
    add_assets_bench(targets)
    add_sim_benches(targets)

    from evaluation.command import add_arguments as add_eval_arguments
    from evaluation.command import main as eval_command

    e = sub.add_parser("eval", help="the paper's protocol: every module, K attempts, noise on")
    add_eval_arguments(e, EXPERT_NAMES)
    e.set_defaults(func=eval_command)

    from preview.command import add_arguments, view_main

    v = sub.add_parser("view", help="browser preview of modules and episodes (viser)")
    add_arguments(v)
    v.set_defaults(func=view_main)

    # torch (the `rl` extra) is imported when `train` or `report` runs, not here: it would
    # add over a second to every command
    from rl.commands import add_export_parser, add_report_parser, add_train_parser

    add_train_parser(sub, _train_env, TEACHERS, _probe, add_engine_argument)
    add_report_parser(sub)
    add_export_parser(sub)
    return p


def _train_env(*args, engine: str | None = None, **kwargs):
    # the simulator (MuJoCo, with its GL bindings: ~0.3 s) is imported when a command uses
    # it, not by every command's parser: `assetgen sample` is timed whole
    from sim.engines.registry import train_env_factory

    return train_env_factory(engine)(*args, **kwargs)


def _probe(*args, **kwargs):
    # evaluation (with torch and the simulator) is imported when `train --probe-steps` runs
    from evaluation.probe import dataset_probe

    return dataset_probe(*args, **kwargs)


def _expert(name: str):
    from sim.task.expert import EXPERTS

    return EXPERTS[name]


TEACHERS = {name: functools.partial(_expert, name) for name in EXPERT_NAMES}
"""`assetgen train --demos NAME`: the teachers an agent can learn from."""


EXTRAS: dict[str, tuple[str, ...]] = {
    "scipy": ("cad", "physx"),
    "manifold3d": ("cad", "view"),
    "trimesh": ("cad", "view"),
    "fcl": ("cad",),
    "coacd": ("cad",),
    "pxr": ("cad", "physx"),
    "sapien": ("physx",),
    "warp": ("warp",),
    "mujoco_warp": ("warp",),
    "torch": ("rl",),
    "safetensors": ("rl",),
    "gymnasium": ("rl",),
    "tensorboard": ("rl",),
    "matplotlib": ("rl",),
    "viser": ("view",),
}
"""Top-level module -> the extras of pyproject.toml that install it."""
COMMAND_EXTRA = {"view": "view", "train": "rl", "report": "rl", "eval": "rl", "export": "rl"}
"""The extra to name first for a command, where a module comes with several."""


def missing_extra_message(command: str, module: str, engine: str | None = None) -> str | None:
    """The one-line advice for a missing optional library (None: not an optional one);
    `engine`: the command's --sim, whose extra is named first."""
    from sim.engines.registry import ENGINES

    top = module.split(".")[0]
    extras = EXTRAS.get(top)
    if extras is None:
        return None
    spec = ENGINES.get(engine or "")
    first = spec.extra if spec is not None and spec.extra in extras else None
    first = first or COMMAND_EXTRA.get(command)
    extra = first if first in extras else extras[0]
    return (
        f"`assetgen {command}` needs the Python package {top!r}, which comes with the "
        f'[{extra}] extra: pip install "peg-in-hole-assetgen[{extra}]" (in a checkout: '
        f'pip install -e ".[{extra}]")'
    )


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if hasattr(args, "sim"):
            from sim.engines.registry import check_device

            try:  # before any env is built: an engine for a GPU would run on the CPU
                check_device(args)
            except ValueError as e:
                return _err(str(e))
        return args.func(args)
    except ModuleNotFoundError as e:
        message = missing_extra_message(args.command, e.name or "", getattr(args, "sim", None))
        if message is None:
            raise
        return _err(message)


if __name__ == "__main__":
    sys.exit(main())
