"""The learning commands of `assetgen`; cli.py registers them and calls them:

    add_train_parser(subparsers, make_env, teachers, make_probe)    assetgen train ...
    add_report_parser(subparsers)                                   assetgen report ...
    add_export_parser(subparsers)                                   assetgen export ...

(`assetgen eval` is evaluation/command.py's; it uses print_error and torch_threads from here.)

`make_env(dataset: str, num_envs: int, seed: int, **task) -> VecEnv` (rl/vec_env.py; train passes
`curriculum_steps=N`, the length of the env's spawn curriculum, as a keyword) is supplied by
the caller, so rl/ never imports the simulator nor evaluation/: `teachers` maps `--demos`
names to policies (the scripted experts) and `make_probe` builds the probe of --probe-steps
(evaluation/probe.py's dataset_probe). For a dataset it cannot use, make_env raises
ValueError with a message for the user. Each parser sets `func(args) -> int` (an exit code),
as the other subcommands do.

    assetgen train --algo ppo|sac|dreamer|random [--stack 10] --dataset D [--preset cpu]
                   [--steps N | --minutes M] [--seed S] --out RUN_DIR [--resume]
                   [--envs N] [--device cpu|cuda] [--threads T] [--no-progress]
                   [--demos scripted] [--set FIELD=VALUE ...]
    assetgen report RUN_DIR... [--baselines FILE_OR_DIR...] --out DIR

`report` (add_report_parser) needs no env: it reads run folders and evaluation JSONs.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from assetgen.core.preflight import Bound, count, positive, seed, share
from rl.vec_env import VecEnv

CHECKPOINT_FILE = "checkpoint.safetensors"
"""A run folder's checkpoint (rl/checkpoint.py's FILE_NAME, named here without torch)."""

MakeEnv = Callable[..., VecEnv]
"""make_env(dataset, num_envs, seed, **task) -> a VecEnv; ValueError for a bad dataset
(one written for other physics among them, unless keep_physics=True)."""
Teacher = Callable[[np.ndarray], np.ndarray]
"""A policy of unstacked observations (N, obs_dim) -> actions (N, act_dim) in [-1, 1]."""
Probe = Callable[[Any], dict[str, float]]
"""agent -> the probe_* columns of that iteration's metrics row (rl/runner.py's `probe`)."""
MakeProbe = Callable[..., Probe]
"""make_probe(dataset, modules, attempts, stack, keep_physics=False, **engine) -> the probe
of `train --probe-steps`: the frozen policy on the dataset's first `modules` modules,
`attempts` episodes each, its observations stacked `stack` deep; ValueError for bad input."""


def parse_overrides(algo: str, items: list[str]) -> dict[str, Any]:
    """`--set FIELD=VALUE` items -> {field: value} for `algo`'s config, each value parsed as
    the field's default is typed (ValueError naming the field and the valid ones)."""
    from assetgen.core.overrides import parse_overrides as parse
    from rl.algorithms import config_class

    return parse(config_class(algo), items)


FLAGS = {
    "noise_scale": "--noise-scale",
    "num_envs": "--envs",
    "keep_physics=True": "--keep-dataset-physics",
    "checkpoint_minutes": "--checkpoint-minutes",
}
"""Library parameter names as the command line spells them, for error messages."""


def flag_words(message: str) -> str:
    """A library error in the command line's words: `noise_scale = 3` -> `--noise-scale 3`."""
    for name, flag in FLAGS.items():
        message = message.replace(f"{name} = ", f"{flag} ").replace(name, flag)
    return message


def print_error(message: str) -> int:
    """Print a one-line error for the user on stderr, library names as the command line
    spells them (flag_words); exit code 2."""
    from assetgen.core.console_output import print_error as print_line

    return print_line(flag_words(message))


