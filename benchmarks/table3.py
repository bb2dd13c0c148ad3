"""Table III's teacher-free rows on this machine, one seed at a time: train, evaluate, file.

    python -m benchmarks.table3 ROW --seed S [--minutes 60] [--threads 1]
    python -m benchmarks.table3 --next [--lanes N] # the lanes still to do, one after another
    python -m benchmarks.table3 --plan            # every row × seed: what each still needs,
                                                  # which process runs it, how far it got

ROW is one of ROWS (random, ppo, ppo-stack, sac, sac-stack, dreamer: the paper's; sac-symlog,
sac-symlog-n3, sac-symlog-n3-gs05, sac-symlog-n3-gs05-g098: the best teacher-free candidates
screened, 120 minutes). A trained row runs

    assetgen train --algo ALGO [--stack 10] [--set FIELD=VALUE] --dataset train --minutes M \\
        --seed S --threads T --out runs/table3/ROW-sS

and evaluates the run on the test split under the paper's protocol (every module × 10
attempts), with its mean action (the paper's) and with sampled actions. It then copies the
run's config.json, metrics.csv and both evaluation files into docs/results/runs/table3/ROW-sS,
where `python -m benchmarks.results_pages` reads them (the weights stay in runs/). The
random row is its evaluation alone, seeded S, filed in docs/results/baselines/.

Every stage is skipped when its output exists, a training cut short goes on from its last
checkpoint (`--minutes` is the whole run's budget) and an evaluation from its last snapshot
(both five minutes apart): the same command picks up where a stopped session left it. A
filed lane is done for `--next` and `--plan` (a fresh clone has no runs/; naming the lane
reruns it), and a lane builds its splits from their specs in datasets/ when they are missing
(seconds). Two lanes at a time on the 2-core machine, one torch thread each, as the
published rows were run: two `--next` processes share the lanes (each claims the one it runs
in a file beside the runs; a claim whose process has gone is taken over). They train side by
side and take turns to evaluate, since an evaluation's simulator threads use both cores;
`--lanes 1` in each files two lanes in about two and a half hours. A candidate row that a
later one superseded is left out of `--next`; its seeds still run by name.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

from evaluation.snapshots import snapshot_path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
"""Where lanes file their results: runs/table3/ROW-sS and baselines/random_test_sS.json."""
SEEDS = (0, 1, 2)
"""The seeds of a row: three, the least a learned figure is reported over."""
RUN_FILES = ("config.json", "metrics.csv")
EVALS = {"eval_test.json": (), "eval_test_sampled.json": ("--stochastic",)}
"""The evaluation files of a trained row and the `assetgen eval` flags that make them."""


@dataclass(frozen=True)
class Row:
    """A Table III row: how `assetgen train` makes it."""

    algo: str
    stack: int = 1
    overrides: tuple[str, ...] = ()
    """`--set FIELD=VALUE` overrides of the preset's config (a screened candidate's)."""
    flags: tuple[str, ...] = ()
    """Further `assetgen train` flags: the env's training options (e.g. --inside-starts)."""
    minutes: float | None = None
    """The row's own training budget; None: the lane's --minutes (60, the paper's rows)."""
    superseded_by: str | None = None
    """The candidate row that replaced this one: `--next` leaves the seeds it has not filed
    (two hours each, for a recipe no longer the best); its filed seeds stay on the pages and
    `python -m benchmarks.table3 ROW --seed S` still runs one."""


RECIPE_OVERRIDES = ("obs_symlog_scale=1000", "n_step=3", "gradient_steps=0.5", "gamma=0.98")
"""The teacher-free recipe's overrides (the README's), of its row and its candidates'."""

