"""A report's tables in markdown: Table III's layout (`markdown_table`, beside the paper's
figures or alone for a screening page) and the README's short form (`compact_table`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rl.report_load import SAMPLED
from rl.report_summary import ROW_ORDER, Cell, ordered_variants

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


DASH = "–"


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
    for v in ordered_variants(names):
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
    for v in ordered_variants((names | set(ROW_ORDER)) - leave_out):
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
