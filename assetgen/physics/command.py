"""`assetgen physics`: the MJCF physics checks of a dataset's modules, with their report
(the arguments are assetgen/physics/arguments.py's, shared with `python -m
assetgen.physics.report`)."""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    """`assetgen physics`, beside the code it drives (MuJoCo is imported when checks run)."""
    from assetgen.physics.arguments import add_arguments

    ph = sub.add_parser("physics", help="MJCF physics checks (drop, side pushes) per module")
    add_arguments(ph)
    ph.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from assetgen.core.console_output import print_error
    from assetgen.core.preflight import check_numbers, check_output_file
    from assetgen.dataset.spec import DatasetError, resolve
    from assetgen.physics.arguments import NUMBERS
    from assetgen.physics.report import report

    try:
        check_numbers(args, NUMBERS)
        if args.json is not None:
            check_output_file(args.json, "--json", "physics.json")
        root, _ = resolve(args.dataset)
    except (DatasetError, ValueError) as e:
        return print_error(str(e))
    try:
        return report(root, args.limit, args.json, args.workers, args.timestep)
    except ValueError as e:
        return print_error(str(e))
