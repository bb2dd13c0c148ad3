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
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

PAPER_SUCCESS_PCT: dict[str, tuple[float, float]] = {
    "random": (0.00, 0.00),
    "PPO": (0.00, 0.00),
    "PPO-STACK": (20.52, 20.10),
    "SAC": (68.53, 49.73),
    "SAC-STACK": (82.97, 54.70),
    "DreamerV3": (94.32, 93.94),
}
"""Table III of the paper (Orsula et al., iSpaRo 2024): variant -> (train, test) success, %."""
PAPER_MEDIAN_TEST_S: dict[str, float] = {"SAC-STACK": 2.22, "DreamerV3": 1.60}
"""Paper: median time until success on the test set, seconds."""
ROW_ORDER = ("random", "PPO", "PPO-STACK", "SAC", "SAC-STACK", "DreamerV3", "scripted")
"""Table rows always shown, in the paper's order; other variants follow, sorted."""
SPLITS = ("train", "test")
"""Table columns always shown; evaluations on other datasets add columns after these."""
DASH = "–"
WALL_POINTS = 256
"""Points of a curve over wall-clock minutes (evenly spaced) when its runs logged more."""
SAMPLED = " (sampled)"
"""Suffix of the row of a trained policy evaluated with sampled actions."""


class ReportError(ValueError):
    """A run folder or evaluation file that cannot be read; the message names the path."""


@dataclass(frozen=True)
class EvalResult:
    """One evaluation file.

    time_to_success_s: (k,) float seconds, one per successful episode (k = successes).
    """

    path: Path
    variant: str
    split: str
    policy: str
    episodes: int
    success_rate: float
    time_to_success_s: np.ndarray


@dataclass(frozen=True)
class Run:
    """One training run (one seed of a variant).

    env_steps: (T,) int env steps summed over envs at the end of each logged iteration.
    success_rate: (T,) float in [0, 1]; NaN where no training episode had finished yet.
    """

    path: Path
    variant: str
    seed: int
    env_steps: np.ndarray
    success_rate: np.ndarray
    evals: tuple[EvalResult, ...]
    probe_env_steps: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    """(P,) env steps of the rows with a frozen-policy probe (`train --probe-steps`)."""
    probe_success_rate: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """(P,) the probe's success rate there."""
    wall_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """(T,) wall-clock seconds of training at each logged iteration (a resumed run goes on
    from its checkpoint's); empty for a metrics file without the column."""

    @property
    def budget(self) -> tuple[int, float]:
        """(env steps, wall-clock seconds) at the run's last logged iteration."""
        steps = int(self.env_steps[-1]) if len(self.env_steps) else 0
        wall = float(self.wall_s[-1]) if len(self.wall_s) else math.nan
        return steps, wall


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


def variant_name(
    algo: str, stack: int, demos: str | None = None, overrides: dict[str, Any] | None = None
) -> str:
    """The paper's name for an agent: ("sac", 10) -> "SAC-STACK", ("ppo", 1) -> "PPO".

    A stack other than the paper's 10 keeps its size in the name ("SAC-STACK4") so runs
    that differ are never averaged together; so do demonstrations ("SAC+scripted") and
    config overrides ("SAC+scripted [bc_weight=0.0]").
    """
    name = _base_name(algo, stack)
    if demos:
        name += f"+{demos}"
    if overrides:
        name += " [" + ", ".join(f"{k}={v}" for k, v in sorted(overrides.items())) + "]"
    return name


def _base_name(algo: str, stack: int) -> str:
    # the built-in agents keep their names
    if algo in ("random", "scripted", "scripted-fast", "scripted-direct"):
        base = algo
    elif algo.lower() in ("dreamer", "dreamerv3"):
        base = "DreamerV3"
    else:
        base = algo.upper()
    if stack <= 1:
        return base
    return f"{base}-STACK" if stack == 10 else f"{base}-STACK{stack}"


class NotAnEvalFileError(ReportError):
    """A readable JSON object that lacks the keys of an evaluation file."""


def _read_json(path: Path) -> dict[str, Any]:
    try:
        doc = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise ReportError(f"{path}: cannot read it as JSON ({e})") from e
    if not isinstance(doc, dict):
        raise ReportError(f"{path}: expected a JSON object")
    return doc


