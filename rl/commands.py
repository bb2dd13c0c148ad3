"""The learning commands of `assetgen`; cli.py registers them and calls them:

    add_train_parser(subparsers, make_env, teachers)   assetgen train ...
    eval_main(args, EvalHooks(...))          assetgen eval --agent NAME | --checkpoint RUN ...
    add_report_parser(subparsers)            assetgen report ...

`make_env(dataset: str, num_envs: int, seed: int, **task) -> VecEnv` (rl/vec_env.py; train passes
`curriculum_steps=N`, the length of the env's spawn curriculum, as a keyword) is supplied by
the caller, so rl/ never imports the simulator (nor its scripted expert: `teachers` maps
`--demos` names to policies); for a dataset it cannot use it raises
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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rl.vec_env import VecEnv

MakeEnv = Callable[..., VecEnv]
"""make_env(dataset, num_envs, seed, **task) -> a VecEnv; ValueError for a bad dataset
(one written for other physics among them, unless keep_physics=True)."""
Teacher = Callable[[np.ndarray], np.ndarray]
"""A policy of unstacked observations (N, obs_dim) -> actions (N, act_dim) in [-1, 1]."""


def parse_overrides(algo: str, items: list[str]) -> dict[str, Any]:
    """`--set FIELD=VALUE` items -> {field: value} for `algo`'s config, each value parsed as
    the field's default is typed (ValueError naming the field and the valid ones)."""
    from assetgen.core.overrides import parse_overrides as parse
    from rl.runner import ALGOS

    return parse(ALGOS[algo], items)


FLAGS = {
    "noise_scale": "--noise-scale",
    "num_envs": "--envs",
    "keep_physics=True": "--keep-dataset-physics",
    "checkpoint_minutes": "--checkpoint-minutes",
}
"""Library parameter names as the command line spells them, for error messages."""

SNAPSHOT_EVERY_S = 300.0
"""Seconds between the snapshots of a checkpoint's evaluation with --out
(OUT.partial.safetensors): the same command, rerun after a cut, goes on from the last one
(evaluation/snapshots.py)."""


def _flags(message: str) -> str:
    """A library error in the command line's words: `noise_scale = 3` -> `--noise-scale 3`."""
    for name, flag in FLAGS.items():
        message = message.replace(f"{name} = ", f"{flag} ").replace(name, flag)
    return message


def _error(message: str) -> int:
    """Print a one-line error for the user on stderr; exit code 2."""
    from rich.console import Console
    from rich.markup import escape

    err = Console(stderr=True)
    err.print(f"[bold red]error:[/] {escape(_flags(message))}", highlight=False, soft_wrap=True)
    return 2


