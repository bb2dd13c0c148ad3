"""`assetgen bench sim|load|contacts`: the simulator's benchmarks, each a subcommand with its
own flags beside the code it drives. Building the parsers imports no engine."""

from __future__ import annotations

import argparse

from assetgen.core.preflight import count, positive
from sim.engines.registry import add_engine_argument, engine_names

SIM_NUMBERS = {
    "envs": count("give at least 1 environment"),
    "steps": count("give at least 1 control step"),
    "threads": count("give at least 1 thread, or leave it out"),
    "shard_size": count("give at least 1 env per model, or leave it out (8)"),
}
LOAD_NUMBERS = {"n": count("give at least 1 module")}
CONTACTS_NUMBERS = {
    "limit": count("give at least 1 module"),
    "push_time": positive("give a positive, finite number of seconds"),
    "physics_version": count("give a physics version (1 or more), or leave it out"),
    "threads": count("give at least 1 thread, or leave it out"),
}
"""The bounds of the `bench` subcommands' numeric flags (assetgen.core.preflight), checked
before any dataset is read."""


def add_parsers(bench: argparse._SubParsersAction) -> None:
    """The simulator's `bench` subcommands."""
    engines = "|".join(engine_names())
    s = bench.add_parser("sim", help="env steps per second next to the engine's own steps")
    s.add_argument("--envs", type=int, default=1024, help="environments (default 1024)")
    s.add_argument("--steps", type=int, default=200, help="control steps (default 200)")
    s.add_argument("--dataset", default="test", help="dataset (spec name or folder; test)")
    s.add_argument("--threads", type=int, default=None, help="MuJoCo's rollout threads")
    s.add_argument("--shard-size", type=int, default=None, help="envs per MuJoCo model (8)")
    s.add_argument("--json", action="store_true", help="print the figures as one JSON line")
    add_engine_argument(s, f"the engine ({engines}; default %(default)s)")
    s.set_defaults(func=run_sim)

    load = bench.add_parser("load", help="time to read modules and build the engine's envs")
    load.add_argument("--n", type=int, default=256, help="modules (default 256)")
    load.add_argument("--dataset", default="test", help="dataset (spec name or folder; test)")
    load.add_argument("--json", action="store_true", help="print the figures as JSON last")
    add_engine_argument(load, f"the engine whose construction is timed ({engines})", robots=False)
    load.set_defaults(func=run_load)

    c = bench.add_parser("contacts", help="the contact stress benchmark on a dataset")
    c.add_argument("target", help="the dataset (spec name or folder) to stress")
    c.add_argument("--limit", type=int, default=None, help="the first N modules only")
    c.add_argument(
        "--set",
        action="append",
        metavar="FIELD=VALUE",
        help="replace a field of the engine's settings (repeatable), e.g. --set timestep=0.001",
    )
    c.add_argument(
        "--source",
        choices=["sim", "mjcf"],
        default="sim",
        help="the simulator's models of the modules (default) or their exported "
        "peg_in_hole.xml files with the physics they carry",
    )
    c.add_argument("--cases", help="push,impact,friction,rebound (default: all)")
    c.add_argument("--push-time", type=float, default=None, help="seconds a push lasts (1.5)")
    c.add_argument(
        "--physics-version",
        type=int,
        default=None,
        help="simulate with an earlier physics version's settings (1: generator 0.5.0's 5 ms "
        "steps), for comparison; default: the project's",
    )
    c.add_argument("--threads", type=int, default=None, help="MuJoCo's rollout threads")
    c.add_argument("--json", metavar="FILE", default=None, help="write every run's figures here")
    add_engine_argument(c, f"the engine ({engines}; default %(default)s)")
    c.set_defaults(func=run_contacts)


def _user_errors() -> tuple[type[Exception], ...]:
    from assetgen.dataset.spec import DatasetError
    from sim.assets.loading import AssetError

    return DatasetError, AssetError, ValueError


def run_sim(args: argparse.Namespace) -> int:
    from assetgen.core.console_output import print_error
    from assetgen.core.preflight import check_numbers
    from sim.bench.throughput import bench_main

    try:
        check_numbers(args, SIM_NUMBERS)  # --envs 0 would have run the default 1024
        return bench_main(args)
    except (*_user_errors(), ImportError) as e:
        return print_error(str(e))


def run_load(args: argparse.Namespace) -> int:
    from assetgen.core.console_output import print_error, print_figures
    from assetgen.core.preflight import check_numbers
    from assetgen.dataset.spec import resolve
    from sim.bench.build import bench_build
    from sim.bench.load import bench_load

    try:
        check_numbers(args, LOAD_NUMBERS)
        root = resolve(args.dataset)[0]
        result = bench_load(root, n=args.n)
        # and what the engine (--sim) costs a module at construction
        built = bench_build(root, n=args.n, engine=args.sim)
        result |= {f"{args.sim}_{k}": v for k, v in built.items() if k != "engine"}
    except _user_errors() as e:
        return print_error(str(e))
    print_figures("bench load", result, args.json)
    return 0


def run_contacts(args: argparse.Namespace) -> int:
    from assetgen.core.console_output import print_error
    from assetgen.core.preflight import check_numbers, check_output_file
    from sim.bench.stress.command import main

    args.dataset = args.target
    try:
        check_numbers(args, CONTACTS_NUMBERS)
        if args.json is not None:
            check_output_file(args.json, "--json", "contacts.json")
        return main(args)
    except _user_errors() as e:
        return print_error(str(e))
