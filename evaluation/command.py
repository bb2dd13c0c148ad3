"""`assetgen eval`: the paper's protocol for a built-in agent or a trained checkpoint; cli.py
registers it (add_parser) and calls it:

    add_parser(subparsers)              `assetgen eval`: its flags (add_arguments) and main
    add_arguments(parser)               the flags of `assetgen eval`
    main(args)                          the parser's func: checks --agent/--checkpoint, runs
                                        eval_main
    eval_main(args, make_env=None)      build the env and the policy, play the protocol

    assetgen eval --agent NAME | --checkpoint RUN_DIR [--stochastic] [--dataset D]
                  [--attempts K] [--modules N] [--sim ENGINE] [--seed S] [--envs N]
                  [--noise-scale X] [--record DIR] [--record-limit N] [--threads T]
                  [--out FILE] [--json] [--keep-dataset-physics]

The env is the simulator's evaluation env (sim.make_eval_env); the built-in agents are the
scripted experts (sim/task/expert.py) and the random agent; a checkpoint's policy is loaded
through rl.runner. Every agent plays through the one loop of evaluation/protocol.py, an
assembly dataset stage by stage (evaluation/sequence.py). Building the parser imports
neither the simulator nor torch: they are imported when the command runs.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from assetgen.core.preflight import Bound, check_numbers, count, seed
from evaluation.protocol import Policy
from rl.commands import MakeEnv, engine_options, print_error, torch_threads
from sim.engines.registry import add_engine_argument, get_engine

SNAPSHOT_EVERY_S = 300.0
"""Seconds between the snapshots of a checkpoint's evaluation with --out
(OUT.partial.safetensors): the same command, rerun after a cut, goes on from the last one
(evaluation/snapshots.py)."""


NUMBERS = {
    "attempts": count("give at least 1 episode per module"),
    "modules": count("give at least 1 module, or leave it out"),
    "seed": seed(high=None),
    "envs": count("give at least 1 env, or leave it out (one per module)"),
    "noise_scale": Bound(low=0.0, hint="give a finite scale of at least 0 (1: the paper's noise)"),
    "record_limit": count(low=0),
    "threads": count(),
}
"""The bounds of eval's numeric flags (assetgen.core.preflight), checked before any work."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    """`assetgen eval`, beside the code it drives."""
    e = sub.add_parser("eval", help="the paper's protocol: every module, K attempts, noise on")
    add_arguments(e)
    e.set_defaults(func=main)


def add_arguments(e: argparse.ArgumentParser) -> None:
    """Declare the flags of `assetgen eval` on its subparser; `--agent` offers the scripted
    experts of sim.task.expert.EXPERTS (a numpy-only module: no engine is imported), then
    random."""
    from sim.task.expert import EXPERTS

    e.add_argument(
        "--agent",
        choices=[*EXPERTS, "random"],
        help="a built-in agent",
    )
    e.add_argument("--checkpoint", type=Path, help="a training run folder (rl)")
    e.add_argument(
        "--stochastic",
        action="store_true",
        help="with --checkpoint: sample the policy's actions (default: its mean action)",
    )
    e.add_argument("--dataset", default="test", help="spec name or dataset folder")
    e.add_argument("--attempts", type=int, default=10, help="episodes per module")
    e.add_argument(
        "--modules", type=int, default=None,
        help="the dataset's first N modules (or assemblies) only (default: all, the protocol)",
    )  # fmt: skip
    add_engine_argument(
        e,
        "physics engine: MuJoCo (the simulator), PhysX (the referee: SAPIEN on the CPU, "
        "read from the USD files; the physx extra) or MuJoCo Warp (the simulator's physics on "
        "a GPU; the warp extra)",
    )
    e.add_argument("--seed", type=int, default=0)
    e.add_argument(
        "--envs", type=int, default=None, help="parallel envs at most (default: one per module)"
    )
    e.add_argument(
        "--noise-scale",
        type=float,
        default=1.0,
        help="multiply the observation and action noise (robustness: 2 = twice the paper's)",
    )
    e.add_argument("--record", type=Path, help="folder for recorded episodes (.npz)")
    e.add_argument(
        "--record-limit", type=int, default=None,
        help="episodes to record (assembly datasets: the first attempt of this many assemblies)",
    )  # fmt: skip
    e.add_argument(
        "--threads", type=int, default=None,
        help="torch threads for a checkpoint's policy (default: half the cores, as in train; "
        "more threads than free cores slow a run several times)",
    )  # fmt: skip
    e.add_argument("--out", type=Path, help="write the results JSON here")
    e.add_argument("--json", action="store_true", help="print the results as one JSON line")
    e.add_argument(
        "--keep-dataset-physics",
        action="store_true",
        help="simulate a dataset written for other physics with the physics its files carry "
        "(default: refuse it and say how to regenerate it)",
    )


def _random_agent(seed: int) -> Policy:
    rng = np.random.default_rng(seed)
    return lambda obs: rng.uniform(-1.0, 1.0, (len(obs), 6))


def built_in_agents() -> dict[str, Callable[[int], Policy]]:
    """`--agent`'s agents: name -> (seed -> policy); the scripted experts, then random."""
    from sim.task.expert import EXPERTS

    return {
        **{name: (lambda seed, act=act: act) for name, act in EXPERTS.items()},
        "random": _random_agent,
    }


