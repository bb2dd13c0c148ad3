"""`assetgen check`: re-verify a dataset's files and checks, and with --repair regenerate
the modules that are missing, corrupt or stale."""

from __future__ import annotations

import argparse

from assetgen.core.preflight import count

NUMBERS = {"workers": count("give at least 1 process, or leave it out (all cores)")}
"""The bounds of check's numeric flags (assetgen.core.preflight)."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    """`assetgen check`, beside the code it drives."""
    c = sub.add_parser("check", help="re-verify a dataset's files and checks")
    c.add_argument("dataset", help="spec name (train, test) or dataset folder")
    c.add_argument("--repair", action="store_true", help="regenerate missing/corrupt/stale")
    c.add_argument("--hashes-only", action="store_true", help="skip re-running the geometry checks")
    c.add_argument("--workers", type=int, default=None)
    c.add_argument("--quiet", action="store_true")
    c.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.table import Table

    from assetgen.core.console_output import print_error
    from assetgen.core.preflight import check_numbers
    from assetgen.dataset.check import check_dataset, repair
    from assetgen.dataset.spec import DatasetError, resolve

    try:
        check_numbers(args, NUMBERS)
        root, _ = resolve(args.dataset)
        report = check_dataset(root, geometry_checks=not args.hashes_only)
    except (DatasetError, ValueError) as e:
        return print_error(str(e))
    console = Console(stderr=False)
    table = Table(title=f"check {root}", show_header=False)
    table.add_row("modules checked", str(report.checked))
    table.add_row("missing", str(len(report.missing)))
    table.add_row("corrupt", str(len(report.corrupt)))
    table.add_row("stale", str(len(report.stale)))
    table.add_row("manifest", report.manifest_error or "ok")
    table.add_row("dataset.json", report.spec_error or "ok")
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
    try:
        s = repair(root, report, workers=args.workers, progress=not args.quiet)
    except (DatasetError, ValueError) as e:  # a spec it cannot regenerate (unknown formats)
        return print_error(str(e))
    console.print(f"repaired {s.generated} module(s); {len(s.failures)} failed")
    return 1 if s.failures else 0
