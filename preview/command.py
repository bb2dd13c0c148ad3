"""`assetgen view`, beside the viewer it runs (kept import-light: viser loads only when the
command runs).

    assetgen view DATASET [--module ID] [--episode FILE] [--host H] [--port P] [--html OUT]
                          [--policy RUN_OR_POLICY_DIR [--record DIR]] [--robot panda]

cli.py calls `add_parser(subparsers)`, which declares the flags (`add_arguments`) and sets
`view_main` as the handler.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from assetgen.core.preflight import Bound

NUMBERS = {"port": Bound(low=0, high=65535, hint="give a port from 1 to 65535, or 0 (a free one)")}
"""The bounds of view's numeric flags (assetgen.core.preflight)."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    """`assetgen view`, beside the code it drives."""
    v = sub.add_parser("view", help="browser preview of modules and episodes (viser)")
    add_arguments(v)
    v.set_defaults(func=view_main)


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
    p.add_argument(
        "--policy",
        type=Path,
        default=None,
        help="training run or exported policy folder (holds checkpoint.safetensors): run it "
        "live on the shown module (needs the [rl] extra)",
    )
    from sim.robots.registry import robot_names

    p.add_argument(
        "--robot",
        choices=robot_names(),
        default=None,
        help="show a robot holding the peg (its links posed to the peg's pose; a live "
        "--policy runs through it); needs the [robot] extra",
    )
    p.add_argument(
        "--record",
        type=Path,
        default=None,
        help="with --policy: folder for the live episodes (.npz, replayable with Load episode; "
        "default: a new temporary folder, printed at start)",
    )


def view_main(args: argparse.Namespace) -> int:
    """Run `assetgen view`: the live viewer until Ctrl-C, or `--html` a snapshot. Returns the
    exit status: 2 for a dataset that cannot be read, a host it cannot listen on, or a
    --policy without a checkpoint or one that does not fit the task (the live viewer reports
    bad data found later, e.g. a corrupt module or NaN actions, in the page and keeps
    running)."""
    from rich.console import Console

    from assetgen.core.console_output import print_error
    from assetgen.core.preflight import (
        PreflightError,
        check_numbers,
        check_output_file,
        check_output_folder,
    )

    err = Console(stderr=True)  # the live viewer's messages

    policy = getattr(args, "policy", None)  # absent when a caller builds args by hand
    record = getattr(args, "record", None)
    if policy is not None and args.html is not None:
        return print_error("--policy runs in the live viewer; drop --html (a snapshot cannot step)")
    if record is not None and policy is None:
        return print_error("--record DIR records the live runs of --policy; give --policy RUN too")
    try:  # before the dataset is read or a server started
        check_numbers(args, NUMBERS)
        if args.html is not None:
            check_output_file(args.html, "--html", "snapshot.html")
        if record is not None:
            check_output_folder(record, "--record")
    except PreflightError as e:
        return print_error(str(e))
    if policy is not None:
        from preview.live import find_checkpoint
        from preview.scene import PreviewError

        try:
            find_checkpoint(policy)  # before loading torch: a wrong path is told at once
        except PreviewError as e:
            return print_error(str(e))
    if args.html is not None:
        from preview.scene import PreviewError
        from preview.snapshot import write_html

        try:
            path = write_html(args.dataset, args.html, module=args.module, episode=args.episode,
                              robot=getattr(args, "robot", None))  # fmt: skip
        except PreviewError as e:
            return print_error(str(e))
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
            policy=policy,
            record=record,
            robot=getattr(args, "robot", None),
        )
    except PreviewError as e:  # no such dataset, a host it cannot listen on, a bad policy
        return print_error(str(e))
    handle.wait()
    return 0
