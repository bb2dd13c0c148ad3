"""A report's figures from its runs and evaluation files: each variant's learning curves
(mean ± std over seeds on a shared grid, over env steps, wall-clock minutes or the probe's
rows), its evaluation files pooled per split (Cell), and the order variants are listed in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from rl.report_load import SAMPLED, EvalResult, Run

ROW_ORDER = ("random", "PPO", "PPO-STACK", "SAC", "SAC-STACK", "DreamerV3", "scripted")
"""Table rows always shown, in the paper's order; other variants follow, sorted."""


SPLITS = ("train", "test")
"""Table columns always shown; evaluations on other datasets add columns after these."""


WALL_POINTS = 256
"""Points of a curve over wall-clock minutes (evenly spaced) when its runs logged more."""


@dataclass(frozen=True)
class Curve:
    """Success rate of a variant's runs on a shared env-step (or wall-clock) grid.

    env_steps, mean, std: (G,) over the range every run covers (cut at the shortest run), each
    run linearly interpolated onto the union of the runs' logged steps; std over runs, ddof 0.
    A curve over wall-clock time holds minutes in env_steps (`learning_curve(..., wall=True)`).
    """

    variant: str
    runs: int
    env_steps: np.ndarray
    mean: np.ndarray
    std: np.ndarray


@dataclass(frozen=True)
class Cell:
    """A variant on one split: `evals` files pooled.

    success_mean, success_std: fraction, over the files (seeds), ddof 0. episodes: summed.
    time_to_success_s: (k,) seconds, all files' successes pooled; median over them (NaN if k = 0).
    """

    evals: int
    episodes: int
    success_mean: float
    success_std: float
    time_to_success_s: np.ndarray

    @property
    def median_time_to_success_s(self) -> float:
        t = self.time_to_success_s
        return float(np.median(t)) if len(t) else math.nan


def learning_curve(runs: list[Run], probe: bool = False, wall: bool = False) -> Curve:
    """Mean ± std over `runs` (one variant) of the training success rate, or (probe) of the
    frozen-policy probe's success rate; runs without probe rows are left out of the latter.
    wall: over wall-clock minutes instead of env steps (runs without wall_s are left out)."""
    if wall:
        pairs = [(r.wall_s / 60.0, r.success_rate) for r in runs if len(r.wall_s)]
    else:
        pairs = [(r.probe_env_steps, r.probe_success_rate) if probe
                 else (r.env_steps, r.success_rate) for r in runs]  # fmt: skip
    ok = [(s[m], y[m]) for s, y in pairs if (m := ~np.isnan(y)).any()]
    if not ok:
        empty = np.zeros(0)
        return Curve(runs[0].variant, 0, empty.astype(np.int64), empty, empty)
    lo, hi = max(s[0] for s, _ in ok), min(s[-1] for s, _ in ok)
    grid = np.unique(np.concatenate([s for s, _ in ok]))
    grid = grid[(grid >= lo) & (grid <= hi)]
    if wall and len(grid) > WALL_POINTS:  # seeds log at their own times: a union of them
        grid = np.linspace(lo, hi, WALL_POINTS)  # would only bloat report.json
    ys = np.stack([np.interp(grid, s, y) for s, y in ok])  # (runs, G)
    return Curve(runs[0].variant, len(ok), grid, ys.mean(0), ys.std(0))


def eval_cell(evals: list[EvalResult]) -> Cell:
    """Pool a variant's evaluation files of one split (one file per seed)."""
    rates = np.array([e.success_rate for e in evals])
    tts = np.concatenate([e.time_to_success_s for e in evals]) if evals else np.zeros(0)
    return Cell(len(evals), sum(e.episodes for e in evals), rates.mean(), rates.std(), tts)


def ordered_variants(names: set[str]) -> list[str]:
    """The paper's rows first, the others sorted; a variant's sampled-action row right
    after it, so that the two read side by side in tables and figures."""
    bases = {v.removesuffix(SAMPLED) for v in names}
    ordered = [v for v in ROW_ORDER if v in bases] + sorted(bases - set(ROW_ORDER))
    return [n for v in ordered for n in (v, v + SAMPLED) if n in names]


def summarise(runs: list[Run], baselines: list[EvalResult]) -> dict[str, Any]:
    """Group by variant: {"curves": {variant: Curve}, "wall_curves": {variant: Curve over
    minutes}, "cells": {variant: {split: Cell}}, "seeds": {variant: [seed, ...]},
    "budgets": {variant: (runs, 2) env steps and wall seconds at each run's end},
    "splits": [split, ...]}."""
    by_variant: dict[str, list[Run]] = {}
    for r in runs:
        by_variant.setdefault(r.variant, []).append(r)
    curves = {v: learning_curve(rs) for v, rs in by_variant.items()}
    wall_curves = {v: learning_curve(rs, wall=True) for v, rs in by_variant.items()}
    budgets = {v: np.array([r.budget for r in rs], dtype=float) for v, rs in by_variant.items()}
    probes = {v: c for v, rs in by_variant.items() if (c := learning_curve(rs, probe=True)).runs}
    evals = [e for r in runs for e in r.evals] + list(baselines)
    groups: dict[tuple[str, str], list[EvalResult]] = {}
    for e in evals:
        groups.setdefault((e.variant, e.split), []).append(e)
    cells: dict[str, dict[str, Cell]] = {}
    for (v, s), es in groups.items():
        cells.setdefault(v, {})[s] = eval_cell(es)
    splits = list(SPLITS) + sorted({e.split for e in evals} - set(SPLITS))
    seeds = {v: sorted(r.seed for r in rs) for v, rs in by_variant.items()}
    return {
        "curves": curves,
        "wall_curves": wall_curves,
        "budgets": budgets,
        "probe_curves": probes,
        "cells": cells,
        "seeds": seeds,
        "splits": splits,
    }