def load_eval(path: str | Path) -> EvalResult:
    """Read one evaluation JSON (schema in the module docstring)."""
    path = Path(path)
    doc = _read_json(path)
    missing = [
        k for k in ("success_rate", "episodes", "time_to_success_s", "dataset") if k not in doc
    ]
    policy = str(doc.get("policy", "deterministic"))
    if policy not in ("deterministic", "stochastic"):
        raise ReportError(f"{path}: policy {policy!r} is neither deterministic nor stochastic")
    if "algo" in doc:
        variant = variant_name(
            doc["algo"], int(doc.get("stack", 1)), doc.get("demos"), doc.get("overrides")
        )
        if policy == "stochastic":
            variant += SAMPLED
    elif "agent" in doc:
        variant = variant_name(str(doc["agent"]), 1)
    else:
        missing.append("algo or agent")
    if missing:
        raise NotAnEvalFileError(
            f"{path}: not an evaluation file of `assetgen eval --out` (missing {missing}); "
            "re-run the evaluation with --out"
        )
    split = Path(str(doc["dataset"])).name  # "datasets/test" and "test" both name the split
    noise = float(doc.get("noise_scale", 1.0))
    if noise != 1.0:  # a robustness evaluation gets its own column
        split += f" (noise ×{noise:g})"
    return EvalResult(
        path=path,
        variant=variant,
        split=split,
        policy=policy,
        episodes=int(doc["episodes"]),
        success_rate=float(doc["success_rate"]),
        time_to_success_s=np.asarray(doc["time_to_success_s"], dtype=float),
    )


