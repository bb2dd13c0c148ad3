"""What a command prints for the user: a one-line error, and a table of figures (with JSON
last on request). Shared by the commands of every package so they read alike."""

from __future__ import annotations

import json
from typing import Any


def print_error(message: str) -> int:
    """Print `error: message` on stderr, one line for the user; exit code 2."""
    from rich.console import Console
    from rich.markup import escape

    err = Console(stderr=True)
    err.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    return 2


def print_figures(title: str, result: dict[str, Any], as_json: bool = False) -> None:
    """The scalar figures of `result` as a two-column table; its `step_ms` dict (a per-step
    breakdown) as a second table; with `as_json`, the whole result as one JSON line last."""
    from rich.console import Console
    from rich.table import Table

    console = Console(stderr=False)
    table = Table(title=title, show_header=False)
    for k, v in result.items():
        if not isinstance(v, dict):
            table.add_row(k, f"{v:.4g}" if isinstance(v, float) else str(v))
    console.print(table)
    steps = result.get("step_ms", {})
    if steps:
        t = Table(title="per module, each step (ms, one worker's wall time)")
        t.add_column("step")
        t.add_column("ms", justify="right")
        for k, v in steps.items():
            t.add_row(k, f"{v:.2f}")
        console.print(t)
    if as_json:
        print(json.dumps(result))