ROWS: dict[str, Row] = {
    "random": Row("random"),
    "ppo": Row("ppo"),
    "ppo-stack": Row("ppo", 10),
    "sac": Row("sac"),
    "sac-stack": Row("sac", 10),
    "dreamer": Row("dreamer"),
    "sac-symlog": Row(
        "sac",
        overrides=("obs_symlog_scale=1000",),
        minutes=120.0,
        superseded_by="sac-symlog-n3-gs05-g098",
    ),
    "sac-symlog-n3": Row(
        "sac",
        overrides=("obs_symlog_scale=1000", "n_step=3"),
        minutes=120.0,
        superseded_by="sac-symlog-n3-gs05-g098",
    ),
    "sac-symlog-n3-gs05": Row(
        "sac",
        overrides=("obs_symlog_scale=1000", "n_step=3", "gradient_steps=0.5"),
        minutes=120.0,
        superseded_by="sac-symlog-n3-gs05-g098",
    ),
    "sac-symlog-n3-gs05-g098": Row("sac", overrides=RECIPE_OVERRIDES, minutes=120.0),
    "sac-symlog-n3-gs05-g098-inside25": Row(
        "sac",
        overrides=RECIPE_OVERRIDES,
        flags=("--inside-starts", "0.25"),
        minutes=120.0,
    ),
    "sac-symlog-n3-gs05-g098-inside25-until10": Row(
        "sac",
        overrides=RECIPE_OVERRIDES,
        flags=("--inside-starts", "0.25", "--inside-starts-until", "0.1"),
        minutes=120.0,
    ),
}
"""The paper's rows ("-stack": its STACK variant, the last 10 observations), then the best
teacher-free candidates of the screening (docs/results/README.md), with their overrides and
their two hours: SAC on symlog observations, then the same with 3-step returns, then with
half a gradient step per env step as well (more env steps in the two hours), then with a
discount of 0.98 as well (the return of a success is 1 whatever its time: only the discount
rewards speed), then the same with a quarter of the training episodes started inside the
hole (a reverse curriculum's first stage: it takes off on the seeds the recipe stalls on),
then the same with the inside starts ended at take-off (10 % of 256 task episodes in a row)."""


def run_dir(runs: Path, row: str, seed: int) -> Path:
    return runs / f"{row}-s{seed}"


def filed_dir(results: Path, row: str, seed: int) -> Path:
    return run_dir(results / "runs" / "table3", row, seed)


def random_file(results: Path, seed: int) -> Path:
    return results / "baselines" / f"random_test_s{seed}.json"


def stages(row: str, seed: int, runs: Path, results: Path) -> list[tuple[str, str]]:
    """(stage, mark) in order: "+" done, "~" begun (a training's checkpoint, an
    evaluation's snapshot), "-" to do."""
    if row == "random":
        return [("evaluate", "+" if random_file(results, seed).exists() else "-")]
    run, filed = run_dir(runs, row, seed), filed_dir(results, row, seed)
    if all((filed / f).exists() for f in (*RUN_FILES, *EVALS)):
        # filed is done, whether or not its run folder (the weights) is still here: a
        # fresh clone has no runs/ and must not train a filed lane again
        return [(name, "+") for name in ("train", *(f"evaluate {n}" for n in EVALS), "file")]
    evaluated = [(run / name).exists() for name in EVALS]
    begun = (run / "checkpoint.safetensors").exists()
    marks = [("train", "+" if any(evaluated) else "~" if begun else "-")]
    marks += [
        (f"evaluate {name}", "+" if ok else "~" if snapshot_path(run / name).exists() else "-")
        for name, ok in zip(EVALS, evaluated, strict=True)
    ]
    marks.append(("file", "-"))
    return marks


def holder(runs: Path, row: str, seed: int) -> int | None:
    """The pid of the live process that holds the lane's claim, else None."""
    try:
        pid = int((runs / f".{row}-s{seed}.claim").read_text() or 0)
        os.kill(pid, 0)
    except PermissionError:  # a live process of another user
        return pid
    except (OSError, ValueError):  # no claim, or its holder is gone
        return None
    return pid


