"""Write the result pages of docs/results/ from the evaluation files the repository tracks.

    python -m benchmarks.results_pages            # every page
    python -m benchmarks.results_pages --check    # exit 1 when a page is stale

Each page is `assetgen report` of its inputs (rl.report.write_report): table.md, the
learning curves and the time-to-success plot, report.json. The inputs are the shipped
policies (checkpoints/), the further seeds' configs, metrics and evaluations
(docs/results/runs/) and the built-in agents' evaluations (docs/results/baselines/); every one
of them is an evaluation on the current physics, which tests/test_results_pages.py checks.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"


@dataclass(frozen=True)
class Page:
    """One results page: docs/results/<name>/ made from these inputs."""

    name: str
    """Folder under docs/results/."""
    runs: tuple[str, ...]
    """Run folders (config.json, metrics.csv, eval_*.json), relative to the repository root."""
    baselines: tuple[str, ...] = ()
    """Built-in agents' evaluation files or folders of them, relative to the root."""
    readme: bool = False
    """Also write the table into README.md (between rl.report's table markers)."""
    screening: bool = False
    """A screening page: every run its own row named by its folder, evaluated on the train
    split (the candidates are chosen there), without the paper's rows."""

    @property
    def attempts(self) -> int:
        """Attempts a module of the page's evaluations: the paper's 10; a screening's 2 (on
        256 train modules: a candidate costs minutes to screen, not the hour of a test)."""
        return 2 if self.screening else 10

    def run_paths(self) -> list[Path]:
        return [ROOT / r for r in self.runs]

    def baseline_paths(self) -> list[Path]:
        return [ROOT / b for b in self.baselines]


def shipped_runs() -> tuple[str, ...]:
    return tuple(
        str(p.parent.relative_to(ROOT))
        for p in sorted((ROOT / "checkpoints").glob("*/checkpoint.safetensors"))
    )


def filed_runs(folder: str) -> tuple[str, ...]:
    """The run folders (with a config.json) under docs/results/runs/<folder>/."""
    return tuple(
        str(p.parent.relative_to(ROOT))
        for p in sorted((RESULTS / "runs" / folder).glob("*/config.json"))
    )


PAGES: tuple[Page, ...] = (
    Page(
        "table3",
        runs=(
            *filed_runs("table3"),  # the teacher-free rows' seeds benchmarks/table3.py filed
            "checkpoints/sac-direct-bc",
            "docs/results/runs/sac-direct-bc-s1",
            "docs/results/runs/sac-direct-bc-s2",
            "checkpoints/dreamer-direct-bc",
            "docs/results/runs/dreamer-direct-bc-s1",
            "docs/results/runs/dreamer-direct-bc-s2",
        ),
        baselines=("docs/results/baselines",),
        readme=True,
    ),
    Page("shipped", runs=shipped_runs()),
    Page("screening", runs=filed_runs("screening"), screening=True),
)
"""table3: Table III's rows, the teacher-free ones as benchmarks/table3.py files them and SAC
and DreamerV3 taught by the direct expert (three seeds each), next to the built-in agents and
the paper (the README's table). shipped: every policy in checkpoints/. screening: the
teacher-free candidates, one seed each on the train split (docs/results/runs/screening/)."""


REFEREE: tuple[tuple[str, str, str, str], ...] = (
    ("scripted", "test", "docs/results/baselines/scripted_test.json",
     "docs/results/referee/scripted_physx_test.json"),
    ("scripted-fast", "test", "docs/results/baselines/scripted-fast_test.json",
     "docs/results/referee/scripted-fast_physx_test.json"),
    ("scripted-direct", "test", "docs/results/baselines/scripted-direct_test.json",
     "docs/results/referee/scripted-direct_physx_test.json"),
    ("sac-direct-bc", "test", "checkpoints/sac-direct-bc/eval_test.json",
     "docs/results/referee/sac-direct-bc_physx_test.json"),
    ("sac-fast-bc", "test", "checkpoints/sac-fast-bc/eval_test.json",
     "docs/results/referee/sac-fast-bc_physx_test.json"),
    ("dreamer-direct-bc", "test", "checkpoints/dreamer-direct-bc/eval_test.json",
     "docs/results/referee/dreamer-direct-bc_physx_test.json"),
    ("scripted", "test_c025", "docs/results/referee/scripted_mujoco_test_c025.json",
     "docs/results/referee/scripted_physx_test_c025.json"),
    ("scripted-direct", "test_c025", "docs/results/referee/scripted-direct_mujoco_test_c025.json",
     "docs/results/referee/scripted-direct_physx_test_c025.json"),
    ("sac-direct-bc", "test_c025", "checkpoints/sac-direct-bc/eval_test_c025.json",
     "docs/results/referee/sac-direct-bc_physx_test_c025.json"),
)  # fmt: skip
"""The referee page: (agent, split, its MuJoCo evaluation, its PhysX evaluation); rows whose
files are missing are left out."""


