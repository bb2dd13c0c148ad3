"""CLI wiring for `assetgen view` (kept import-light: viser loads only when the command runs).

    assetgen view DATASET [--module ID] [--episode FILE] [--host H] [--port P] [--html OUT]

In cli.py:
    v = sub.add_parser("view", help="browser preview of modules and episodes (viser)")
    from preview.command import add_arguments, view_main
    add_arguments(v)
    v.set_defaults(func=view_main)
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Arguments of `assetgen view`."""
    p.add_argument("dataset", help="spec name (train, test) or dataset folder")
    p.add_argument("--module", help="module id to show first (e.g. 000003 or 3)")
    p.add_argument("--episode", type=Path, help="recorded episode (.npz) to replay")
    p.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1; others expose an unauthenticated viewer)",
    )
    p.add_argument("--port", type=int, default=None, help="port (default: a free one)")
    p.add_argument(
        "--html",
        type=Path,
        default=None,
        help="write a self-contained HTML snapshot to this file and exit (no server)",
    )


def view_main(args: argparse.Namespace) -> int:
    """Run `assetgen view`: the live viewer until Ctrl-C, or `--html` a snapshot. Returns the
    exit status: 2 for a dataset that cannot be read or a host it cannot listen on (the live
    viewer reports bad data found later, e.g. a corrupt module, in the page and keeps
    running)."""
    from rich.console import Console
    from rich.markup import escape

    err = Console(stderr=True)
    if args.html is not None:
        from preview.scene import PreviewError
        from preview.snapshot import write_html

        try:
            path = write_html(args.dataset, args.html, module=args.module, episode=args.episode)
        except PreviewError as e:
            err.print(f"[bold red]error:[/] {escape(str(e))}", highlight=False, soft_wrap=True)
            return 2
        size = path.stat().st_size / 1e6
        print(f"wrote {path} ({size:.1f} MB): opens in a browser without a server")
        return 0
    from preview.scene import PreviewError, open_dataset
    from preview.server import serve

    try:
        open_dataset(args.dataset)  # a dataset that cannot be read is an error before any server
        handle = serve(
            args.dataset,
            module=args.module,
            episode=args.episode,
            host=args.host,
            port=args.port,
            console=err,
        )
    except PreviewError as e:  # no such dataset, or a host it cannot listen on
        err.print(f"[bold red]error:[/] {escape(str(e))}", highlight=False, soft_wrap=True)
        return 2
    handle.wait()
    return 0
