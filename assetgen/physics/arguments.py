"""The arguments of the physics checks' command, declared once for `assetgen physics` and
`python -m assetgen.physics.report` (importing nothing heavy: the CLI builds its parser
without MuJoCo)."""

from __future__ import annotations

import argparse
from pathlib import Path

from assetgen.core.preflight import count, positive

NUMBERS = {
    "limit": count("give at least 1 module"),
    "workers": count("give at least 1 process, or leave it out (all cores)"),
    "timestep": positive("give a positive, finite physics step in seconds"),
}
"""The bounds of the numeric arguments (assetgen.core.preflight)."""


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command's arguments (`assetgen physics` and `python -m assetgen.physics.report`)."""
    ap.add_argument("dataset", help="spec name (test) or dataset folder")
    ap.add_argument("--limit", type=int, default=None, help="first N modules only")
    ap.add_argument("--json", type=Path, default=None, help="write per-module figures here")
    ap.add_argument("--workers", type=int, default=None, help="processes (default: all cores)")
    ap.add_argument("--timestep", type=float, default=None,
                    help="assemblies: a physics step (s) finer than the files'")  # fmt: skip
