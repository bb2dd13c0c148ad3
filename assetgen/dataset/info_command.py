"""`assetgen info`: a dataset's parameter distributions (min, median, max in the units a
person reads), its cross-section vertex counts and its measured clearances."""

from __future__ import annotations

import argparse

UNITS = {
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
"""Parameter -> (unit shown, factor from the stored SI value); others are shown as stored."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    """`assetgen info`, beside the code it drives."""
    i = sub.add_parser("info", help="summary of a dataset's parameter distributions")
    i.add_argument("dataset", help="spec name or dataset folder")
    i.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    import numpy as np
    from rich.console import Console
    from rich.table import Table

    from assetgen.core.console_output import print_error
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import DatasetError, resolve

    try:
        ds = Dataset(resolve(args.dataset)[0])
    except DatasetError as e:
        return print_error(str(e))
    if not len(ds):
        return print_error(f"{ds.root} holds no finished modules yet; run `assetgen sample` first")
    console = Console(stderr=False)
    params = [r["params"] for r in ds.records.values()]
    table = Table(title=f"{ds.root}: {len(ds)} modules, spec {ds.spec.name!r}")
    for col in ("parameter", "unit", "min", "median", "max"):
        table.add_column(col)
    for key in params[0]:
        v = np.array([p[key] for p in params], float)
        unit, scale = UNITS.get(key, ("", 1.0))
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
