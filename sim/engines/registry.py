"""The physics engines by name: what each one is, where it lives and what it can do.

Importing this module loads no engine: each entry names its classes and functions as
"module:attribute" strings, imported when first used, so the command line lists the engines
and checks `--sim` without importing MuJoCo Warp, SAPIEN or torch. A new engine is a new
entry here and a new folder under sim/engines/ holding an `EngineSim` (sim/engines/base.py).
"""

from __future__ import annotations

import argparse
import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from assetgen.core.references import load_reference


@dataclass(frozen=True)
class Engine:
    """One registered engine. Every "module:attribute" field is imported on use (`load`)."""

    name: str
    """As `--sim` and `engine=` spell it."""
    label: str
    """As summaries name it."""
    sim: str
    """The EngineSim class that PegInHoleVecEnv steps."""
    stress: str
    """The contact stress benchmark's runner on this engine:
    (assets, StressConfig, TaskConfig, settings, progress=) -> records."""
    settings: str
    """The dataclass of the engine's own settings, which the stress benchmark's `--set`
    overrides."""
    extra: str | None = None
    """The pip extra that installs it (None: the base install)."""
    saves_state: bool = False
    """Runs resume exactly (the env's state is saved), not from a fresh reset."""
    parks_idle: bool = False
    """An evaluation's envs that are done are held out of contact and not stepped."""
    one_env_per_module: bool = False
    """Serves one env per module: no module rotation, so num_envs covers the dataset."""
    reads_mjcf: bool = False
    """Can step the exported MJCF files and earlier physics versions (stress --source mjcf)."""
    device_env: str | None = None
    """An env class that keeps the task's arithmetic on the engine's device as well (None:
    the host env, PegInHoleVecEnv, is the only one)."""
    train_env: str = "sim.env:make_train_env"
    """make_train_env(dataset, num_envs, seed, engine=NAME, **task): the env training takes
    (an engine with a device env gives its own, the task on the device too)."""
    device_check: str | None = None
    """(allow_cpu: bool) -> None, raising ValueError when the engine would run on the CPU
    without `--allow-cpu`; run before any env is built (None: runs anywhere)."""
    assemblies: bool = False
    """Plays assemblies stage by stage (evaluation of assembly datasets)."""

    def load(self, field: str) -> Any:
        """The object that `field`, one of REFERENCE_FIELDS, names."""
        if field not in REFERENCE_FIELDS:
            raise ValueError(f"{field!r} is not one of an engine's fields {REFERENCE_FIELDS}")
        ref = getattr(self, field)
        if ref is None:
            raise ValueError(f"engine {self.name!r} has no {field}")
        return load_reference(ref)


REFERENCE_FIELDS = ("sim", "stress", "settings", "device_env", "train_env", "device_check")
"""The fields of an Engine that name code as "module:attribute" (Engine.load)."""

DEFAULT_ENGINE = "mujoco"

ENGINES: dict[str, Engine] = {
    e.name: e
    for e in (
        Engine(
            name="mujoco",
            label="MuJoCo",
            sim="sim.engines.mujoco.batch:BatchSim",
            stress="sim.bench.stress.mujoco:stress_on_mujoco",
            settings="assetgen.core.mujoco_config:PhysicsConfig",
            saves_state=True,
            parks_idle=True,
            reads_mjcf=True,
            assemblies=True,
        ),
        Engine(
            name="physx",
            label="PhysX",
            sim="sim.engines.physx.batch:PhysxBatchSim",
            stress="sim.bench.stress.physx:stress_physx",
            settings="sim.engines.physx.config:PhysxConfig",
            extra="physx",
            one_env_per_module=True,
        ),
        Engine(
            name="mujoco-warp",
            label="MuJoCo Warp",
            sim="sim.engines.warp.batch:WarpBatchSim",
            stress="sim.bench.stress.warp:stress_warp",
            settings="assetgen.core.mujoco_config:PhysicsConfig",
            extra="warp",
            device_env="sim.engines.warp.env:WarpTorchVecEnv",
            train_env="sim.engines.warp.env:make_device_train_env",
            device_check="sim.engines.warp.batch:require_gpu",
        ),
    )
}
"""Every engine, by name; the first is the default."""


def engine_names() -> tuple[str, ...]:
    """The registered engines' names, the default first."""
    return tuple(ENGINES)


def get_engine(name: str | None) -> Engine:
    """The engine named `name` (None: the default); ValueError listing the valid names."""
    if name is None:
        name = DEFAULT_ENGINE
    try:
        return ENGINES[name]
    except KeyError:
        raise ValueError(
            f"engine {name!r} is not registered; valid engines: {', '.join(ENGINES)}"
        ) from None


def is_default(name: str | None) -> bool:
    """Whether `name` is the default engine (None counts as the default)."""
    return get_engine(name).name == DEFAULT_ENGINE


class _EngineAction(argparse.Action):
    """Stores `--sim NAME` and, beside it, `engine_options`: {} for the default engine, else
    {"engine": NAME} (what the env factories take; factories that predate the flag need
    not take it), so that code which never imports the simulator can pass it on."""

    def __call__(self, parser, namespace, value, option_string=None) -> None:
        setattr(namespace, self.dest, value)
        # other flags (--robot) may have put their options there already
        options = dict(getattr(namespace, "engine_options", None) or {})
        options.pop("engine", None)
        if not is_default(value):
            options["engine"] = value
        namespace.engine_options = options


def add_engine_argument(p: argparse.ArgumentParser, help: str, robots: bool = True) -> None:
    """`--sim`, the one engine flag of train, eval and the benches, `--allow-cpu`, and (with
    `robots`) `--robot`, what holds the peg (sim/robots/registry.py)."""
    p.add_argument(
        "--sim", choices=engine_names(), default=DEFAULT_ENGINE, action=_EngineAction, help=help
    )
    p.set_defaults(engine_options={})
    gpu = [e.name for e in ENGINES.values() if e.device_check is not None]
    p.add_argument(
        "--allow-cpu",
        action="store_true",
        help=f"--sim {'|'.join(gpu)} without a GPU: run on the CPU device (hundreds of times "
        "slower than the default engine; for checks only)",
    )
    if robots:
        from sim.robots.registry import add_robot_argument

        add_robot_argument(p)


def check_device(args: argparse.Namespace) -> None:
    """Before any env is built: ValueError when `--sim`'s engine would run on the CPU unasked
    (see Engine.device_check)."""
    spec = get_engine(getattr(args, "sim", None))
    from sim.robots.registry import check_robot

    check_robot(getattr(args, "robot", None), spec.name)  # --robot on an engine without it
    from sim.task.config import ENV_READINGS

    robot_only = [r for r in getattr(args, "readings", None) or () if r not in ENV_READINGS]
    if robot_only and getattr(args, "robot", None) is None:
        raise ValueError(
            f"--readings {','.join(args.readings)}: the floating peg has no wrist or joints; "
            "give --robot panda as well"
        )
    if spec.device_check is not None:
        spec.load("device_check")(bool(getattr(args, "allow_cpu", False)))


def train_env_factory(engine: str | None) -> Callable[..., Any]:
    """make_train_env(dataset, num_envs, seed, **task) on `engine` (see Engine.train_env)."""
    spec = get_engine(engine)
    return functools.partial(spec.load("train_env"), engine=spec.name)
