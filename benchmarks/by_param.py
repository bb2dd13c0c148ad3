"""Success by module parameter: which of Table I's parameters the failures of an evaluation
gather on.

    python -m benchmarks.by_param EVAL.json [EVAL.json ...] [--dataset FOLDER]
        [--param n_vertices ...] [--where n_vertices=3] [--where taper=0:0.05]

EVAL.json is an `assetgen eval --out` file (its per-module success rates); several (a row's
seeds) are pooled, each module's success the mean over the files. The modules' parameters
come from the dataset's manifest (the folder the evaluation names, or --dataset). `--where
NAME=VALUE` or `NAME=LOW:HIGH` (bounds included) keeps the modules whose parameter matches,
so that a weak family can be split further (the triangles by their taper, say). Each
parameter's modules are split into quartiles (a parameter with at most eight values, such as
n_vertices: one group a value, so that triangles are not pooled with squares), and each
group's mean success is printed. `hole_tilt` is derived: the hole axis' angle from the
vertical, hypot(hole_tilt_x, hole_tilt_y) rad. A policy that is short of its target shows
here where: for instance, pegs with few vertices need their yaw within a few degrees, round
ones do not.
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


def parse_where(items: list[str], known: set[str]) -> list[tuple[str, float, float]]:
    """`NAME=VALUE` or `NAME=LOW:HIGH` filters as (name, low, high), bounds included."""
    out = []
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or name not in known:
            raise ValueError(
                f"--where {item!r}: give NAME=VALUE or NAME=LOW:HIGH with NAME one of the "
                f"modules' parameters {sorted(known)}"
            )
        try:
            lo, _, hi = value.partition(":")
            bounds = (float(lo), float(hi or lo))
        except ValueError:
            raise ValueError(f"--where {item!r}: {value!r} is not a number or LOW:HIGH") from None
        if bounds[0] > bounds[1]:
            raise ValueError(f"--where {item!r}: LOW is above HIGH")
        out.append((name, *bounds))
    return out


def select(
    per_module: dict[str, float],
    params: dict[str, dict[str, float]],
    where: list[tuple[str, float, float]],
) -> dict[str, float]:
    """The modules of `per_module` whose parameters lie in every (name, low, high) range."""
    return {
        m: v
        for m, v in per_module.items()
        if m in params and all(lo <= params[m].get(n, math.nan) <= hi for n, lo, hi in where)
    }


def pooled(docs: list[dict], names: list[str]) -> dict[str, float]:
    """Each module's success, the mean over evaluation files of the same modules."""
    first = set(docs[0]["per_module"])
    for doc, name in zip(docs[1:], names[1:], strict=True):
        if set(doc["per_module"]) != first:
            raise ValueError(
                f"{name}: other modules than {names[0]}: pool evaluations of one dataset"
            )
    return {m: float(np.mean([d["per_module"][m] for d in docs])) for m in sorted(first)}


def spread(rows: list[dict[str, float]]) -> float:
    """The gap between the best and the worst group's success: how much the parameter
    matters to this policy."""
    s = [r["success"] for r in rows]
    return max(s) - min(s)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "eval", type=Path, nargs="+", help="`assetgen eval --out` files (several: pooled)"
    )
    ap.add_argument("--dataset", help="the dataset evaluated (default: the file's)")
    ap.add_argument("--param", action="append", help="only these parameters (repeatable)")
    ap.add_argument(
        "--where",
        action="append",
        default=[],
        metavar="NAME=VALUE|NAME=LOW:HIGH",
        help="only the modules whose parameter matches (repeatable; bounds included)",
    )
    args = ap.parse_args(argv)
    docs = []
    for path in args.eval:
        try:
            doc = json.loads(path.read_text())
            if not isinstance(doc["per_module"], dict):
                raise KeyError("per_module")
        except (OSError, json.JSONDecodeError, KeyError) as e:
            ap.error(f"{path}: not an evaluation file with per-module success ({e})")
        docs.append(doc)
    dataset = args.dataset or docs[0].get("dataset_folder") or docs[0]["dataset"]
    try:
        per_module = pooled(docs, [str(p) for p in args.eval])
        params = module_params(dataset)
        known = set.intersection(*(set(p) for p in params.values()))
        per_module = select(per_module, params, parse_where(args.where, known))
        if not per_module:
            raise ValueError(f"no evaluated module matches --where {' '.join(args.where)}")
        table = by_param(per_module, params, args.param)
    except ValueError as e:
        ap.error(str(e))
    mean = float(np.mean(list(per_module.values())))
    what = f"{len(args.eval)} files pooled" if len(args.eval) > 1 else str(args.eval[0])
    where = f" where {' and '.join(args.where)}" if args.where else ""
    print(f"{what}: {len(per_module)} modules{where}, success {100 * mean:.1f} %")
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
