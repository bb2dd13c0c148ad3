"""The `assetgen` command. Each command lives beside the code it drives, where an
`add_parser(subparsers)` declares its flags and handler; this module builds the parser from
them, hands `train` the simulator's env, the probe and the scripted teachers (rl never
imports the simulator), and dispatches, turning a missing optional library into the extra
to install, and every error a user can make into one line (errors below)."""

from __future__ import annotations

import argparse
import errno
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rl.commands import Teacher


def build_parser() -> argparse.ArgumentParser:
    from assetgen.bench import add_parser as add_assets_bench
    from assetgen.dataset.check_command import add_parser as add_check_parser
    from assetgen.dataset.info_command import add_parser as add_info_parser
    from assetgen.dataset.sample_command import add_parser as add_sample_parser
    from assetgen.families.command import add_parser as add_families_parser
    from assetgen.physics.command import add_parser as add_physics_parser
    from assetgen.printing.command import add_parser as add_gauge_parser
    from evaluation.command import add_parser as add_eval_parser
    from preview.command import add_parser as add_view_parser
    from sim.bench.command import add_parsers as add_sim_benches
    from sim.engines.registry import add_engine_argument
    from sim.robots.scene_command import add_parser as add_scene_parser

    p = argparse.ArgumentParser(
        prog="assetgen", description="Procedural peg-in-hole modules, simulation and learning."
    )
    p.add_argument(
        "--debug",
        action="store_true",
        help="show the traceback of an error instead of its one line (before the command: "
        "assetgen --debug sample ...)",
    )
    sub = p.add_subparsers(dest="command", required=True)

    add_sample_parser(sub)
    add_check_parser(sub)
    add_physics_parser(sub)
    add_info_parser(sub)
    add_families_parser(sub)
    add_gauge_parser(sub)

    b = sub.add_parser("bench", help="benchmarks (figures printed; --json for one JSON line)")
    targets = b.add_subparsers(dest="what", required=True, metavar="{assets,sim,load,contacts}")
    add_assets_bench(targets)
    add_sim_benches(targets)

    add_eval_parser(sub)
    add_view_parser(sub)
    add_scene_parser(sub)

    # torch (the `rl` extra) is imported when `train` or `report` runs, not here: it would
    # add over a second to every command
    from rl.commands import add_export_parser, add_report_parser, add_train_parser

    add_train_parser(sub, _train_env, teachers(), _probe, add_engine_argument)
    add_report_parser(sub)
    add_export_parser(sub)
    return p


def _train_env(*args, engine: str | None = None, **kwargs):
    # the simulator (MuJoCo, with its GL bindings: ~0.3 s) is imported when a command uses
    # it, not by every command's parser: `assetgen sample` is timed whole
    from sim.engines.registry import train_env_factory

    return train_env_factory(engine)(*args, **kwargs)


def _probe(*args, **kwargs):
    # evaluation (with torch and the simulator) is imported when `train --probe-steps` runs
    from evaluation.probe import dataset_probe

    return dataset_probe(*args, **kwargs)


def teachers() -> dict[str, Callable[[], Teacher]]:
    """`assetgen train --demos NAME`: the teachers an agent can learn from, the scripted
    experts of sim.task.expert.EXPERTS (a numpy-only module), each behind a function that
    returns it."""
    from sim.task.expert import EXPERTS

    return {name: (lambda act=act: act) for name, act in EXPERTS.items()}


EXTRAS: dict[str, tuple[str, ...]] = {
    "scipy": ("cad", "physx"),
    "manifold3d": ("cad", "view"),
    "trimesh": ("cad", "view"),
    "fcl": ("cad",),
    "coacd": ("cad",),
    "pxr": ("cad", "physx"),
    "sapien": ("physx",),
    "warp": ("warp",),
    "mujoco_warp": ("warp",),
    "torch": ("rl",),
    "safetensors": ("rl",),
    "gymnasium": ("rl",),
    "tensorboard": ("rl",),
    "matplotlib": ("rl",),
    "viser": ("view",),
    "gymnasium_robotics": ("robot",),
}
"""Top-level module -> the extras of pyproject.toml that install it."""
COMMAND_EXTRA = {"view": "view", "train": "rl", "report": "rl", "eval": "rl", "export": "rl"}
"""The extra to name first for a command, where a module comes with several."""


def missing_extra_message(command: str, module: str, engine: str | None = None) -> str | None:
    """The one-line advice for a missing optional library (None: not an optional one);
    `engine`: the command's --sim, whose extra is named first."""
    from sim.engines.registry import ENGINES

    top = module.split(".")[0]
    extras = EXTRAS.get(top)
    if extras is None:
        return None
    spec = ENGINES.get(engine or "")
    first = spec.extra if spec is not None and spec.extra in extras else None
    first = first or COMMAND_EXTRA.get(command)
    extra = first if first in extras else extras[0]
    return (
        f"`assetgen {command}` needs the Python package {top!r}, which comes with the "
        f'[{extra}] extra: pip install "peg-in-hole-assetgen[{extra}]" (in a checkout: '
        f'pip install -e ".[{extra}]")'
    )


