"""The paper's figures and Table III from training runs and evaluation files.

Inputs (nothing here trains or simulates; torch is not needed):

    RUN_DIR/config.json       written by rl/runner.py train(): algo, stack, seed, config, ...
    RUN_DIR/metrics.csv       one row per iteration; columns env_steps, success_rate (the
                              fraction of the last finished training episodes that succeeded)
    RUN_DIR/eval_*.json       `assetgen eval --checkpoint RUN_DIR --out ...` (evaluation/)
    baseline *.json           `assetgen eval --agent scripted|random --out ...` (evaluation/)

An evaluation file needs: success_rate (fraction), episodes (count), time_to_success_s (list
of seconds, one per success), dataset (the split's name or folder: its last path component,
"train" or "test", names the column), and either algo + stack (a trained run) or agent.
Its policy ("deterministic", the paper's protocol and the default of older files, or
"stochastic") keeps the protocols apart: a trained policy's sampled actions make their own
row, "PPO (sampled)". A run trained with demonstrations or config overrides is its own
variant too ("SAC+scripted", "SAC+scripted [bc_weight=0]"), so ablations never pool.

Runs are grouped into variants (`variant_name`: SAC + stack 10 -> "SAC-STACK"); the seeds of a
variant give mean ± std (population std, ddof = 0) over runs. Outputs of `write_report`:
learning_curves.png, time_to_success.png, table.md and report.json in one folder.

This module writes a report folder (`write_report`), its report.json and the table into a
README (`replace_table`); the pieces live beside it: rl/report_load.py (reading run folders
and evaluation files), rl/report_summary.py (curves and pooled evaluations per variant),
rl/report_tables.py (the markdown tables) and rl/report_plots.py (the PNG plots).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from rl.report_load import ReportError, load_baselines, load_run
from rl.report_plots import palette, plot_learning_curves, plot_time_to_success
from rl.report_summary import Curve, ordered_variants, summarise
from rl.report_tables import PAPER_MEDIAN_TEST_S, PAPER_SUCCESS_PCT, markdown_table, median_split


def _num(x: float) -> float | None:
    return None if math.isnan(x) else float(x)  # strict JSON has no NaN


def report_json(summary: dict[str, Any]) -> dict[str, Any]:
    """The summary as plain JSON: curves as lists, cells with their medians, paper numbers."""
    variants: dict[str, Any] = {}

    def curve(c: Curve | None) -> dict[str, Any] | None:
        if c is None:
            return None
        return {
            "runs": c.runs,
            "env_steps": c.env_steps.tolist(),
            "success_mean": c.mean.tolist(),
            "success_std": c.std.tolist(),
        }

    def wall_curve(c: Curve | None) -> dict[str, Any] | None:
        if c is None:
            return None
        doc = curve(c)
        return doc and {"wall_min" if k == "env_steps" else k: x for k, x in doc.items()}

    for v in ordered_variants(set(summary["curves"]) | set(summary["cells"])):
        variants[v] = {
            "seeds": summary["seeds"].get(v, []),
            "curve": curve(summary["curves"].get(v)),
            "probe_curve": curve(summary.get("probe_curves", {}).get(v)),
            "wall_curve": wall_curve(summary.get("wall_curves", {}).get(v)),
            "budgets": [
                {"env_steps": int(st), "wall_s": _num(w)}
                for st, w in summary.get("budgets", {}).get(v, np.zeros((0, 2)))
            ],
            "eval": {
                s: {
                    "files": cell.evals,
                    "episodes": cell.episodes,
                    "success_mean": _num(cell.success_mean),
                    "success_std": _num(cell.success_std),
                    "median_time_to_success_s": _num(cell.median_time_to_success_s),
                    "successes": len(cell.time_to_success_s),
                }
                for s, cell in summary["cells"].get(v, {}).items()
            },
        }
    paper = {
        v: {"train_pct": t, "test_pct": s, "median_test_s": PAPER_MEDIAN_TEST_S.get(v)}
        for v, (t, s) in PAPER_SUCCESS_PCT.items()
    }
    return {"variants": variants, "paper_table_iii": paper}


def load_summary(
    run_paths: list[str | Path], baselines: list[str | Path], label_runs: bool = False
) -> tuple[dict[str, Any], list[Path]]:
    """`summarise` of the run folders and evaluation files given (label_runs: as in
    `write_report`), and the baseline files skipped; ReportError when there is nothing."""
    runs = [load_run(p, Path(p).name if label_runs else None) for p in run_paths]
    base, skipped = load_baselines(baselines)
    if not runs and not base:
        raise ReportError("nothing to report: give run folders and/or --baselines")
    return summarise(runs, base), skipped


def write_report(
    run_paths: list[str | Path],
    baselines: list[str | Path],
    out: str | Path,
    label_runs: bool = False,
    paper: bool = True,
) -> dict[str, Any]:
    """Read everything first (so bad input fails before any file is written), then write
    out/learning_curves.png, out/time_to_success.png, out/table.md, out/report.json, and
    out/probe_curves.png when runs logged a frozen-policy probe. label_runs: every run its
    own row, named by its folder (`load_run`'s label); paper: as in `markdown_table`.
    Returns the report.json document."""
    summary, skipped = load_summary(run_paths, baselines, label_runs)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    colors = palette(set(summary["curves"]) | set(summary["cells"]))
    plot_learning_curves(
        summary["curves"],
        out / "learning_curves.png",
        colors=colors,
        wall_curves=summary["wall_curves"],
    )
    if summary["probe_curves"]:
        plot_learning_curves(
            summary["probe_curves"],
            out / "probe_curves.png",
            ylabel="frozen deterministic policy, success on the probe (%)",
            title="Probe of the frozen policy (train --probe-steps; mean ± std over seeds)",
            legend="lower right",
            colors=colors,
        )
    plot_time_to_success(
        summary["cells"], out / "time_to_success.png", median_split(summary), colors=colors
    )
    (out / "table.md").write_text(markdown_table(summary, paper))
    doc = report_json(summary) | {"skipped_baselines": [str(f) for f in skipped]}
    (out / "report.json").write_text(json.dumps(doc, indent=2))
    return doc


TABLE_BEGIN, TABLE_END = "<!-- shipped-table:begin -->", "<!-- shipped-table:end -->"
"""The lines between which `assetgen report --readme FILE` writes the table."""


def replace_table(path: str | Path, table: str) -> None:
    """Put `table` between TABLE_BEGIN and TABLE_END in the markdown file `path` (written to
    a temporary name, then renamed); ReportError when the markers are missing."""
    import os

    path = Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise ReportError(f"{path}: cannot read it ({e})") from e
    start, end = text.find(TABLE_BEGIN), text.find(TABLE_END)
    if start < 0 or end < start:
        raise ReportError(
            f"{path} lacks the lines {TABLE_BEGIN} and {TABLE_END}: add them where the table goes"
        )
    new = text[: start + len(TABLE_BEGIN)] + "\n" + table.strip() + "\n" + text[end:]
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(new)
    os.replace(tmp, path)
