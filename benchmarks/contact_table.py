"""The contact stress benchmark's figures side by side, as a markdown table.

    python -m benchmarks.contact_table A.json B.json ... [--labels "v1 1 mm,v2 1 mm,..."]

Each file is one `assetgen bench contacts DATASET --json FILE` run (one clearance); the table
has one column per file, in the order given, and one row per figure, lengths as a fraction of
the clearance (and in mm), with each target met or missed.
"""

from __future__ import annotations

import argparse
import json

from sim.bench.stress.figures import TARGETS, targets


def _pct(s: dict, key: str) -> str:
    return f"{100 * s[key] / s['clearance']:.0f} % ({s[key] * 1e3:.3f} mm)"


def _friction(s: dict) -> str:
    """The range of effective over configured friction; '–' for a run without the case."""
    lo = [v for k, v in s.items() if k.startswith("friction_") and k.endswith("_min")]
    hi = [v for k, v in s.items() if k.startswith("friction_") and k.endswith("_max")]
    return f"{min(lo):.3f}–{max(hi):.3f}" if lo else "–"


ROWS = (
    ("modules / pushes / impacts", lambda s: f"{s['modules']} / {s['pushes']} / {s['impacts']}"),
    ("pass-throughs", lambda s: str(s["passed_through"])),
    ("transient penetration, p99", lambda s: _pct(s, "penetration_p99")),
    ("transient penetration, worst", lambda s: _pct(s, "penetration_worst")),
    ("runs deeper than the clearance", lambda s: str(s["deeper_than_clearance"])),
    ("depth at rest, worst", lambda s: _pct(s, "rest_depth_worst")),
    (
        "straight pushes not at rest (chattering)",
        lambda s: f"{s['straight_not_at_rest']} ({s.get('straight_chattering', '–')})",
    ),
    (
        "twisting pushes not at rest (chattering)",
        lambda s: f"{s['twisting_not_at_rest']} ({s.get('twisting_chattering', '–')})",
    ),
    (
        "sliding friction / configured",
        lambda s: _friction(s),
    ),
    ("rebound e, worst", lambda s: f"{s['rebound_worst']:.3f}"),
    ("seconds (2 threads)", lambda s: f"{s['seconds']:.0f}"),
)


def table(docs: list[dict], labels: list[str]) -> str:
    """Markdown: one column per document, its first summary."""
    sums = [d["summaries"][0] | {"seconds": d["seconds"]} for d in docs]
    lines = ["| figure | " + " | ".join(labels) + " |", "|---" * (len(labels) + 1) + "|"]
    for name, cell in ROWS:
        lines.append(f"| {name} | " + " | ".join(cell(s) for s in sums) + " |")
    met = [targets(s) for s in sums]
    for target in TARGETS:
        if not any(target in m for m in met):
            continue
        cells = ("–" if target not in m else "met" if m[target] else "**missed**" for m in met)
        lines.append(f"| target: {target} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("files", nargs="+")
    p.add_argument("--labels", default=None, help="comma-separated column names")
    a = p.parse_args()
    docs = [json.loads(open(f).read()) for f in a.files]
    labels = a.labels.split(",") if a.labels else a.files
    print(table(docs, labels))


if __name__ == "__main__":
    main()
