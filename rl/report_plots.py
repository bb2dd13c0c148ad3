"""A report's plots as PNG files (matplotlib, no display): learning curves over env steps
and wall-clock minutes, times to success per variant, one colour per variant throughout
(`palette`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rl.report_load import SAMPLED
from rl.report_summary import Cell, Curve, ordered_variants


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
    bases = ordered_variants({v.removesuffix(SAMPLED) for v in variants})
    colour = {b: cmap(order[i % 20]) for i, b in enumerate(bases)}
    return {v: colour[v.removesuffix(SAMPLED)] for v in variants}


def _figure(ncols: int = 1) -> tuple[Any, Any]:
    import matplotlib

    matplotlib.use("Agg")  # files only: no display on servers and CI
    import matplotlib.pyplot as plt

    return plt.subplots(1, ncols, figsize=(8 * ncols, 5), dpi=100)


def _draw_curves(ax: Any, curves: dict[str, Curve], colors: dict[str, Any]) -> None:
    """Mean line and ± std band of each variant's curve, in table order."""
    for v in ordered_variants(set(curves)):
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
    names = ordered_variants(set(have))
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