PROJECT_ERRORS = frozenset((
    "assetgen.core.preflight.PreflightError",
    "assetgen.dataset.spec.DatasetError",
    "assetgen.params.module_params.ParamError",
    "assetgen.dataset.module_writer.ModuleFailure",
    "sim.assets.loading.AssetError",
    "rl.checkpoint.CheckpointError",
    "rl.report_load.ReportError",
    "rl.dreamer.replay.ReplayMemoryError",
    "preview.scene.PreviewError",
    "sim.robots.panda.model.MissingRobotError",
    "sim.robots.panda.sim.UnreachableError",
    "sim.cameras.gl.CameraError",
))  # fmt: skip
"""The project's exceptions whose message is written for the user (it names the file or
value and says what to do), by class path: matching them imports no package (rl's would
import torch). A subclass (GeometryError, NotAnEvalFileError) is one of them too."""


def project_error(e: BaseException) -> bool:
    """Whether `e` is one of PROJECT_ERRORS (or a subclass of one)."""
    return any(f"{c.__module__}.{c.__qualname__}" in PROJECT_ERRORS for c in type(e).__mro__)


def kept_on_interrupt(args: argparse.Namespace) -> str:
    """What a command stopped by Ctrl-C kept, and how to go on from it."""
    command = args.command
    if command == "sample":
        where = args.out or args.dataset
        return f"the modules finished in {where} are kept; run the same command again to resume"
    if command == "check":
        if args.repair:
            return "the modules repaired so far are kept; run the same command again to finish"
        return "nothing was changed"
    if command == "train":
        from rl.checkpoint import FILE_NAME

        if (args.out / FILE_NAME).is_file():
            return (
                f"the last checkpoint in {args.out} is kept; continue with the same command "
                "and --resume"
            )
        return "no checkpoint had been written yet; run the same command again to start over"
    if command == "eval":
        out = args.out
        if out is None or args.checkpoint is None:
            return "nothing was written (a checkpoint's evaluation with --out can resume)"
        from evaluation.command import SNAPSHOT_EVERY_S
        from evaluation.snapshots import snapshot_path

        snapshot = snapshot_path(out)
        if snapshot.is_file():
            return f"its snapshot {snapshot} is kept; run the same command again to resume from it"
        return (
            f"no snapshot had been saved yet (one every {SNAPSHOT_EVERY_S / 60:g} minutes); "
            "run the same command again to start over"
        )
    if command == "physics" and args.json is not None:
        return f"the figures checked so far are in {args.json} (complete: false)"
    return "nothing to resume"


def main(argv: list[str] | None = None) -> int:
    """Run the command line `argv` (default: sys.argv); its exit code. Every mistake a user
    can make ends in one line `error: ...` on stderr: exit code 2, and 130 for Ctrl-C (with
    what was kept and how to resume). A bug says so in one line, then shows its traceback;
    `--debug` shows the traceback of every error."""
    from assetgen.core.console_output import print_error
    from assetgen.core.user_errors import INTERRUPTED, os_error_message

    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    if args.debug:
        return _dispatch(args)
    try:
        return _dispatch(args)
    except KeyboardInterrupt:
        print_error(f"interrupted (Ctrl-C): {kept_on_interrupt(args)}")
        return INTERRUPTED
    except ModuleNotFoundError as e:
        message = missing_extra_message(args.command, e.name or "", getattr(args, "sim", None))
        if message is None:
            _say_bug(e)
            raise
        return print_error(message)
    except OSError as e:
        message = os_error_message(e, args, argv)
        if e.errno in (errno.ENOSPC, errno.EDQUOT) and args.command in ("sample", "train"):
            message += f" ({kept_on_interrupt(args)})"
        return print_error(message)
    except Exception as e:
        if not project_error(e):
            _say_bug(e)
            raise
        return print_error(str(e))


def _dispatch(args: argparse.Namespace) -> int:
    if hasattr(args, "sim"):
        from assetgen.core.console_output import print_error
        from sim.engines.registry import check_device

        try:  # before any env is built: an engine for a GPU would run on the CPU
            check_device(args)
        except ValueError as e:
            return print_error(str(e))
    return args.func(args)


def _say_bug(e: BaseException) -> None:
    """One line before a bug's traceback: not the user's mistake, and what to report."""
    from assetgen.core.console_output import print_error

    print_error(
        f"unexpected {type(e).__name__}: a bug in assetgen, not a mistake in the command; "
        "please report it with the traceback below"
    )


if __name__ == "__main__":
    sys.exit(main())