def referee_table() -> str:
    """MuJoCo against PhysX (docs/results/referee/table.md), from the evaluation files."""
    import json

    head = (
        "| agent | split | engine | episodes | success | median time to success | truncated "
        "| failed | unstable |\n|---|---|---|---|---|---|---|---|---|"
    )
    rows = [head]
    for agent, split, *files in REFEREE:
        for f in files:
            path = ROOT / f
            if not path.exists():
                continue
            d = json.loads(path.read_text())
            engine = d.get("engine", "mujoco")
            step = d.get("timestep")
            rows.append(
                f"| {agent} | {split} | {engine} ({step * 1e3:g} ms) | {d['episodes']} "
                f"({d['attempts']} × {d['episodes'] // d['attempts']}) | "
                f"{100 * d['success_rate']:.2f} % | {d['median_time_to_success_s']:.2f} s | "
                f"{100 * d['truncation_rate']:.2f} % | {100 * d['failure_rate']:.2f} % | "
                f"{d.get('unstable', 0)} |"
            )
    rows += [
        "",
        "The transfer, module by module: on the modules both files evaluated, the success rate in "
        "each engine (each module weighted alike), PhysX's minus MuJoCo's, and how many modules "
        "fell short of 100 % in one engine, the other or both (a module played 10 times falls "
        "short more easily than one played twice).",
        "",
        "| agent | split | modules | MuJoCo | PhysX | gap | short in both | MuJoCo only "
        "| PhysX only |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for agent, split, mujoco, physx in REFEREE:
        if not ((ROOT / mujoco).exists() and (ROOT / physx).exists()):
            continue
        m, p = (json.loads((ROOT / f).read_text())["per_module"] for f in (mujoco, physx))
        common = sorted(set(m) & set(p))
        rm, rp = (sum(r[k] for k in common) / len(common) for r in (m, p))
        short = [(m[k] < 1, p[k] < 1) for k in common]
        rows.append(
            f"| {agent} | {split} | {len(common)} | {100 * rm:.2f} % | {100 * rp:.2f} % "
            f"| {100 * (rp - rm):+.2f} | {short.count((True, True))} "
            f"| {short.count((True, False))} | {short.count((False, True))} |"
        )
    return "\n".join(rows) + "\n"


ROBOT_AGENTS = ("scripted", "scripted-direct", "sac-teacher-free", "sac-direct-bc",
                "sac-fast-bc", "dreamer-direct-bc")  # fmt: skip
"""The robot page's shipped agents: for each registered robot (sim/robots/registry.py) ROBOT
and clearance, docs/results/robot/AGENT_{none,ROBOT}_test64{SUFFIX}.json, the floating peg and
the robot on the first 64 test modules; both success rates are over the modules the robot holds
(it refuses some by name). Rows whose files are missing are left out."""
ROBOT_CLEARANCES = (("1 mm", ""), ("0.25 mm", "_c025"))
"""(clearance, file suffix): the test split, and its first 64 modules at 0.25 mm
(`assetgen sample --n 64 --seed 2048 --clearance-mm 0.25`)."""
ROBOT_TRAINED = (
    ("sac-teacher-free recipe, trained on the arm", "arm-sac"),
    ("the same with the wrist reading", "arm-sac-wrist"),
    ("the recipe with --inside-starts 0.25, trained on the arm", "arm-sac-inside"),
)
"""Policies trained on the robot: (label, NAME); their files NAME_sSEED_{none,ROBOT}_test64
{SUFFIX}.json, one a seed (a policy with the wrist reading has no floating file)."""


def robot_files(agent: str, robot: str, suffix: str = "") -> tuple[Path, Path]:
    """The floating peg's and `robot`'s evaluation files of `agent` on the robot page."""
    return tuple(RESULTS / "robot" / f"{agent}_{r}_test64{suffix}.json" for r in ("none", robot))


def _held_rate(doc: dict, held: list[str]) -> float:
    """A document's success rate over the modules `held` (its per-module rates)."""
    return float(np.mean([doc["per_module"][m] for m in held]))


def robot_table() -> str:
    """The floating peg against each robot (docs/results/robot/table.md), from the
    evaluation files: the shipped agents unchanged, then the policies trained on the robot
    (mean ± std over their seeds)."""
    import json

    from sim.robots.registry import ROBOTS

    rows = [
        "| clearance | agent | robot | modules × attempts | floating | robot | gap | median "
        "time (floating / robot) | robot truncated / failed |\n" + "|---" * 9 + "|"
    ]
    for robot in ROBOTS.values():
        for clearance, suffix in ROBOT_CLEARANCES:
            for agent in ROBOT_AGENTS:
                files = robot_files(agent, robot.name, suffix)
                if not all(f.exists() for f in files):
                    continue
                free, arm = (json.loads(f.read_text()) for f in files)
                assert free.get("robot") is None and arm.get("robot") == robot.name, agent
                held = list(arm["per_module"])  # the floating peg on the modules it holds
                floating = _held_rate(free, held)
                rows.append(
                    f"| {clearance} | {agent} | {robot.label} | {len(held)} of "
                    f"{free['modules']} × {arm['attempts']} | {100 * floating:.2f} % | "
                    f"{100 * arm['success_rate']:.2f} % | "
                    f"{100 * (arm['success_rate'] - floating):+.2f} | "
                    f"{free['median_time_to_success_s']:.2f} / "
                    f"{arm['median_time_to_success_s']:.2f} s | "
                    f"{100 * arm['truncation_rate']:.2f} / {100 * arm['failure_rate']:.2f} % |"
                )
            for label, name in ROBOT_TRAINED:
                seeds = sorted(RESULTS.glob(f"robot/{name}_s*_{robot.name}_test64{suffix}.json"))
                if not seeds:
                    continue
                arms = [json.loads(f.read_text()) for f in seeds]
                held = list(arms[0]["per_module"])
                frees = [
                    json.loads(f.read_text())
                    for f in (Path(str(g).replace(f"_{robot.name}_", "_none_")) for g in seeds)
                    if f.exists()
                ]

                def pm(values: list[float]) -> str:
                    return f"{100 * np.mean(values):.2f} ± {100 * np.std(values):.2f} %"

                a = [d["success_rate"] for d in arms]
                f = [_held_rate(d, held) for d in frees]
                steps = sorted({d["trained_env_steps"] for d in arms})
                rows.append(
                    f"| {clearance} | {label} ({len(arms)} seeds, {steps[0] / 1e6:.2f}–"
                    f"{steps[-1] / 1e6:.2f} M env steps) | {robot.label} | {len(held)} of "
                    f"{arms[0]['modules']} × {arms[0]['attempts']} | "
                    f"{pm(f) if frees else '–'} | {pm(a)} | "
                    f"{f'{100 * (np.mean(a) - np.mean(f)):+.2f}' if frees else '–'} | – | "
                    f"{100 * np.mean([d['truncation_rate'] for d in arms]):.2f} / "
                    f"{100 * np.mean([d['failure_rate'] for d in arms]):.2f} % |"
                )
    return "\n".join(rows) + "\n"


TAKEOFF_STALL_STEPS = 1_000_000
"""The take-off page's stall: no training success >= 10 % by this many env steps."""


def takeoff_table() -> str:
    """Take-off and stalls of the teacher-free candidates (docs/results/takeoff/table.md),
    from the recipe's filed Table III runs and the run folders filed under
    docs/results/runs/takeoff/ (config.json, metrics.csv): one row a run, then each
    candidate's stall rate (benchmarks/takeoff.py)."""
    from benchmarks.takeoff import env_labels, stall_rates, takeoff
    from rl.report_load import load_run

    # a candidate: the run's variant (algorithm, --set fields) and the env options that set
    # it apart (--near-starts, ...)
    recipe = [r for r in filed_runs("table3") if "/sac-symlog-n3-gs05-g098-" in r]
    paths = [str(ROOT / r) for r in (*recipe, *filed_runs("takeoff"))]
    labels = env_labels(paths) if paths else []
    rows = [
        takeoff(replace(load_run(p), variant=_candidate(p, extra)), 0.10, TAKEOFF_STALL_STEPS)
        for p, extra in zip(paths, labels, strict=True)
    ]
    rows.sort(key=lambda r: (r.variant, r.seed))
    out = [
        f"Take-off: the first training success >= 10 % (over the last 100 or more finished "
        f"episodes, all ended after the warm-up); a stall: none by "
        f"{TAKEOFF_STALL_STEPS / 1e6:g} M env steps.\n",
        "| candidate | seed | take-off, env steps | minutes | env steps run | training "
        "success at the end |\n" + "|---" * 6 + "|",
    ]
    for r in rows:
        out.append(
            f"| {r.variant} | {r.seed} | {r.at} | {r.minutes_text} | "
            f"{r.reached_steps / 1e6:.2f} M | {100 * r.last_success:.1f} % |"
        )
    out.append("\n| candidate | stalled | seeds |\n|---|---|---|")
    for variant, (stalled, decided) in stall_rates(rows).items():
        seeds = ", ".join(str(r.seed) for r in rows if r.variant == variant)
        out.append(f"| {variant} | {stalled} of {decided} | {seeds} |")
    return "\n".join(out) + "\n"


def _candidate(path: str, extra: str) -> str:
    """ "the recipe" (the README's teacher-free SAC, benchmarks/table3.py) and the run's other
    --set fields and env options, or its variant where it is not the recipe's."""
    import json

    from assetgen.core.overrides import parse_overrides
    from benchmarks.table3 import RECIPE_OVERRIDES
    from rl.configs import SACConfig
    from rl.report_load import variant_name

    meta = json.loads((Path(path) / "config.json").read_text())
    over = meta.get("overrides") or {}
    recipe = parse_overrides(SACConfig, list(RECIPE_OVERRIDES))
    if (
        meta["algo"] != "sac"
        or meta.get("demos")
        or any(over.get(k) != v for k, v in recipe.items())
    ):
        name = variant_name(meta["algo"], int(meta.get("stack", 1)), meta.get("demos"), over)
        return f"{name} {extra}".strip()
    rest = [f"{k}={v}" for k, v in sorted(over.items()) if k not in recipe]
    return ", ".join(["the recipe", *rest, *([extra] if extra else [])])


ASSEMBLY: tuple[tuple[str, str], ...] = (
    ("scripted expert", "docs/results/assembly/scripted_assembly_test.json"),
    ("`sac-direct-bc`, zero-shot", "docs/results/assembly/sac-direct-bc_assembly_test.json"),
    ("scripted expert", "docs/results/assembly/scripted_assembly_test_c1.json"),
    ("`sac-direct-bc`, zero-shot", "docs/results/assembly/sac-direct-bc_assembly_test_c1.json"),
)  # fmt: skip
"""The assembly page: (agent, its sequence evaluation); rows whose files are missing are left
out."""


def assembly_table() -> str:
    """The assembly sequences (docs/results/assembly/table.md), from the evaluation files."""
    import json

    rows = [
        "| agent | split | assemblies × attempts | profile | bolt | sequence | profile failed "
        "/ truncated | physics step | wall time |\n|---|---|---|---|---|---|---|---|---|"
    ]
    for agent, f in ASSEMBLY:
        path = ROOT / f
        if not path.exists():
            continue
        d = json.loads(path.read_text())
        profile, bolt = d["stages"]
        gaps = " / ".join(f"{1e3 * st['clearance_m'][0]:g}" for st in d["stages"])

        def rate(st: dict) -> str:
            return f"{100 * st['success_rate']:.2f} % ({st['median_time_to_success_s']:.2f} s)"

        rows.append(
            f"| {agent} | {d['dataset']} ({gaps} mm) | {d['assemblies']} × {d['attempts']} "
            f"| {rate(profile)} | {rate(bolt)} | {rate(d['sequence'])} "
            f"| {100 * profile['failure_rate']:.2f} / {100 * profile['truncation_rate']:.2f} % "
            f"| {d['timestep'] * 1e3:g} ms | {d['seconds']:.0f} s |"
        )
    return "\n".join(rows) + "\n"


FAMILIES: tuple[tuple[str, str], ...] = (
    ("scripted expert", "scripted"),
    ("direct expert", "scripted-direct"),
    ("`sac-teacher-free`, zero-shot", "sac-teacher-free"),
    ("`sac-direct-bc`, zero-shot", "sac-direct-bc"),
    ("`sac-fast-bc`, zero-shot", "sac-fast-bc"),
    ("`dreamer-direct-bc`, zero-shot", "dreamer-direct-bc"),
)
"""The families page: (agent, its name in docs/results/families/<name>_<split>.json)."""
FAMILY_SPLITS = ("profile_test", "multi_peg_test")
"""The test splits of the families beyond Table I, each a row per agent whose file exists."""


def families_table() -> str:
    """The agents on each family's test split (docs/results/families/table.md), from the
    evaluation files (`assetgen eval ... --dataset <split> --attempts 1`)."""
    import json

    rows = [
        "| agent | family | split (clearance) | modules × attempts | success (median time) "
        "| failed / truncated | wall time |\n|---|---|---|---|---|---|---|"
    ]
    for split in FAMILY_SPLITS:
        for agent, name in FAMILIES:
            path = RESULTS / "families" / f"{name}_{split}.json"
            if not path.exists():
                continue
            d = json.loads(path.read_text())
            (stage,) = d["stages"]  # a family of one step
            gap = " / ".join(f"{1e3 * c:g}" for c in stage["clearance_m"])
            median = stage["median_time_to_success_s"]
            rate = f"{100 * stage['success_rate']:.2f} % ({median:.2f} s)"
            rows.append(
                f"| {agent} | {d['family']} | {d['dataset']} ({gap} mm) "
                f"| {d['assemblies']} × {d['attempts']} "
                f"| {rate} "
                f"| {100 * stage['failure_rate']:.2f} / {100 * stage['truncation_rate']:.2f} % "
                f"| {d['seconds']:.0f} s |"
            )
    contacts = [RESULTS / "families" / f"stress_{split}.json" for split in FAMILY_SPLITS]
    contacts = [c for c in contacts if c.exists()]
    if contacts:
        rows += ["", *_contact_rows(contacts)]
    return "\n".join(rows) + "\n"


def _contact_rows(paths: list[Path]) -> list[str]:
    """The contact stress benchmark on the families' test splits (`assetgen bench contacts
    SPLIT --limit N --json stress_SPLIT.json`): one row a split, then the targets it misses."""
    import json

    def mm(x: float, c: float) -> str:
        return f"{x * 1e3:.3f} mm ({100 * x / c:.0f} %)"

    out = [
        "The contact stress benchmark (`assetgen bench contacts SPLIT --limit N`), floating peg:\n",
        "| split | modules | pass-throughs | penetration worst / p99 | depth at rest, worst "
        "| straight / twisting pushes not at rest | impacts not at rest | rebound e, worst "
        "| targets missed |\n" + "|---" * 9 + "|",
    ]
    for path in paths:
        d = json.loads(path.read_text())
        (s,) = d["summaries"]
        c = s["clearance"]
        missed = ", ".join(k for k, ok in s["targets"].items() if not ok) or "none"
        out.append(
            f"| {Path(d['dataset']).name} | {s['modules']} | {s['passed_through']} "
            f"| {mm(s['penetration_worst'], c)} / {mm(s['penetration_p99'], c)} "
            f"| {mm(s['rest_depth_worst'], c)} "
            f"| {s['straight_not_at_rest']} of {s['straight_pushes']} / "
            f"{s['twisting_not_at_rest']} of {s['twisting_pushes']} "
            f"| {s['impacts_not_at_rest']} of {s['impacts']} | {s['rebound_worst']:.3f} "
            f"| {missed} |"
        )
    return out


CHAMFER_AGENTS: tuple[tuple[str, str], ...] = (
    ("scripted expert", "scripted"),
    ("direct expert", "scripted-direct"),
    ("`sac-direct-bc`, zero-shot", "sac-direct-bc"),
    ("`sac-teacher-free`, zero-shot", "sac-teacher-free"),
)
"""The chamfers page: (agent, its name in docs/results/chamfers/<name>_<split>.json)."""
CHAMFER_SPLITS = (
    ("test64_c025", "none"),
    ("test64_c025_chamfered", "peg 1 mm, entrance 1.5 mm, 45°"),
)
"""The chamfers page's datasets: the first 64 test modules at 0.25 mm, without and with
chamfers (`assetgen sample --n 64 --seed 2048 --clearance-mm 0.25 --formats mjcf
[--peg-chamfer 1 --hole-chamfer 1.5] --out datasets/<split>`: the same seeds, so the same
modules but for their chamfers; without them, the robot page's `test64_c025`)."""


def chamfers_table() -> str:
    """The agents on the same modules without and with chamfers (docs/results/chamfers/
    table.md), from the evaluation files (`assetgen eval ... --attempts 4 --out ...`)."""
    import json

    rows = [
        "| agent | chamfers | dataset | episodes | success (median time) | failed / truncated |"
        "\n|---|---|---|---|---|---|"
    ]
    for agent, name in CHAMFER_AGENTS:
        for split, chamfers in CHAMFER_SPLITS:
            path = RESULTS / "chamfers" / f"{name}_{split}.json"
            if not path.exists():
                continue
            d = json.loads(path.read_text())
            rows.append(
                f"| {agent} | {chamfers} | {split} ({d['dataset_hash'][:16]}) | {d['episodes']} "
                f"| {100 * d['success_rate']:.2f} % ({d['median_time_to_success_s']:.2f} s) "
                f"| {100 * d['failure_rate']:.2f} / {100 * d['truncation_rate']:.2f} % |"
            )
    return "\n".join(rows) + "\n"


def superseded_variants(page: Page) -> frozenset[str]:
    """The variant names of the page's filed Table III lanes whose row a later candidate
    superseded (benchmarks/table3.py's Row.superseded_by): the full table keeps them, the
    README's leaves them out."""
    import json

    from benchmarks.table3 import ROWS
    from rl.report_load import env_words, variant_name

    names = set()
    for run in page.run_paths():
        row = ROWS.get(run.name.rsplit("-s", 1)[0])
        if run.parent.name == "table3" and row is not None and row.superseded_by is not None:
            meta = json.loads((run / "config.json").read_text())
            name = variant_name(meta["algo"], int(meta.get("stack", 1)), meta.get("demos"),
                                meta.get("overrides"))  # fmt: skip
            names.add(f"{name} {env_words(meta.get('env_options') or {})}".strip())
    return frozenset(names)


def page_table(page: Page, compact: bool = False) -> str:
    """The markdown table the page's inputs give now; compact: the README's short form."""
    from rl.report import load_summary
    from rl.report_tables import compact_table, markdown_table

    summary, _ = load_summary(page.run_paths(), page.baseline_paths(), page.screening)
    if compact:
        return compact_table(
            summary, f"docs/results/{page.name}/table.md", superseded_variants(page)
        )
    return markdown_table(summary, paper=not page.screening)


def readme_table() -> str:
    """The table between the markers in README.md ('' without them)."""
    import re

    from rl.report import TABLE_BEGIN, TABLE_END

    text = (ROOT / "README.md").read_text()
    m = re.search(re.escape(TABLE_BEGIN) + r"\n(.*?)" + re.escape(TABLE_END), text, re.S)
    return m.group(1).strip() if m else ""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only compare; exit 1 if stale")
    args = ap.parse_args(argv)
    from rl.report import TABLE_BEGIN, TABLE_END, replace_table, write_report

    stale = []
    for page in PAGES:
        out = RESULTS / page.name
        table = out / "table.md"
        if args.check:
            now = page_table(page).strip()
            if not table.exists() or table.read_text().strip() != now:
                stale.append(page.name)
            if page.readme and readme_table() != page_table(page, compact=True).strip():
                stale.append("README.md")
            continue
        write_report(
            page.run_paths(),
            page.baseline_paths(),
            out,
            label_runs=page.screening,
            paper=not page.screening,
        )
        print(f"wrote {out.relative_to(ROOT)}/")
        if page.readme:
            replace_table(ROOT / "README.md", page_table(page, compact=True))
            print(f"wrote its table into README.md ({TABLE_BEGIN} … {TABLE_END})")
    pages = (
        ("referee", referee_table),
        ("assembly", assembly_table),
        ("families", families_table),
        ("chamfers", chamfers_table),
        ("robot", robot_table),
        ("takeoff", takeoff_table),
    )
    for name, make in pages:
        path = RESULTS / name / "table.md"
        if args.check:
            if not path.exists() or path.read_text() != make():
                stale.append(name)
            continue
        from assetgen.core.atomic_file import write_text

        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, make())
        print(f"wrote {path.relative_to(ROOT)}")
    if stale:
        print(f"stale: {', '.join(stale)}; run python -m benchmarks.results_pages", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