def torch_threads(threads: int | None) -> int:
    """--threads, or by default half the cores (at least 1): the simulator's C threads need
    the rest, and oversubscribed torch threads spin."""
    import os

    return threads or max(1, (os.cpu_count() or 2) // 2)


TRAIN_NUMBERS = {
    "stack": count("stack at least 1 observation (1 = no stacking)"),
    "steps": count("give a positive number of env steps"),
    "minutes": positive("give a positive, finite duration in minutes"),
    "seed": seed(),  # numpy's global generator takes seeds below 2**32
    "envs": count("give at least 1 env, or leave it out (the preset's)"),
    "curriculum_steps": count("give 0 (off) or more steps", low=0),
    "curriculum_success": share("give a success rate in (0, 1], e.g. 0.8"),
    "module_replay": share(
        "give the share of modules drawn by their failures, in (0, 1], e.g. 0.5"
    ),
    "near_starts": share("give the share of episodes that start near the hole, in (0, 1]"),
    "inside_starts": share(
        "give the share of episodes that start inside the hole, in (0, 1), e.g. 0.25",
        whole=False,
    ),
    "inside_starts_until": share("give the task episodes' success rate that ends them, in (0, 1]"),
    "axis_shaping": Bound(low=0.0, hint="give a finite weight of 0 or more, e.g. 2"),
    "threads": count(),
    "probe_steps": count("give a positive number of steps"),
    "checkpoint_minutes": positive("give a positive, finite number of minutes"),
    "probe_modules": count(),
    "probe_attempts": count("give at least 1 probe episode per module"),
}
"""The bounds of train's numeric flags (assetgen.core.preflight), checked before any env is
built."""


def check_train_args(args: argparse.Namespace) -> None:
    """ValueError (PreflightError) for a flag of `train` that the run would fail on later:
    a number out of bounds, --out a file or in a place that cannot be written, --out holding
    a run without --resume or none with it."""
    from assetgen.core.preflight import PreflightError, check_numbers, check_output_folder

    check_numbers(args, TRAIN_NUMBERS)
    out = Path(args.out)
    check_output_folder(out, "--out")
    held = out / CHECKPOINT_FILE
    if getattr(args, "resume", False) and not held.is_file():
        raise PreflightError(
            f"--resume: no checkpoint at {held}; drop --resume to start a new run there"
        )
    if not getattr(args, "resume", False) and held.exists():
        raise PreflightError(
            f"{out} already holds a run ({CHECKPOINT_FILE}): pass --resume to continue it, "
            "or choose another --out folder"
        )


def add_train_parser(
    subparsers: argparse._SubParsersAction,
    make_env: MakeEnv,
    teachers: dict[str, Callable[[], Teacher]] | None = None,
    make_probe: MakeProbe | None = None,
    add_engine_argument: Callable[[argparse.ArgumentParser, str], None] | None = None,
) -> argparse.ArgumentParser:
    """Register `train` on an argparse subparsers object; `teachers` maps the names that
    --demos accepts to functions that build the policy; `make_probe` builds the probe of
    --probe-steps (MakeProbe); `add_engine_argument(parser, help)` adds the simulator's
    engine flag (`--sim`, which leaves `engine_options` for make_env), when the caller has
    engines to offer."""
    from rl.algorithms import ALGOS
    from rl.presets import PRESETS

    p = subparsers.add_parser(
        "train",
        help="train an agent (PPO, SAC, DreamerV3, random) on a dataset's modules",
        description="Train an agent on the vector env; progress bar, metrics.csv, TensorBoard "
        "and checkpoints in --out. --resume continues a run exactly (see rl/runner.py).",
    )
    p.add_argument("--algo", choices=sorted(ALGOS), required=True, help="algorithm")
    p.add_argument(
        "--stack",
        type=int,
        default=1,
        help="observations stacked, newest first (10: the paper's STACK; default 1)",
    )
    p.add_argument("--dataset", required=True, help="dataset spec name or folder")
    p.add_argument(
        "--preset",
        choices=sorted(PRESETS),
        default="cpu",
        help="hyperparameter preset (rl/presets.py; default cpu)",
    )
    budget = p.add_mutually_exclusive_group()
    budget.add_argument("--steps", type=int, help="total env steps (default: the preset's)")
    budget.add_argument(
        "--minutes",
        type=float,
        help="wall-clock budget of the run (with --resume: of the whole run, what the "
        "checkpoint had not spent)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    p.add_argument("--out", type=Path, required=True, help="run folder")
    p.add_argument("--resume", action="store_true", help="continue the run in --out")
    p.add_argument("--envs", type=int, help="parallel envs (default: the preset's)")
    if add_engine_argument is not None:
        add_engine_argument(
            p,
            "physics engine: MuJoCo (the simulator), PhysX (the referee, one env per module: "
            "--envs must cover the dataset; the physx extra) or MuJoCo Warp (the simulator's "
            "physics on a GPU; the warp extra)",
        )
    p.add_argument(
        "--curriculum-steps",
        type=int,
        help="env steps over which spawn ranges grow to full (default: the preset's; 0: off)",
    )
    p.add_argument(
        "--curriculum-success",
        type=float,
        metavar="RATE",
        help="widen the spawn ranges when the training episodes succeed at RATE or more "
        "(in (0, 1]; a success-gated curriculum instead of --curriculum-steps)",
    )
    p.add_argument(
        "--module-replay",
        type=float,
        metavar="SHARE",
        help="draw SHARE (in (0, 1]) of the next modules weighted by their recent failure "
        "rate instead of in turn (prioritized level replay; sim/task/module_replay.py)",
    )
    p.add_argument(
        "--near-starts",
        type=float,
        metavar="SHARE",
        help="start SHARE (in (0, 1]) of the training episodes near the hole, at 5 %% of the "
        "full spawn ranges, whatever the curriculum (the rest as without it)",
    )
    p.add_argument(
        "--inside-starts",
        type=float,
        metavar="SHARE",
        help="start SHARE (in (0, 1)) of the training episodes with the peg inside its hole, "
        "aligned, between the entrance and the seat (a reverse curriculum's first stage); "
        "they are left out of the training columns and of the curriculum's counts",
    )
    p.add_argument(
        "--inside-starts-until",
        type=float,
        metavar="RATE",
        help="stop the inside starts for good once 256 training episodes of the task's own "
        "starts in a row succeed at RATE (in (0, 1]) or more: the hand-over at take-off",
    )
    p.add_argument(
        "--axis-shaping",
        type=float,
        metavar="W",
        help="training shaping, not the paper's reward: add W times the peg's distance from "
        "the hole's axis to the distance to the seat, so that sliding onto the axis pays "
        "(>= 0; evaluation is unchanged)",
    )
    p.add_argument("--device", help="torch device (default: cuda when present, else cpu)")
    p.add_argument(
        "--threads",
        type=int,
        help="torch CPU threads (default: half the cores, at least 1: the simulator's C "
        "threads need the rest, and oversubscribed torch threads spin)",
    )
    p.add_argument(
        "--demos",
        help="learn from a teacher: it plays the warm-up (sac, dreamer) and, for sac, its "
        "actions label every stored observation for a behaviour-cloning term; one of "
        f"{sorted(teachers or {})}",
    )
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="replace a field of the preset's config (repeatable; e.g. --set bc_weight=0 for "
        "an ablation); the fields are the algorithm's config dataclass (rl/)",
    )
    p.add_argument(
        "--probe-steps",
        type=int,
        help="every this many env steps, run the frozen deterministic policy on fixed episodes "
        "of the training set and log probe_* columns (the training columns describe a policy "
        "that changes at every gradient step; default: no probe)",
    )
    p.add_argument(
        "--checkpoint-minutes",
        type=float,
        default=5.0,
        metavar="M",
        help="also checkpoint after the first iteration M minutes past the last checkpoint, so "
        "that a stopped machine costs at most about M minutes of training (default 5; raise "
        "it where a checkpoint is slow to write, e.g. a replay of many GB)",
    )
    p.add_argument(
        "--probe-modules",
        type=int,
        default=64,
        help="modules of the training set the probe plays, the first ones (default 64)",
    )
    p.add_argument(
        "--probe-attempts", type=int, default=2, help="probe episodes per module (default 2)"
    )
    p.add_argument(
        "--keep-dataset-physics",
        action="store_true",
        help="simulate a dataset written for other physics with the physics its files carry "
        "(default: refuse it and say how to regenerate it)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON line")
    p.set_defaults(func=lambda args: train_main(args, make_env, teachers or {}, make_probe))
    return p


def engine_options(args: argparse.Namespace) -> dict[str, Any]:
    """`engine=` for the env factories, as the engine flag (sim/engines/registry.py's
    add_engine_argument) left it: empty for the default engine."""
    return dict(getattr(args, "engine_options", None) or {})


def train_main(
    args: argparse.Namespace,
    make_env: MakeEnv,
    teachers: dict[str, Callable[[], Teacher]],
    make_probe: MakeProbe | None = None,
) -> int:
    """Run `train` from parsed arguments; prints a summary. Exit code 0, 1 on NaN."""
    import torch

    from rl.checkpoint import CheckpointError
    from rl.presets import get_setup
    from rl.runner import console, train

    try:
        check_train_args(args)  # before any env is built or anything written
        torch.set_num_threads(torch_threads(args.threads))
        setup = get_setup(args.preset, args.algo)
        curriculum = setup.curriculum_steps
        if args.curriculum_steps is not None:
            curriculum = args.curriculum_steps
        gated = getattr(args, "curriculum_success", None)
        if gated is not None and args.curriculum_steps is not None:
            raise ValueError(
                "--curriculum-success and --curriculum-steps exclude each other: the "
                "spawn ranges follow either success or env steps"
            )
        gate = {} if gated is None else {"curriculum_success": gated}
        options = ("module_replay", "near_starts", "inside_starts", "inside_starts_until")
        for option in (*options, "axis_shaping"):
            value = getattr(args, option, None)  # the env's training options, where given
            if value is not None:
                gate[option] = value
        teacher = None
        demos = getattr(args, "demos", None)
        if demos is not None:
            if demos not in teachers:
                raise ValueError(
                    f"--demos {demos!r}: no such demonstration source; valid sources: "
                    f"{sorted(teachers)}"
                )
            teacher = teachers[demos]()
        overrides = parse_overrides(args.algo, getattr(args, "set", None) or [])
        keep = bool(getattr(args, "keep_dataset_physics", False))
        on_engine = engine_options(args)
        probe, probe_steps = None, getattr(args, "probe_steps", None)
        if probe_steps is not None:
            if make_probe is None:
                raise ValueError("--probe-steps: this env offers no evaluation env to probe")
            probe = make_probe(args.dataset, args.probe_modules, args.probe_attempts, args.stack,
                               keep_physics=keep, **on_engine)  # fmt: skip
        env = make_env(
            args.dataset,
            args.envs or setup.num_envs,
            args.seed,
            curriculum_steps=curriculum,
            keep_physics=keep,
            **on_engine,
            **gate,
        )
        result = train(
            args.algo,
            env,
            setup,
            steps=args.steps,
            minutes=args.minutes,
            seed=args.seed,
            out_dir=args.out,
            resume=args.resume,
            stack=args.stack,
            device=args.device,
            progress=not args.no_progress,
            env_options={"curriculum_steps": curriculum, **on_engine, **gate},
            teacher=teacher,
            demos=demos,
            overrides=overrides,
            probe=probe,
            probe_steps=probe_steps,
            checkpoint_minutes=args.checkpoint_minutes,
        )
    except (ValueError, CheckpointError) as e:
        return print_error(str(e))
    if args.json:
        print(json.dumps(result))
    elif result["status"] != "interrupted":  # the runner said in one line what was kept
        m, nan = result["metrics"], float("nan")
        # a resumed run whose budget was already spent ran no iteration: no row to give
        last = (
            f"success {m.get('success_rate', nan):.1%}, return {m.get('return_mean', nan):.3f}"
            if m
            else "no iteration left in its budget"
        )
        console.print(
            f"{result['status']}: {result['env_steps']:,} env steps, {result['iterations']} "
            f"iterations, {result['seconds']:.0f} s; {last}; checkpoint {result['checkpoint']}"
        )
    return {"done": 0, "nan": 1, "interrupted": 130}[result["status"]]


def add_export_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `export` (a run's policy, small enough to ship) on a subparsers object."""
    p = subparsers.add_parser(
        "export",
        help="copy a run's trained networks (no optimiser, no replay) into a new folder",
        description="Write RUN's networks to OUT/checkpoint.safetensors without optimiser "
        "states, replay buffer or RNG states (it evaluates, it does not resume), with the "
        "run's config.json, metrics.csv and eval_*.json, so `assetgen eval --checkpoint OUT` "
        "and `assetgen report OUT` work on it.",
    )
    p.add_argument("run", type=Path, help="a training run folder")
    p.add_argument("--out", type=Path, required=True, help="new folder for the policy")
    p.set_defaults(func=export_main)
    return p


def export_main(args: argparse.Namespace) -> int:
    from rl.checkpoint import CheckpointError
    from rl.export import export_policy

    try:
        res = export_policy(args.run, args.out)
    except CheckpointError as e:
        return print_error(str(e))
    for name, size in res["files"].items():
        print(f"{args.out / name}  {size / 1e6:.2f} MB")
    return 0


def add_report_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register `report`: figures, Table III and report.json from runs and eval files."""
    p = subparsers.add_parser(
        "report",
        help="learning curves, time-to-success plot and Table III from runs and evaluations",
        description="Reads each RUN_DIR (config.json, metrics.csv, eval_*.json written by "
        "`assetgen eval --checkpoint RUN_DIR --out RUN_DIR/eval_<split>.json`) and the "
        "--baselines evaluation JSONs (`assetgen eval --agent scripted|random --out ...`); "
        "writes learning_curves.png, time_to_success.png, table.md and report.json into --out. "
        "Runs of the same algo and stack are seeds of one variant (mean ± std).",
    )
    p.add_argument("runs", nargs="*", type=Path, help="training run folders")
    p.add_argument(
        "--baselines",
        nargs="+",
        type=Path,
        default=[],
        help="evaluation JSON files, or folders of them (e.g. results/)",
    )
    p.add_argument("--out", type=Path, required=True, help="report folder")
    p.add_argument(
        "--readme",
        type=Path,
        help="also write the table into this markdown file, between the lines "
        "<!-- shipped-table:begin --> and <!-- shipped-table:end -->",
    )
    p.set_defaults(func=report_main)
    return p


def report_main(args: argparse.Namespace) -> int:
    """Write the report; print the table. Exit code 0, or 2 on bad input."""
    from assetgen.core.preflight import PreflightError, check_output_folder
    from rl.report import ReportError, replace_table, write_report

    try:
        check_output_folder(args.out, "--out")  # before the runs are read
        doc = write_report(args.runs, args.baselines, args.out)
        if getattr(args, "readme", None) is not None:
            replace_table(args.readme, (args.out / "table.md").read_text())
    except (ReportError, PreflightError) as e:
        return print_error(str(e))
    print((args.out / "table.md").read_text(), end="")
    for f in doc["skipped_baselines"]:
        print(f"skipped {f}: not an evaluation file of `assetgen eval --out`")
    print(f"wrote {args.out}/learning_curves.png, time_to_success.png, table.md, report.json")
    return 0
