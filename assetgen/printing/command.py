"""`assetgen gauge --out DIR`: write the printable clearance gauge (assetgen/printing/gauge.py)
into a new folder, its files checked as every module's."""

from __future__ import annotations

import argparse

from assetgen.core.preflight import positive

NUMBERS = {"diameter_mm": positive("give the pegs' diameter in mm, e.g. 10")}
"""The bounds of gauge's numeric flags (assetgen.core.preflight); --clearances-mm is a list,
which GaugeParams validates."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    g = sub.add_parser("gauge", help="write a printable clearance gauge (holes 0.1-1.0 mm)")
    g.add_argument("--out", required=True, help="folder to write (new, or empty)")
    g.add_argument(
        "--clearances-mm",
        default="0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,1.0",
        help="the holes' clearances, mm, comma-separated (each in (0, 2]; default 0.1 to 1.0)",
    )
    g.add_argument("--diameter-mm", type=float, default=10.0, help="the pegs' diameter, mm")
    g.set_defaults(func=main)


def parse_clearances(text: str) -> tuple[float, ...]:
    """'0.1,0.2' (mm) -> (1e-4, 2e-4) m; ValueError naming the entry that is not a number."""
    out = []
    for item in text.split(","):
        try:
            out.append(float(item) * 1e-3)
        except ValueError:
            raise ValueError(
                f"--clearances-mm: {item.strip()!r} is not a number; give mm, e.g. 0.1,0.2,0.3"
            ) from None
    return tuple(out)


def main(args: argparse.Namespace) -> int:
    import os
    import shutil
    import tempfile
    from dataclasses import replace
    from pathlib import Path

    from rich.console import Console
    from rich.table import Table

    from assetgen.core.console_output import print_error
    from assetgen.core.preflight import check_numbers
    from assetgen.dataset.assembly_writer import write_assembly
    from assetgen.dataset.module_writer import ModuleFailure, module_id
    from assetgen.params.module_params import ParamError
    from assetgen.printing.gauge import GaugeParams, build_gauge, label

    out = Path(args.out)
    try:
        check_numbers(args, NUMBERS)
        if out.exists() and (not out.is_dir() or any(out.iterdir())):
            raise ValueError(f"--out {out}: exists and is not an empty folder; give a new one")
        params = replace(
            GaugeParams(),
            clearances=parse_clearances(args.clearances_mm),
            diameter=args.diameter_mm * 1e-3,
        ).validate()
        assembly = build_gauge(params)
        out.parent.mkdir(parents=True, exist_ok=True)
        # written beside its destination and renamed into place: all of it or nothing
        stage = Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=out.parent))
        try:
            record = write_assembly("gauge", params, assembly, 0, stage)
            if out.exists():
                out.rmdir()
            os.replace(stage / module_id(0), out)
        finally:
            shutil.rmtree(stage, ignore_errors=True)
    except (ParamError, ModuleFailure, ValueError, OSError) as e:
        return print_error(str(e))
    table = Table(title=f"clearance gauge: {out}")
    for column in ("peg", "label (mm)", "measured on the STL (mm)", "insertion (mm)"):
        table.add_column(column)
    for s, c in zip(record["checks"]["steps"], params.clearances, strict=True):
        table.add_row(s["part"], label(c), f"{s['clearance_m'] * 1e3:.5f}",
                      f"{s['insertion_min_distance_m'] * 1e3:.5f}")  # fmt: skip
    Console().print(table)
    print(
        "print base.stl and the peg_*.stl files (or assembly.3mf); the first peg that fits its "
        "hole gives your printer's hole offset"
    )
    return 0
