"""Success by a Table I parameter: where a policy's misses lie, read from its evaluation files.

    python -m benchmarks.by_parameter EVAL.json [EVAL.json ...] [--param n_vertices ...]
                                      [--bins 4] [--dataset FOLDER]

An evaluation file (`assetgen eval --out`) holds every module's success rate (`per_module`)
and the folder of the dataset it ran on; each module's parameters come from its module.json.
A parameter with at most 8 distinct values is grouped by value, any other into `--bins`
groups of as many modules each (quantiles). One table per parameter: each group, its
modules, and for each file the success over them (the mean of the modules' rates) and the
share of the file's misses the group holds. Files compared must cover the same modules.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

DISTINCT = 8
"""A parameter with at most this many distinct values is grouped by value."""


class EvalFileError(ValueError):
    """An evaluation file this tool cannot read, with what to do."""


def per_module(path: Path) -> tuple[dict[str, float], str]:
    """(module id -> success rate, dataset folder) of one `assetgen eval` file."""
    try:
        doc = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise EvalFileError(f"{path}: not a readable evaluation file ({e})") from e
    rates = doc.get("per_module")
    if not isinstance(rates, dict) or not rates:
        raise EvalFileError(
            f"{path}: no per_module success rates; it is not a single-module evaluation file "
            "of `assetgen eval --out` (an assembly's sequence file has none)"
        )
    return {str(k): float(v) for k, v in rates.items()}, str(doc.get("dataset_folder", ""))


def module_params(folder: Path, ids: list[str]) -> dict[str, dict[str, float]]:
    """Each module's numeric Table I parameters, from its module.json."""
    from assetgen.dataset.reader import Dataset

    ds = Dataset(folder)
    out = {}
    for mid in ids:
        params = ds.module_json(mid)["params"]
        out[mid] = {k: float(v) for k, v in params.items() if isinstance(v, int | float)}
    return out


def groups(values: dict[str, float], bins: int) -> list[tuple[str, list[str]]]:
    """(label, module ids) per group: one per value when there are few, else quantile bins
    of (nearly) equal size, in increasing order of the value."""
    order = sorted(values, key=lambda k: (values[k], k))
    distinct = sorted(set(values.values()))
    if len(distinct) <= DISTINCT:
        return [(f"{v:g}", [k for k in order if values[k] == v]) for v in distinct]
    n, out = len(order), []
    for i in range(bins):
        part = order[i * n // bins : (i + 1) * n // bins]
        if part:
            out.append((f"{values[part[0]]:.3g} – {values[part[-1]]:.3g}", part))
    return out


def table(
    param: str,
    params: dict[str, dict[str, float]],
    evals: list[tuple[str, dict[str, float]]],
    bins: int,
) -> str:
    """A markdown table of success and share of misses by `param`'s groups."""
    values = {mid: p[param] for mid, p in params.items()}
    head = f"| {param} | modules | " + " | ".join(f"{n}: success | misses" for n, _ in evals)
    lines = [head + " |", "|---|---|" + "---|---|" * len(evals)]
    misses = [sum(1.0 - r[m] for m in values) for _, r in evals]
    for label, ids in groups(values, bins):
        cells = []
        for (_, rates), total in zip(evals, misses, strict=True):
            ok = sum(rates[m] for m in ids) / len(ids)
            miss = sum(1.0 - rates[m] for m in ids)
            share = f"{100 * miss / total:.0f} %" if total > 0 else "–"
            cells.append(f"{100 * ok:.1f} % | {share}")
        lines.append(f"| {label} | {len(ids)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("evals", nargs="+", type=Path, help="evaluation files (assetgen eval --out)")
    ap.add_argument("--param", action="append", help="a parameter (default: every one that varies)")
    ap.add_argument("--bins", type=int, default=4, help="groups of a continuous parameter")
    ap.add_argument("--dataset", type=Path, help="the dataset folder (default: the files')")
    args = ap.parse_args(argv)
    if args.bins < 1:
        ap.error(f"--bins {args.bins}: give at least 1 group")
    try:
        read = [(p, *per_module(p)) for p in args.evals]
    except EvalFileError as e:
        ap.error(str(e))
    first, ids = read[0][0], sorted(read[0][1])
    for path, rates, _ in read[1:]:
        if sorted(rates) != ids:
            ap.error(f"{path} covers other modules than {first} ({len(rates)} against "
                     f"{len(ids)}): compare files of the same dataset")  # fmt: skip
    folder = args.dataset or Path(read[0][2])
    if not (folder / "dataset.json").exists():
        ap.error(f"dataset folder {folder} is not here: give it with --dataset FOLDER")
    params = module_params(folder, ids)
    varying = [k for k in params[ids[0]] if len({p[k] for p in params.values()}) > 1]
    for name in args.param or []:
        if name not in params[ids[0]]:
            ap.error(f"--param {name}: not a parameter of these modules; one of {varying}")
    names = [p.parent.name or p.stem for p, _, _ in read]
    if len(set(names)) < len(names):  # two files of one run: tell them by their own names
        names = [f"{p.parent.name}/{p.stem}" if p.parent.name else p.stem for p, _, _ in read]
    evals = [(name, rates) for name, (_, rates, _) in zip(names, read, strict=True)]
    for param in args.param or varying:
        print(table(param, params, evals, args.bins), end="\n\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