def lane(
    row: str,
    seed: int,
    minutes: float,
    threads: int,
    runs: Path,
    dataset: str,
    test: str,
    results: Path = RESULTS,
    preset: str = "cpu",
    attempts: int = 10,
) -> int:
    """Run what the lane still needs; 0 when its results are filed."""
    from cli import main as assetgen

    def call(argv: list[str]) -> None:
        print("assetgen " + " ".join(argv), flush=True)
        rc = assetgen(argv)
        if rc:
            raise SystemExit(f"assetgen {argv[0]} stopped with exit code {rc}")

    if row == "random":
        out = random_file(results, seed)
        if not out.exists():
            out.parent.mkdir(parents=True, exist_ok=True)
            call(["eval", "--agent", "random", "--dataset", test, "--attempts", str(attempts),
                  "--seed", str(seed), "--out", str(out)])  # fmt: skip
        return 0
    spec = ROWS[row]
    run = run_dir(runs, row, seed)
    from assetgen.dataset.spec import DatasetError, resolve

    for split in (dataset, test):  # a fresh clone has the specs alone: build them (seconds)
        try:
            folder, named = resolve(split)
        except DatasetError:
            continue  # neither a spec nor a folder: `assetgen train` says so
        if named is not None and not (folder / "dataset.json").exists():
            call(["sample", "--dataset", split, "--quiet"])
    minutes = spec.minutes if spec.minutes is not None else minutes
    train = ["train", "--algo", spec.algo, "--preset", preset, "--dataset", dataset,
             "--minutes", f"{minutes:g}",
             "--seed", str(seed), "--threads", str(threads), "--out", str(run)]  # fmt: skip
    if spec.stack > 1:
        train += ["--stack", str(spec.stack)]
    for kv in spec.overrides:
        train += ["--set", kv]
    train += list(spec.flags)
    # always called: a finished run returns at once (its budget is spent), a cut one goes on
    call(train + (["--resume"] if (run / "checkpoint.safetensors").exists() else []))
    todo = {name: flags for name, flags in EVALS.items() if not (run / name).exists()}
    with evaluation_turn(runs) if todo else contextlib.nullcontext():
        for name, flags in todo.items():
            call(["eval", "--checkpoint", str(run), "--dataset", test, "--attempts", str(attempts),
                  "--threads", str(threads), *flags, "--out", str(run / name)])  # fmt: skip
    file_run(run, filed_dir(results, row, seed), {f: f for f in (*RUN_FILES, *EVALS)})
    return 0