def _torch_threads(threads: int | None) -> int:
    """--threads, or by default half the cores (at least 1): the simulator's C threads need
    the rest, and oversubscribed torch threads spin."""
    import os

    return threads or max(1, (os.cpu_count() or 2) // 2)


def add_train_parser(
    subparsers: argparse._SubParsersAction,
    make_env: MakeEnv,
    teachers: dict[str, Callable[[], Teacher]] | None = None,
    make_probe_env: Callable[[str, int], Any] | None = None,
    add_engine_argument: Callable[[argparse.ArgumentParser, str], None] | None = None,
) -> argparse.ArgumentParser:
    """Register `train` on an argparse subparsers object; `teachers` maps the names that
    --demos accepts to functions that build the policy; `make_probe_env(dataset, k)` makes
    the evaluation env of the dataset's first k modules for --probe-steps;
    `add_engine_argument(parser, help)` adds the simulator's engine flag (`--sim`, which
    leaves `engine_options` for make_env), when the caller has engines to offer."""
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
    p.set_defaults(func=lambda args: train_main(args, make_env, teachers or {}, make_probe_env))
    return p


def _engine_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """`engine=` for the env factories, as the engine flag (sim/engines/registry.py's
    add_engine_argument) left it: empty for the default engine."""
    return dict(getattr(args, "engine_options", None) or {})


def train_main(
    args: argparse.Namespace,
    make_env: MakeEnv,
    teachers: dict[str, Callable[[], Teacher]],
    make_probe_env: Callable[[str, int], Any] | None = None,
) -> int:
    """Run `train` from parsed arguments; prints a summary. Exit code 0, 1 on NaN."""
    import torch

    from rl.checkpoint import CheckpointError
    from rl.presets import get_setup
    from rl.runner import console, train

    torch.set_num_threads(_torch_threads(args.threads))
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
        gated = getattr(args, "curriculum_success", None)
        if gated is not None:
            if not 0.0 < gated <= 1.0:
                raise ValueError(
                    f"--curriculum-success {gated}: give a success rate in (0, 1], e.g. 0.8"
                )
            if args.curriculum_steps is not None:
                raise ValueError(
                    "--curriculum-success and --curriculum-steps exclude each other: the "
                    "spawn ranges follow either success or env steps"
                )
        gate = {} if gated is None else {"curriculum_success": gated}
        replay = getattr(args, "module_replay", None)
        if replay is not None:
            if not 0.0 < replay <= 1.0:
                raise ValueError(
                    f"--module-replay {replay}: give the share of modules drawn by their "
                    "failures, in (0, 1], e.g. 0.5"
                )
            gate["module_replay"] = replay
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
        on_engine = _engine_kwargs(args)
        probe, probe_steps = None, getattr(args, "probe_steps", None)
        if probe_steps is not None:
            from rl.probe import make_probe

            if probe_steps < 1:
                raise ValueError(f"--probe-steps {probe_steps}: give a positive number of steps")
            if make_probe_env is None:
                raise ValueError("--probe-steps: this env offers no evaluation env to probe")
            if args.probe_modules < 1:
                raise ValueError(f"--probe-modules {args.probe_modules}: give at least 1")
            probe_env = make_probe_env(args.dataset, args.probe_modules, keep_physics=keep,
                                       **on_engine)  # fmt: skip
            probe = make_probe(probe_env, args.probe_attempts, args.stack)
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
        return _error(str(e))
    if args.json:
        print(json.dumps(result))
    else:
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


@dataclass(frozen=True)
class EvalHooks:
    """What `assetgen eval` needs from the simulator, supplied by cli.py (rl/ never imports
    it)."""

    make_env: MakeEnv
    """make_env(dataset, num_envs, seed, noise_scale=x) -> the evaluation VecEnv, with a
    `protocol` dict (dataset folder and hash, control_dt, noise scale) when it has one."""
    agents: dict[str, Callable[[int], Teacher]]
    """Built-in agents: name -> (seed -> policy)."""
    labels: Callable[[Any], list[str]] | None = None
    """env -> what each env plays (its module id), for per-module results."""
    recorder: Callable[[Path, int | None], Any] | None = None
    """(folder, limit) -> a recorder of episodes (evaluation/protocol.py's Recorder)."""
    policies: dict[str, str] = field(default_factory=dict)
    """Built-in agent -> "deterministic" or "stochastic" (what its actions are)."""
    is_sequence: Callable[[str], bool] | None = None
    """dataset -> whether it holds assemblies, played stage by stage by `run_sequence`."""
    run_sequence: Callable[..., dict[str, Any]] | None = None
    """run_sequence(dataset, policy, attempts, seed=, reset=, wrap=, noise_scale=, record=,
    record_limit=, keep_physics=) -> results per stage and for the whole sequence
    (evaluation/sequence.py)."""


def eval_main(args: argparse.Namespace, hooks: EvalHooks) -> int:
    """`assetgen eval`: the paper's protocol for a built-in agent (args.agent) or a trained
    checkpoint (args.run), through the one loop of evaluation/protocol.py. Prints a short table or a
    JSON line; args.out receives the JSON."""
    import numpy as np

    from assetgen.core.recorded_path import recorded_path
    from evaluation.protocol import evaluate

    run = getattr(args, "run", None)
    stochastic = bool(getattr(args, "stochastic", False))
    noise_scale = getattr(args, "noise_scale", None)
    noise_scale = 1.0 if noise_scale is None else float(noise_scale)  # 0 is a valid scale
    record = getattr(args, "record", None)
    keep = bool(getattr(args, "keep_dataset_physics", False))
    engine = getattr(args, "sim", None) or "mujoco"
    # a subset reaches the factories only when asked for: the protocol plays every module
    limit = getattr(args, "modules", None)
    subset: dict[str, Any] = {} if limit is None else {"modules": limit}
    out = getattr(args, "out", None)  # absent when a caller builds args without --out
    snapshots = None
    try:
        if args.episodes < 1:
            raise ValueError(f"--attempts {args.episodes}: give at least 1 episode per module")
        if limit is not None and limit < 1:
            raise ValueError(f"--modules {limit}: give at least 1 module, or leave it out")
        on_engine = _engine_kwargs(args)
        sequence = hooks.is_sequence is not None and hooks.is_sequence(args.dataset)
        if sequence and on_engine:
            raise ValueError(f"--sim {engine}: assemblies in sequence run on MuJoCo only")
        reset = None
        policy_state = None
        wrap: Callable[[Any], Any] = lambda env: env  # noqa: E731
        if run is not None:
            import torch

            from rl.checkpoint import CheckpointError, read_counters
            from rl.report import variant_name
            from rl.runner import acting_state_hooks, load_agent, reset_hook
            from rl.stack import StackObs

            threads = getattr(args, "threads", None)
            if threads is not None and threads < 1:
                raise ValueError(f"--threads {threads}: give at least 1")
            torch.set_num_threads(_torch_threads(threads))
            # the recurrent agents sample their latents: seeded, an evaluation repeats exactly
            torch.manual_seed(args.seed)
            try:
                agent, meta = load_agent(run, getattr(args, "device", None))
            except CheckpointError as e:
                raise ValueError(str(e)) from e

            def wrap(base: Any) -> Any:
                """Stack as in training; refuse a policy of another observation size."""
                env = StackObs(base, meta["stack"]) if meta["stack"] > 1 else base
                if env.obs_dim != meta["obs_dim"]:
                    raise ValueError(
                        f"{run}: the checkpoint's policy takes observations of "
                        f"{meta['obs_dim']} values ({meta['stack']} stacked), but this env "
                        f"gives {env.obs_dim} ({base.obs_dim} per step, stacked "
                        f"{meta['stack']}): evaluate it on the task it was trained on"
                    )
                return env

            if not sequence:
                base = hooks.make_env(
                    args.dataset, args.envs, args.seed, noise_scale=noise_scale,
                    keep_physics=keep, **on_engine, **subset,
                )  # fmt: skip
                env = wrap(base)
            policy = lambda o: agent.policy(o, deterministic=not stochastic)  # noqa: E731
            reset = reset_hook(agent)
            policy_state = acting_state_hooks(agent)
            head: dict[str, Any] = {
                "algo": meta["algo"],
                "stack": meta["stack"],
                "demos": meta.get("demos"),
                "overrides": meta.get("overrides", {}),
                "run": recorded_path(run),
                # which training state was evaluated: a resumed run's older evaluation is stale
                "trained_env_steps": read_counters(run).get("env_steps"),
                "policy": "stochastic" if stochastic else "deterministic",
            }
            name = f"{variant_name(meta['algo'], meta['stack'], meta.get('demos'))} ({run})"
        else:
            if args.agent not in hooks.agents:
                raise ValueError(
                    f"--agent {args.agent!r}: built-in agents are {sorted(hooks.agents)}; "
                    "or give --checkpoint RUN_DIR"
                )
            if stochastic:
                raise ValueError("--stochastic applies to --checkpoint policies only")
            if not sequence:
                env = base = hooks.make_env(
                    args.dataset, args.envs, args.seed, noise_scale=noise_scale,
                    **on_engine, **subset,
                )  # fmt: skip
            policy = hooks.agents[args.agent](args.seed)
            head = {"agent": args.agent, "policy": hooks.policies.get(args.agent, "deterministic")}
            name = args.agent
        if sequence:
            assert hooks.run_sequence is not None
            res = hooks.run_sequence(
                args.dataset, policy, args.episodes, seed=args.seed, reset=reset, wrap=wrap,
                noise_scale=noise_scale, record=None if record is None else Path(record),
                record_limit=getattr(args, "record_limit", None), keep_physics=keep,
                **subset,
            )  # fmt: skip
            return _sequence_out(args, {**head, "dataset": recorded_path(args.dataset),
                                        "attempts": args.episodes, "seed": args.seed, **res},
                                 name)  # fmt: skip
        recorder = None
        if record is not None:
            if hooks.recorder is None:
                raise ValueError("--record: this env cannot record episodes")
            recorder = hooks.recorder(Path(record), getattr(args, "record_limit", None))
        saveable = reset is None or policy_state is not None
        if out is not None and run is not None and saveable and recorder is None:
            if engine == "mujoco" and hasattr(env, "get_state"):
                # a checkpoint's evaluation can take an hour: a cut one goes on from its snapshot
                import torch

                from evaluation.snapshots import EvalSnapshots, snapshot_path

                snapshots = EvalSnapshots(
                    snapshot_path(Path(out)),
                    {
                        **head,
                        **getattr(base, "protocol", {}),
                        "dataset": recorded_path(args.dataset),
                        "attempts": args.episodes,
                        "seed": args.seed,
                        "envs": args.envs,
                        "modules": limit,
                        "threads": torch.get_num_threads(),
                    },
                    every_s=SNAPSHOT_EVERY_S,
                )
        res = evaluate(
            policy,
            env,
            args.episodes,
            seed=args.seed,
            reset=reset,
            labels=hooks.labels(base) if hooks.labels is not None else None,
            recorder=recorder,
            live=getattr(base, "set_live", None),
            snapshots=snapshots,
            policy_state=policy_state,
        )
    except ValueError as e:
        return _error(str(e))
    res = {
        **head,
        "dataset": recorded_path(args.dataset),
        **getattr(base, "protocol", {}),
        "attempts": args.episodes,
        "seed": args.seed,
        **res,
    }
    if out is not None:
        from assetgen.core.atomic_file import strict_json, write_json

        write_json(out, strict_json(res))
        if snapshots is not None:
            snapshots.clear()
    if args.json:
        print(json.dumps(res))
        return 0
    tts = np.asarray(res["time_to_success_s"])
    q = np.percentile(tts, [10, 50, 90]) if len(tts) else [float("nan")] * 3
    where = f"{res.get('dataset_folder', res['dataset'])} ({res.get('dataset_hash', '?')[:16]})"
    rows = [
        ("agent", f"{name}, {res['policy']} actions"),
        ("dataset", where),
        ("episodes", res["episodes"]),
        ("success rate", f"{100 * res['success_rate']:.2f} %"),
        ("time to success p10/p50/p90", f"{q[0]:.2f} / {q[1]:.2f} / {q[2]:.2f} s"),
        ("failure rate", f"{100 * res['failure_rate']:.2f} %"),
        ("truncated", f"{100 * res['truncation_rate']:.2f} %"),
        ("unstable episodes", res["unstable"]),
        ("mean return", f"{res['mean_return']:.3f}"),
        ("wall time", f"{res['seconds']:.1f} s"),
    ]
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    return 0


def _sequence_out(args: argparse.Namespace, res: dict[str, Any], name: str) -> int:
    """Write and print an assembly dataset's evaluation: each stage, then the sequence."""
    import numpy as np

    out = getattr(args, "out", None)
    if out is not None:
        from assetgen.core.atomic_file import strict_json, write_json

        write_json(out, strict_json(res))
    if args.json:
        print(json.dumps(res))
        return 0

    def times(tts: list[float]) -> str:
        if not tts:
            return "-"
        q = np.percentile(tts, [10, 50, 90])
        return f"{q[0]:.2f} / {q[1]:.2f} / {q[2]:.2f} s"

    rows = [
        ("agent", f"{name}, {res['policy']} actions"),
        ("dataset", f"{res['dataset_folder']} ({res['dataset_hash'][:16]}), {res['family']}"),
        ("attempts", f"{res['assemblies']} assemblies x {res['attempts']}"),
    ]
    for k, st in enumerate(res["stages"]):
        gap = ", ".join(f"{1e3 * c:g}" for c in st["clearance_m"])
        rows.append((
            f"stage {k + 1}: {st['part']} ({gap} mm)",
            f"{100 * st['success_rate']:.2f} % of {st['episodes']} episodes "
            f"(failed {100 * st['failure_rate']:.2f} %, truncated "
            f"{100 * st['truncation_rate']:.2f} %), p10/p50/p90 {times(st['time_to_success_s'])}",
        ))  # fmt: skip
    seq = res["sequence"]
    rows += [
        ("whole sequence", f"{100 * seq['success_rate']:.2f} % of {seq['episodes']} attempts, "
                           f"p10/p50/p90 {times(seq['time_to_success_s'])}"),
        ("wall time", f"{res['seconds']:.1f} s"),
    ]  # fmt: skip
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    return 0


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
    from rl.runner import export_policy

    try:
        res = export_policy(args.run, args.out)
    except CheckpointError as e:
        return _error(str(e))
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
    from rl.report import ReportError, replace_table, write_report

    try:
        doc = write_report(args.runs, args.baselines, args.out)
        if getattr(args, "readme", None) is not None:
            replace_table(args.readme, (args.out / "table.md").read_text())
    except ReportError as e:
        from rich.console import Console

        Console(stderr=True, highlight=False).print(f"[bold red]error:[/] {e}")
        return 2
    print((args.out / "table.md").read_text(), end="")
    for f in doc["skipped_baselines"]:
        print(f"skipped {f}: not an evaluation file of `assetgen eval --out`")
    print(f"wrote {args.out}/learning_curves.png, time_to_success.png, table.md, report.json")
    return 0
