"""The learning commands of `assetgen`; cli.py registers them and calls them:

    add_train_parser(subparsers, make_env)   assetgen train ...
    eval_main(args, make_eval_env)           assetgen eval --checkpoint RUN ...
    add_report_parser(subparsers)            assetgen report ...

`make_env(dataset: str, num_envs: int, seed: int, **task) -> VecEnv` (rl/vec_env.py; train passes
`curriculum_steps=N`, the length of the env's spawn curriculum, as a keyword) is supplied by
the caller, so rl/ never imports the simulator; for a dataset it cannot use it raises
ValueError with a message for the user. Each parser sets `func(args) -> int` (an exit code),
as the other subcommands do.

    assetgen train --algo ppo|sac|dreamer|random [--stack 10] --dataset D [--preset cpu]
                   [--steps N | --minutes M] [--seed S] --out RUN_DIR [--resume]
                   [--envs N] [--device cpu|cuda] [--threads T] [--no-progress]
    assetgen report RUN_DIR... [--baselines FILE_OR_DIR...] --out DIR

`report` (add_report_parser) needs no env: it reads run folders and evaluation JSONs.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path

from rl.vec_env import VecEnv

MakeEnv = Callable[..., VecEnv]
"""make_env(dataset, num_envs, seed, **task) -> a VecEnv; ValueError for a bad dataset."""


def _error(message: str) -> int:
    """Print a one-line error for the user on stderr; exit code 2."""
    from rich.console import Console
    from rich.markup import escape

    err = Console(stderr=True)
    err.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    return 2


def add_train_parser(
    subparsers: argparse._SubParsersAction, make_env: MakeEnv
) -> argparse.ArgumentParser:
    """Register `train` on an argparse subparsers object."""
    from rl.names import ALGO_NAMES, PRESET_NAMES

    p = subparsers.add_parser(
        "train",
        help="train an agent (PPO, SAC, DreamerV3, random) on a dataset's modules",
        description="Train an agent on the vector env; progress bar, metrics.csv, TensorBoard "
        "and checkpoints in --out. --resume continues a run exactly (see rl/runner.py).",
    )
    p.add_argument("--algo", choices=ALGO_NAMES, required=True, help="algorithm")
    p.add_argument(
        "--stack",
        type=int,
        default=1,
        help="observations stacked, newest first (10: the paper's STACK; default 1)",
    )
    p.add_argument("--dataset", required=True, help="dataset spec name or folder")
    p.add_argument(
        "--preset",
        choices=PRESET_NAMES,
        default="cpu",
        help="hyperparameter preset (rl/presets.py; default cpu)",
    )
    budget = p.add_mutually_exclusive_group()
    budget.add_argument("--steps", type=int, help="total env steps (default: the preset's)")
    budget.add_argument("--minutes", type=float, help="wall-clock budget of this call")
    p.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    p.add_argument("--out", type=Path, required=True, help="run folder")
    p.add_argument("--resume", action="store_true", help="continue the run in --out")
    p.add_argument("--envs", type=int, help="parallel envs (default: the preset's)")
    p.add_argument(
        "--curriculum-steps",
        type=int,
        help="env steps over which spawn ranges grow to full (default: the preset's; 0: off)",
    )
    p.add_argument("--device", help="torch device (default: cuda when present, else cpu)")
    p.add_argument(
        "--threads",
        type=int,
        help="torch CPU threads (default: half the cores, at least 1: the simulator's C "
        "threads need the rest, and oversubscribed torch threads spin; a SAC gradient step "
        "on the 2-core machine under load took 87 ms with 1 thread, 406 ms with 2)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON line")
    p.set_defaults(func=lambda args: train_main(args, make_env))
    return p


def train_main(args: argparse.Namespace, make_env: MakeEnv) -> int:
    """Run `train` from parsed arguments; prints a summary. Exit code 0, 1 on NaN."""
    import os

    import torch

    from rl.checkpoint import CheckpointError
    from rl.presets import get_setup
    from rl.runner import console, train

    torch.set_num_threads(args.threads or max(1, (os.cpu_count() or 2) // 2))
    try:
        setup = get_setup(args.preset, args.algo)
        if args.steps is not None and args.steps < 1:
            raise ValueError(f"--steps {args.steps}: give a positive number of env steps")
        if args.minutes is not None and args.minutes <= 0:
            raise ValueError(f"--minutes {args.minutes}: give a positive duration")
        curriculum = setup.curriculum_steps
        if args.curriculum_steps is not None:
            if args.curriculum_steps < 0:
                raise ValueError(
                    f"--curriculum-steps {args.curriculum_steps}: give 0 (off) or more steps"
                )
            curriculum = args.curriculum_steps
        env = make_env(
            args.dataset, args.envs or setup.num_envs, args.seed, curriculum_steps=curriculum
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
            env_options={"curriculum_steps": curriculum},
        )
    except (ValueError, CheckpointError) as e:
        return _error(str(e))
    if args.json:
        print(json.dumps(result))
    else:
        m, nan = result["metrics"], float("nan")
        console.print(
            f"{result['status']}: {result['env_steps']:,} env steps, {result['iterations']} "
            f"iterations, {result['seconds']:.0f} s; success {m.get('success_rate', nan):.1%}, "
            f"return {m.get('return_mean', nan):.3f}; checkpoint {result['checkpoint']}"
        )
    return {"done": 0, "nan": 1, "interrupted": 130}[result["status"]]


def eval_main(args: argparse.Namespace, make_env: MakeEnv) -> int:
    """Evaluate a run from parsed arguments; prints a short table or a JSON line."""
    import numpy as np

    from rl.checkpoint import CheckpointError
    from rl.evaluate import evaluate
    from rl.runner import load_agent, reset_hook
    from rl.stack import StackObs

    try:
        agent, meta = load_agent(args.run, args.device)
        env = make_env(args.dataset, args.envs or meta["num_envs"], args.seed)
        if meta["stack"] > 1:
            env = StackObs(env, meta["stack"])
        if env.obs_dim != meta["obs_dim"]:
            raise ValueError(
                f"the env's observations have {env.obs_dim} values, the run's "
                f"policy takes {meta['obs_dim']}"
            )
        res = evaluate(
            lambda o: agent.policy(o, deterministic=not args.stochastic),
            env,
            args.episodes,
            seed=args.seed,
            reset=reset_hook(agent),
        )
    except (ValueError, CheckpointError) as e:
        return _error(str(e))
    # algo, stack, run and dataset let `assetgen report` name the variant and the split
    res = {
        "algo": meta["algo"],
        "stack": meta["stack"],
        "run": str(args.run),
        "dataset": str(args.dataset),
        **res,
    }
    out = getattr(args, "out", None)  # absent when a caller builds args without --out
    if out is not None:
        from assetgen.core.atomic_file import strict_json, write_json

        write_json(out, strict_json(res))
    if args.json:
        print(json.dumps(res))
        return 0
    tts = np.asarray(res["time_to_success_s"])
    q = np.percentile(tts, [10, 50, 90]) if len(tts) else [float("nan")] * 3
    rows = [
        ("agent", f"{meta['algo']}{'-STACK' if meta['stack'] > 1 else ''} ({args.run})"),
        ("episodes", res["episodes"]),
        ("success rate", f"{100 * res['success_rate']:.2f} %"),
        ("time to success p10/p50/p90", f"{q[0]:.2f} / {q[1]:.2f} / {q[2]:.2f} s"),
        ("mean return", f"{res['mean_return']:.3f}"),
        ("truncated", f"{100 * res['truncation_rate']:.2f} %"),
        ("wall time", f"{res['seconds']:.1f} s"),
    ]
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
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
    p.set_defaults(func=report_main)
    return p


def report_main(args: argparse.Namespace) -> int:
    """Write the report; print the table. Exit code 0, or 2 on bad input."""
    from rl.report import ReportError, write_report

    try:
        doc = write_report(args.runs, args.baselines, args.out)
    except ReportError as e:
        from rich.console import Console

        Console(stderr=True, highlight=False).print(f"[bold red]error:[/] {e}")
        return 2
    print((args.out / "table.md").read_text(), end="")
    for f in doc["skipped_baselines"]:
        print(f"skipped {f}: not an evaluation file of `assetgen eval --out`")
    print(f"wrote {args.out}/learning_curves.png, time_to_success.png, table.md, report.json")
    return 0