@contextlib.contextmanager
def evaluation_turn(runs: Path):
    """Hold the lanes' one evaluation turn (an advisory lock on runs/.evaluate.lock; the
    kernel drops it when its process dies). An evaluation's simulator threads use every
    core, so the lane beside waits its turn instead of halving it: the first lane to finish
    training is filed about an hour sooner, before a stopped machine can cost it."""
    runs.mkdir(parents=True, exist_ok=True)
    with open(runs / ".evaluate.lock", "w") as f:
        try:
            import fcntl
        except ImportError:  # Windows: no advisory locks, lanes evaluate side by side
            yield
            return
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            print("waiting for the other lane's evaluation", flush=True)
            fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def file_run(run: Path, filed: Path, files: dict[str, str]) -> None:
    """Copy a run's files {name in the run: name filed} into `filed`, whole or not at all
    (a temporary folder, renamed), replacing what was filed there before."""
    tmp = filed.with_name(f".{filed.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    for src, dst in files.items():
        shutil.copy2(run / src, tmp / dst)
    shutil.rmtree(filed, ignore_errors=True)
    tmp.rename(filed)
    print(f"filed {filed}: run python -m benchmarks.results_pages")


def lanes() -> list[tuple[str, int]]:
    """Every lane, in the order `--next` takes them: row by row in the paper's order (the
    random row first, an evaluation alone), seeds 0, 1, 2, so whole rows fill first; the
    rows a later candidate superseded are left out."""
    return [(row, seed) for row, r in ROWS.items() if r.superseded_by is None for seed in SEEDS]


def _claim(runs: Path, row: str, seed: int) -> Path | None:
    """Claim a lane for this process (a file naming its pid, created exclusively); None
    when a live process holds it. A claim whose process is gone (a stopped session) is
    taken over."""
    runs.mkdir(parents=True, exist_ok=True)
    claim = runs / f".{row}-s{seed}.claim"
    for _ in range(2):
        try:
            fd = os.open(claim, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            try:
                pid = int(claim.read_text() or 0)
                os.kill(pid, 0)  # raises when no such process
                return None
            except (ValueError, ProcessLookupError, FileNotFoundError):
                claim.unlink(missing_ok=True)  # stale: its holder is gone
                continue
            except PermissionError:  # a live process of another user
                return None
        with os.fdopen(fd, "w") as f:
            f.write(str(os.getpid()))
        return claim
    return None


def next_lanes(runs: Path, results: Path, run_lane, limit: int | None = None) -> int:
    """Run the lanes that are not filed and not held by another process, in `lanes()`
    order, until none is left (or `limit` lanes ran). Two such processes share the work."""
    done = 0
    for row, seed in lanes():
        if limit is not None and done >= limit:
            break
        if all(mark == "+" for _, mark in stages(row, seed, runs, results)):
            continue
        claim = _claim(runs, row, seed)
        if claim is None:
            continue
        try:
            print(f"lane {row} seed {seed}", flush=True)
            run_lane(row, seed)
            done += 1
        finally:
            claim.unlink(missing_ok=True)
    return done


def progress(row: str, seed: int, runs: Path) -> str:
    """How far the lane's begun stages are: its training's env steps and minutes (from the
    checkpoint's header) and its evaluation's episodes (from the snapshot's); '' for none."""
    from evaluation.snapshots import snapshot_progress
    from rl.checkpoint import CheckpointError, read_counters

    run = run_dir(runs, row, seed)
    parts = []
    if (run / "checkpoint.safetensors").exists() and not any((run / n).exists() for n in EVALS):
        try:
            c = read_counters(run)
            parts.append(
                f"trained {c['env_steps'] / 1e6:.2f} M env steps, {c['wall_s'] / 60:.0f} min"
            )
        except (CheckpointError, KeyError):
            pass
    for name in EVALS:
        got = snapshot_progress(snapshot_path(run / name)) if not (run / name).exists() else None
        if got is not None:
            parts.append(f"{name}: {got['episodes']:.0f} episodes, {got['seconds'] / 60:.0f} min")
    return "; ".join(parts)


def plan(runs: Path, results: Path = RESULTS) -> str:
    """One line per row and seed: its stages, done (+), begun (~) or still to do (-), and
    the process running it."""
    lines = []
    width = max(map(len, ROWS))
    for row in ROWS:
        for seed in SEEDS:
            staged = stages(row, seed, runs, results)
            marks = " ".join(m + name for name, m in staged)
            later = ROWS[row].superseded_by
            if later and any(m != "+" for _, m in staged):
                marks += f" (superseded by {later}: not in --next)"
            pid = holder(runs, row, seed)
            if pid is not None:
                marks += f" (running: pid {pid})"
            if row != "random":
                done = progress(row, seed, runs)
                marks += f" [{done}]" if done else ""
            lines.append(f"{row:{width}s} seed {seed}: {marks}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("row", nargs="?", choices=sorted(ROWS), help="the Table III row")
    ap.add_argument("--seed", type=int, help="the row's seed (0, 1, 2 make the table)")
    ap.add_argument("--minutes", type=float, default=60.0,
                    help="training budget (wall clock); a row with its own keeps it")  # fmt: skip
    ap.add_argument("--threads", type=int, default=1, help="torch threads (1: two lanes at once)")
    ap.add_argument("--runs", type=Path, default=ROOT / "runs" / "table3", help="run folders")
    ap.add_argument("--dataset", default="train", help="the training split")
    ap.add_argument("--test", default="test", help="the evaluation split")
    ap.add_argument("--preset", default="cpu", help="the agents' preset (rl/presets.py)")
    ap.add_argument("--attempts", type=int, default=10, help="episodes a module (10: the paper)")
    ap.add_argument("--results", type=Path, default=RESULTS, help="where results are filed")
    ap.add_argument("--plan", action="store_true", help="list every lane and what it needs")
    ap.add_argument(
        "--next",
        action="store_true",
        help="run the lanes still to do, in order, skipping those another process holds "
        "(start two for the 2-core machine)",
    )
    ap.add_argument(
        "--lanes",
        type=int,
        default=None,
        help="with --next: run at most this many lanes, then stop (1 in each of two "
        "processes: two lanes filed in about two and a half hours)",
    )
    args = ap.parse_args(argv)
    if args.plan:
        print(plan(args.runs, args.results))
        return 0
    if args.minutes <= 0:
        ap.error(f"--minutes {args.minutes}: give a positive training budget")
    if args.lanes is not None and args.lanes < 1:
        ap.error(f"--lanes {args.lanes}: give at least 1 (or leave it out: every lane left)")

    def run_lane(row: str, seed: int) -> int:
        return lane(row, seed, args.minutes, args.threads, args.runs, args.dataset,
                    args.test, args.results, args.preset, args.attempts)  # fmt: skip

    if args.next:
        ran = next_lanes(args.runs, args.results, run_lane, limit=args.lanes)
        print(f"{ran} lanes run; python -m benchmarks.table3 --plan says what is left")
        return 0
    if args.row is None or args.seed is None:
        ap.error("give a ROW and --seed S, --next, or --plan")
    return run_lane(args.row, args.seed)


if __name__ == "__main__":
    sys.exit(main())