def _read_metrics(
    path: Path,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        cols = reader.fieldnames or []
        if "env_steps" not in cols or "success_rate" not in cols:
            raise ReportError(
                f"{path}: needs the columns env_steps and success_rate (rl/runner.py); has {cols}"
            )
        rows = list(reader)
    # an empty cell or "nan": no training episode had finished by that iteration
    rate = [float(r["success_rate"]) if r["success_rate"] else math.nan for r in rows]
    steps = np.array([int(float(r["env_steps"])) for r in rows], dtype=np.int64)
    probed = [i for i, r in enumerate(rows) if r.get("probe_success_rate")]
    probe = np.array([float(rows[i]["probe_success_rate"]) for i in probed])
    wall = np.array([float(r["wall_s"]) for r in rows]) if "wall_s" in cols else np.zeros(0)
    return steps, np.array(rate), steps[probed], probe, wall


def load_run(path: str | Path, label: str | None = None) -> Run:
    """Read a run folder: config.json, metrics.csv and any eval_*.json. label: the run's
    row instead of its variant's name (a screening page, where every run is a candidate of
    its own and two runs of one variant are not seeds of one recipe)."""
    path = Path(path)
    config, metrics = path / "config.json", path / "metrics.csv"
    if not path.is_dir() or not config.is_file() or not metrics.is_file():
        raise ReportError(
            f"{path} is not a training run: it needs config.json and metrics.csv "
            "(written by `assetgen train --out RUN_DIR`); give run folders only"
        )
    meta = _read_json(config)
    if "algo" not in meta:
        raise ReportError(f"{config}: no 'algo' key; is this a run of `assetgen train`?")
    variant = variant_name(
        meta["algo"], int(meta.get("stack", 1)), meta.get("demos"), meta.get("overrides")
    )
    steps, rate, probe_steps, probe_rate, wall = _read_metrics(metrics)
    evals = tuple(load_eval(p) for p in sorted(path.glob("eval_*.json")))
    for e in evals:
        if e.variant.removesuffix(SAMPLED) != variant:
            raise ReportError(f"{e.path} evaluates {e.variant}, but the run {path} is {variant}")
    kinds = [(e.split, e.policy) for e in evals]
    if len(set(kinds)) != len(kinds):
        raise ReportError(
            f"{path} has two evaluation files of one dataset and policy: keep one of each"
        )
    seed = int(meta.get("seed", 0))
    if label is not None:
        variant = label
        evals = tuple(
            replace(e, variant=label + (SAMPLED if e.variant.endswith(SAMPLED) else ""))
            for e in evals
        )
    return Run(path, variant, seed, steps, rate, evals, probe_steps, probe_rate, wall)


def load_baselines(paths: list[str | Path]) -> tuple[list[EvalResult], list[Path]]:
    """(evaluation results, skipped files) from evaluation files given directly or folders.

    A file named directly must be an evaluation file. In a folder, every *.json directly
    inside is read; valid JSON without the evaluation keys (a `bench --json` output, say)
    is skipped and returned, so a results/ folder can be passed as it is."""
    results: list[EvalResult] = []
    skipped: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            for f in sorted(p.glob("*.json")):
                try:
                    results.append(load_eval(f))
                except NotAnEvalFileError:  # unreadable JSON is still an error
                    skipped.append(f)
        elif p.is_file():
            results.append(load_eval(p))
        else:
            raise ReportError(f"{p}: no such file or folder of evaluation JSONs")
    return results, skipped


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


def _order(names: set[str]) -> list[str]:
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


def _pct(cell: Cell | None, episodes: bool = True) -> str:
    if cell is None:
        return DASH
    std = f" ± {100 * cell.success_std:.2f}" if cell.evals > 1 else ""
    return f"{100 * cell.success_mean:.2f}{std} %" + (f" (n = {cell.episodes})" * episodes)


def _budget(b: np.ndarray | None) -> tuple[str, str]:
    """Table cells of a variant's training budgets ((runs, 2) env steps, wall seconds): their
    means over the seeds, as "2.00 M" and "50 min"."""
    if b is None or not len(b):
        return DASH, DASH
    steps, wall = b[:, 0].mean(), b[:, 1]
    cell = f"{steps / 1e6:.2f} M" if steps >= 1e4 else f"{steps:.0f}"
    ok = wall[~np.isnan(wall)]
    if not len(ok):
        return cell, DASH
    minutes = ok.mean() / 60
    return cell, f"{minutes:.0f} min" if minutes >= 10 else f"{minutes:.1f} min"


def median_split(summary: dict[str, Any]) -> str:
    """The split whose times to success the table and plot give: the test split, or the
    train split where nothing was evaluated on the test split (a screening page)."""
    cells = summary["cells"].values()
    return "test" if any("test" in row for row in cells) or not cells else "train"


def _row_start(summary: dict[str, Any], v: str, split: str) -> tuple[list[str], str]:
    """A table row's first cells (agent, seeds, env steps, wall clock) and its median time
    to success on `split`, as both table layouts write them."""
    row = summary["cells"].get(v, {})
    n_seeds = len(summary["seeds"].get(v, [])) or max((c.evals for c in row.values()), default=0)
    cell = row.get(split)
    median = cell.median_time_to_success_s if cell is not None else math.nan
    start = [v, str(n_seeds) if n_seeds else DASH, *_budget(summary.get("budgets", {}).get(v))]
    return start, DASH if math.isnan(median) else f"{median:.2f} s"


def _paper_median(v: str) -> str:
    return f"{PAPER_MEDIAN_TEST_S[v]:.2f} s" if v in PAPER_MEDIAN_TEST_S else DASH


def markdown_table(summary: dict[str, Any], paper: bool = True) -> str:
    """Table III layout: one row per agent, success on each split, median time on test.
    paper: with the paper's rows always shown and its figures beside ours; without, only
    the variants given (a screening page)."""
    cells, splits = summary["cells"], summary["splits"]
    if not paper:  # only the splits something was evaluated on
        splits = [s for s in splits if any(s in row for row in cells.values())]
    names = set(cells) | set(summary["curves"]) | (set(ROW_ORDER) if paper else set())
    on = median_split(summary)
    head = ["agent", "seeds", "env steps", "wall clock", *(f"{s} set" for s in splits)]
    head += [f"median time to success ({on})"]
    if paper:
        head += ["paper train set", "paper test set", "paper median (test)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for v in _order(names):
        row = cells.get(v, {})
        start, median = _row_start(summary, v, on)
        values = [*start, *(_pct(row.get(s)) for s in splits), median]
        if paper:
            ref = PAPER_SUCCESS_PCT.get(v)
            values += [
                f"{ref[0]:.2f} %" if ref else DASH,
                f"{ref[1]:.2f} %" if ref else DASH,
                _paper_median(v),
            ]
        lines.append("| " + " | ".join(values) + " |")
    return "\n".join(lines) + (
        "\n\nEnv steps, wall clock: a seed's training, mean over the seeds. "
        "Success: mean ± std over seeds (one evaluation file each; no ± for one file), "
        "n = episodes pooled. Median time to success pooled over the seeds' successful "
        "episodes. Trained policies act with their mean action (the paper's protocol) unless "
        f"the row says{SAMPLED}."
        + (" Paper: Orsula et al. 2024, Table III (10 attempts per module).\n" if paper else "\n")
    )


def compact_table(
    summary: dict[str, Any], page: str, leave_out: frozenset[str] = frozenset()
) -> str:
    """The README's short form of `markdown_table` (paper layout): test split only, a
    policy's sampled-action figure in its own row's cell rather than a row of its own, no
    episode counts, and without the variants in `leave_out` (candidates a later one
    superseded). Every filed lane then adds one line, not two, and the rest stays on `page`
    (a link), so the README keeps its size as Table III fills in."""
    cells = summary["cells"]
    names = {v.removesuffix(SAMPLED) for v in set(cells) | set(summary["curves"])}
    head = ["agent", "seeds", "env steps", "wall clock", "test set", "sampled actions"]
    head += ["median time (test)", "paper test set", "paper median"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for v in _order((names | set(ROW_ORDER)) - leave_out):
        start, median = _row_start(summary, v, "test")
        ref = PAPER_SUCCESS_PCT.get(v)
        values = [
            *start,
            _pct(cells.get(v, {}).get("test"), episodes=False),
            _pct(cells.get(v + SAMPLED, {}).get("test"), episodes=False),
            median,
            f"{ref[1]:.2f} %" if ref else DASH,
            _paper_median(v),
        ]
        lines.append("| " + " | ".join(values) + " |")
    return "\n".join(lines) + (
        "\n\nSuccess with the mean action (the paper's protocol) and with sampled actions: "
        "mean ± std over seeds (no ± for one seed). Env steps, wall clock: a seed's training, "
        "mean over the seeds. The other splits, episode counts, the paper's train split"
        + (" and the candidates a later one superseded" if leave_out else "")
        + f": [the full table]({page}). Paper: Orsula et al. 2024, Table III.\n"
    )


def palette(variants: set[str]) -> dict[str, Any]:
    """One colour per variant of a report, distinct for up to 20 variants (tab20's colours,
    strong shades first), in table order, so every plot of the report draws a variant alike.
    A "(sampled)" row is its variant's own run acting otherwise: it takes that variant's
    colour rather than a slot of its own, which would leave 10 runs with sampled rows
    sharing colours in their curves. (A colour from a hash of the name let two variants
    share one.)"""
    import matplotlib

    cmap = matplotlib.colormaps["tab20"]
    order = [2 * i for i in range(10)] + [2 * i + 1 for i in range(10)]
    bases = _order({v.removesuffix(SAMPLED) for v in variants})
    colour = {b: cmap(order[i % 20]) for i, b in enumerate(bases)}
    return {v: colour[v.removesuffix(SAMPLED)] for v in variants}


def _figure(ncols: int = 1) -> tuple[Any, Any]:
    import matplotlib

    matplotlib.use("Agg")  # files only: no display on servers and CI
    import matplotlib.pyplot as plt

    return plt.subplots(1, ncols, figsize=(8 * ncols, 5), dpi=100)


def _draw_curves(ax: Any, curves: dict[str, Curve], colors: dict[str, Any]) -> None:
    """Mean line and ± std band of each variant's curve, in table order."""
    for v in _order(set(curves)):
        c = curves[v]
        if not c.runs:
            continue
        col = colors[v]
        ax.plot(
            c.env_steps, 100 * c.mean, color=col, label=f"{v} ({c.runs} seed{'s' * (c.runs > 1)})"
        )
        lo, hi = np.clip(c.mean - c.std, 0, 1), np.clip(c.mean + c.std, 0, 1)  # rates: 0–100 %
        ax.fill_between(c.env_steps, 100 * lo, 100 * hi, color=col, alpha=0.25)
    if not any(c.runs for c in curves.values()):
        ax.text(0.5, 0.5, "no finished training episodes", ha="center", transform=ax.transAxes)


def plot_learning_curves(
    curves: dict[str, Curve],
    path: Path,
    ylabel: str = "training success rate (%)",
    title: str = "Learning curves (mean ± std over seeds)",
    legend: str = "upper left",
    colors: dict[str, Any] | None = None,
    wall_curves: dict[str, Curve] | None = None,
) -> None:
    """Success rate (%) over env steps, mean line and ± std band per variant, as a PNG.
    colors: {variant: colour} (default: `palette` of these curves). wall_curves: the same
    over wall-clock minutes, drawn in a second panel to the right (same colours)."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    colors = colors or palette(set(curves) | set(wall_curves or {}))
    fig, axes = _figure(2 if wall_curves is not None else 1)
    panels = [(axes[0] if wall_curves is not None else axes, curves, "environment steps")]
    if wall_curves is not None:
        panels.append((axes[1], wall_curves, "wall-clock minutes"))
    for ax, cs, over in panels:
        _draw_curves(ax, cs, colors)
        if over == "environment steps":  # millions on the ticks, not a detached "1e6"
            ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x / 1e6:g}"))
            xlabel = "environment steps (millions)"
        else:
            xlabel = "wall-clock minutes of training"
        ax.set(xlabel=xlabel, ylabel=ylabel, ylim=(-2, 102))
        ax.set_title(title if len(panels) == 1 else f"{title}, over {over}")
        ax.grid(alpha=0.3)
    handles, labels = panels[0][0].get_legend_handles_labels()
    fig.tight_layout()
    if handles and len(panels) == 1:
        panels[0][0].legend(loc=legend, fontsize="small")
    elif handles:  # one legend below both panels: the variants' names are long
        fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.0), fontsize="small")
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)


def plot_time_to_success(
    cells: dict[str, dict[str, Cell]],
    path: Path,
    split: str = "test",
    colors: dict[str, Any] | None = None,
) -> None:
    """Time to success (s) per variant on `split`, one row each in table order: a box from
    the 25th to the 75th percentile, whiskers from the 10th to the 90th, a tick at the
    median; the row's label gives the median and the count of successes. Sampled-action rows
    take their variant's colour, paler. (Overlaid histograms were unreadable past a handful of
    variants; rows stay readable for any number.) colors: {variant: colour} (default:
    `palette` of these variants)."""
    import matplotlib

    matplotlib.use("Agg")  # files only: no display on servers and CI
    import matplotlib.pyplot as plt

    colors = colors or palette(set(cells))
    have = {v: row[split] for v, row in cells.items() if split in row}
    names = _order(set(have))
    fig, ax = plt.subplots(figsize=(8, max(3.0, 1.4 + 0.32 * len(names))), dpi=100)
    labels = []
    for i, v in enumerate(names):
        c, col = have[v], colors[v]
        t = c.time_to_success_s
        if not len(t):
            labels.append(f"{v}: no success (n = {c.episodes})")
            continue
        p10, p25, med, p75, p90 = np.percentile(t, [10, 25, 50, 75, 90])
        alpha = 0.35 if v.endswith(SAMPLED) else 0.8
        ax.hlines(i, p10, p90, color=col, lw=1.5)
        ax.barh(i, p75 - p25, left=p25, height=0.6, color=col, alpha=alpha, edgecolor=col)
        ax.vlines(med, i - 0.3, i + 0.3, color="black", lw=2)
        labels.append(f"{v}: median {med:.2f} s ({len(t)} successes)")
    if not have:
        ax.text(0.5, 0.5, f"no {split}-set evaluation", ha="center", transform=ax.transAxes)
    ax.set_yticks(range(len(names)), labels, fontsize="small")
    ax.set_ylim(max(len(names), 1) - 0.5, -0.5)  # the table's first row on top
    ax.set_xlim(left=0)
    ax.set(xlabel="time to success (s)")
    ax.set_title(
        f"Time to success on the {split} set (box: 25–75 %, whiskers: 10–90 %, tick: median)"
    )
    ax.grid(axis="x", alpha=0.3)
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)


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

    for v in _order(set(summary["curves"]) | set(summary["cells"])):
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