POLICIES = {"random": "stochastic"}
"""What a built-in agent's actions are, where they are not deterministic."""


def main(args: argparse.Namespace) -> int:
    """`assetgen eval` from parsed arguments: exactly one of --agent and --checkpoint."""
    if (args.agent is None) == (args.checkpoint is None):
        agents = "|".join(built_in_agents())
        return print_error(f"give one of --agent {agents} and --checkpoint RUN_DIR")
    args.run, args.episodes = args.checkpoint, args.attempts
    return eval_main(args)


def eval_main(args: argparse.Namespace, make_env: MakeEnv | None = None) -> int:
    """`assetgen eval`: the paper's protocol for a built-in agent (args.agent) or a trained
    checkpoint (args.run), through the one loop of evaluation/protocol.py. Prints a short
    table or a JSON line; args.out receives the JSON.

    make_env: the env factory; None, the simulator's (sim.make_eval_env), whose datasets may
    hold assemblies (played in sequence) and whose envs name their modules (per_module).
    Another factory (a test's toy env) gets neither."""
    from assetgen.core.preflight import check_output_file, check_output_folder
    from assetgen.core.recorded_path import recorded_path
    from evaluation.protocol import evaluate

    simulator = make_env is None
    if make_env is None:
        from sim import make_eval_env as make_env

    run = getattr(args, "run", None)
    stochastic = bool(getattr(args, "stochastic", False))
    noise_scale = getattr(args, "noise_scale", None)
    noise_scale = 1.0 if noise_scale is None else float(noise_scale)  # 0 is a valid scale
    record = getattr(args, "record", None)
    keep = bool(getattr(args, "keep_dataset_physics", False))
    engine = get_engine(getattr(args, "sim", None))
    # a subset reaches the factories only when asked for: the protocol plays every module
    limit = getattr(args, "modules", None)
    subset: dict[str, Any] = {} if limit is None else {"modules": limit}
    out = getattr(args, "out", None)  # absent when a caller builds args without --out
    snapshots = None
    try:
        # before any env is built: an evaluation can take an hour, its results written last
        check_numbers(args, NUMBERS)
        if out is not None:
            check_output_file(out, "--out")
        if record is not None:
            check_output_folder(record, "--record")
        if args.episodes < 1:
            raise ValueError(f"--attempts {args.episodes}: give at least 1 episode per module")
        if limit is not None and limit < 1:
            raise ValueError(f"--modules {limit}: give at least 1 module, or leave it out")
        on_engine = engine_options(args)
        if simulator:
            from evaluation.sequence import is_assembly_dataset

            sequence = is_assembly_dataset(args.dataset)
        else:
            sequence = False
        if sequence and not engine.assemblies:
            raise ValueError(f"--sim {engine.name}: assemblies in sequence run on MuJoCo only")
        reset = None
        policy_state = None
        wrap: Callable[[Any], Any] = lambda env: env  # noqa: E731
        if run is not None:
            import torch

            from rl.agents import acting_state_hooks, reset_hook
            from rl.checkpoint import CheckpointError, read_counters
            from rl.report_load import variant_name
            from rl.run_state import load_agent
            from rl.stack import StackObs

            threads = getattr(args, "threads", None)
            if threads is not None and threads < 1:
                raise ValueError(f"--threads {threads}: give at least 1")
            torch.set_num_threads(torch_threads(threads))
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
                base = make_env(
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
            agents = built_in_agents()
            if args.agent not in agents:
                raise ValueError(
                    f"--agent {args.agent!r}: built-in agents are {sorted(agents)}; "
                    "or give --checkpoint RUN_DIR"
                )
            if stochastic:
                raise ValueError("--stochastic applies to --checkpoint policies only")
            if not sequence:
                env = base = make_env(
                    args.dataset, args.envs, args.seed, noise_scale=noise_scale,
                    keep_physics=keep, **on_engine, **subset,
                )  # fmt: skip
            policy = agents[args.agent](args.seed)
            head = {"agent": args.agent, "policy": POLICIES.get(args.agent, "deterministic")}
            name = args.agent
        if sequence:
            from evaluation.sequence import evaluate_assembly_dataset

            res = evaluate_assembly_dataset(
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
            from evaluation.recording import EpisodeRecorder

            recorder = EpisodeRecorder(Path(record), getattr(args, "record_limit", None))
        saveable = reset is None or policy_state is not None
        if out is not None and run is not None and saveable and recorder is None:
            if engine.saves_state and hasattr(env, "get_state"):
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
        labels = None
        if simulator:
            from evaluation.recording import env_labels

            labels = env_labels(base)
        res = evaluate(
            policy,
            env,
            args.episodes,
            seed=args.seed,
            reset=reset,
            labels=labels,
            recorder=recorder,
            live=getattr(base, "set_live", None),
            snapshots=snapshots,
            policy_state=policy_state,
        )
    except ValueError as e:
        return print_error(str(e))
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
        *(
            [
                (
                    "modules refused",
                    f"{len(res['refused_modules'])} by the {res['robot']}: "
                    + ", ".join(res["refused_modules"]),
                )
            ]
            if res.get("refused_modules")
            else []
        ),
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
