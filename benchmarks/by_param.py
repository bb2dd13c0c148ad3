"""Success by module parameter: which of Table I's parameters the failures of an evaluation
gather on.

    python -m benchmarks.by_param EVAL.json [--dataset FOLDER] [--param n_vertices ...]

EVAL.json is an `assetgen eval --out` file (its per-module success rates); the modules'
parameters come from the dataset's manifest (the folder the evaluation names, or
--dataset). Each parameter's modules are split into quartiles (a parameter with at most
eight values, such as n_vertices: one group a value, so that triangles are not pooled with
squares), and each group's mean success is printed. `hole_tilt`
is derived: the hole axis' angle from the vertical, hypot(hole_tilt_x, hole_tilt_y) rad.
A policy that is short of its target shows here where: for instance, pegs with few
vertices need their yaw within a few degrees, round ones do not.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

QUARTILES = (0.25, 0.5, 0.75)
BY_VALUE = 8
"""A parameter with at most this many distinct values is grouped by value."""


def module_params(dataset: str | Path) -> dict[str, dict[str, float]]:
    """Module id -> its numeric parameters, with the derived hole_tilt."""
    from assetgen.dataset.reader import Dataset

    out = {}
    for mid, rec in Dataset(dataset).records.items():
        p = {k: float(v) for k, v in rec["params"].items() if isinstance(v, int | float)}
        if "hole_tilt_x" in p and "hole_tilt_y" in p:
            p["hole_tilt"] = math.hypot(p["hole_tilt_x"], p["hole_tilt_y"])
        out[mid] = p
    return out


def groups(values: np.ndarray) -> list[tuple[float, float, np.ndarray]]:
    """(low, high, mask) of each group: one per value when there are at most BY_VALUE
    values, else the quartiles (each bound inclusive of its upper edge)."""
    distinct = np.unique(values)
    if len(distinct) <= BY_VALUE:
        return [(v, v, values == v) for v in distinct]
    edges = [values.min(), *np.quantile(values, QUARTILES), values.max()]
    out = []
    for i in range(len(edges) - 1):
        lo, hi = edges[i], edges[i + 1]
        mask = (values >= lo) & (values <= hi) if i == 0 else (values > lo) & (values <= hi)
        if mask.any():
            out.append((float(lo), float(hi), mask))
    return out


def by_param(
    per_module: dict[str, float], params: dict[str, dict[str, float]], names: list[str] | None
) -> dict[str, list[dict[str, float]]]:
    """{parameter: [{low, high, modules, success}, ...]} over the evaluated modules."""
    ids = sorted(per_module)
    missing = [m for m in ids if m not in params]
    if missing:
        raise ValueError(
            f"modules {missing[:3]} of the evaluation are not in the dataset: give the "
            "dataset it was evaluated on (--dataset)"
        )
    success = np.array([per_module[m] for m in ids])
    known = sorted(set.intersection(*(set(params[m]) for m in ids)))
    for n in names or []:
        if n not in known:
            raise ValueError(f"--param {n!r}: the modules' parameters are {known}")
    out = {}
    for name in names or known:
        values = np.array([params[m][name] for m in ids])
        if np.ptp(values) == 0:
            continue  # one value for every module: nothing to split
        out[name] = [
            {
                "low": lo,
                "high": hi,
                "modules": int(mask.sum()),
                "success": float(success[mask].mean()),
            }
            for lo, hi, mask in groups(values)
        ]
    return out


def spread(rows: list[dict[str, float]]) -> float:
    """The gap between the best and the worst group's success: how much the parameter
    matters to this policy."""
    s = [r["success"] for r in rows]
    return max(s) - min(s)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("eval", type=Path, help="an `assetgen eval --out` file")
    ap.add_argument("--dataset", help="the dataset evaluated (default: the file's)")
    ap.add_argument("--param", action="append", help="only these parameters (repeatable)")
    args = ap.parse_args(argv)
    try:
        doc = json.loads(args.eval.read_text())
        per_module = doc["per_module"]
    except (OSError, json.JSONDecodeError, KeyError) as e:
        ap.error(f"{args.eval}: not an evaluation file with per-module success ({e})")
    dataset = args.dataset or doc.get("dataset_folder") or doc["dataset"]
    try:
        table = by_param(per_module, module_params(dataset), args.param)
    except ValueError as e:
        ap.error(str(e))
    mean = float(np.mean(list(per_module.values())))
    print(f"{args.eval}: {len(per_module)} modules, success {100 * mean:.1f} %")
    print("parameters by the spread of their groups' success, largest first:")
    for name, rows in sorted(table.items(), key=lambda kv: -spread(kv[1])):
        cells = "  ".join(
            f"[{r['low']:.3g}, {r['high']:.3g}] {100 * r['success']:5.1f} % ({r['modules']})"
            for r in rows
        )
        print(f"  {name:20s} {cells}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
