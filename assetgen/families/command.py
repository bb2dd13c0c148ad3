"""`assetgen families`: the registered families and their parameters, as one table or JSON."""

from __future__ import annotations

import argparse
import json


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("families", help="the families `sample --family` takes, with parameters")
    p.add_argument("--json", action="store_true", help="print one JSON list instead of the table")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    from assetgen.families.registry import describe

    families = describe()
    if args.json:
        print(json.dumps(families))
        return 0
    table = Table(title="families (assetgen sample --family NAME)")
    for column in ("family / parameter", "default", "meaning"):
        table.add_column(column, no_wrap=column != "meaning")
    for f in families:
        table.add_row(f"[bold]{f['name']}[/]", "", escape(f"{f['summary']} ({f['layout']})"))
        for q in f["parameters"]:
            d = q["default"]
            shown = ", ".join(map(_shown, d)) if isinstance(d, list) else _shown(d)
            table.add_row(f"  {q['name']}", shown, escape(q["doc"]))
    Console().print(table)
    return 0


def _shown(value: object) -> str:
    """A default as the table shows it: numbers to 6 significant digits, names as they are."""
    return f"{value:.6g}" if isinstance(value, int | float) else str(value)
