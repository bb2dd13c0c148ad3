"""The embodiments by name: what holds the peg. The default, None, is the paper's floating
peg, driven by velocity actuators at its bottom; a robot holds it instead and turns the same
velocity actions into its joints' motion.

Importing this module loads no robot (the entries name their classes as "module:attribute"
strings), so the command line lists them and checks `--robot` without MuJoCo's models. A new
robot is a new entry here and a folder under sim/robots/ holding an EngineSim
(sim/engines/base.py) whose pegs it holds.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any

from assetgen.core.references import load_reference


@dataclass(frozen=True)
class Robot:
    """One registered robot."""

    name: str
    """As `--robot` and `robot=` spell it."""
    label: str
    """As summaries name it."""
    sim: str
    """The EngineSim class ("module:attribute") that PegInHoleVecEnv steps in place of the
    engine's own."""
    scene: str
    """(module asset, PhysicsConfig) -> mujoco.MjSpec: the robot holding the module's peg,
    with its visual meshes (`assetgen scene`)."""
    refuses: str
    """(module asset) -> str | None: why the robot cannot hold that module's peg (a sentence
    naming the module), or None where it can. Envs built from a dataset leave refused
    modules out and name them (PegInHoleVecEnv.refused)."""
    stress: str
    """The contact stress benchmark's runner with the robot holding the peg (the engines'
    runner signature, sim/engines/registry.py)."""
    engines: tuple[str, ...]
    """The engines (sim/engines/registry.py) that carry it."""
    extra: str
    """The pip extra that installs its model."""
    settings: str
    """Its settings' frozen dataclass (EngineOptions.robot_settings; its fields are what
    `--robot-set FIELD=VALUE` may change)."""

    def load(self, field: str) -> Any:
        """The object that `field` ("sim", "scene", "refuses", "stress" or "settings") names."""
        known = ("sim", "scene", "refuses", "stress", "settings")
        if field not in known:
            raise ValueError(f"{field!r} is not one of a robot's fields {known}")
        return load_reference(getattr(self, field))


ROBOTS: dict[str, Robot] = {
    r.name: r
    for r in (
        Robot(
            name="panda",
            label="Franka Emika Panda",
            sim="sim.robots.panda.sim:PandaSim",
            scene="sim.robots.panda.scene:build_arm_spec",
            refuses="sim.robots.panda.scene:refusal",
            stress="sim.robots.panda.stress:stress_on_panda",
            engines=("mujoco",),
            extra="robot",
            settings="sim.robots.panda.model:ArmSettings",
        ),
    )
}


def robot_names() -> tuple[str, ...]:
    return tuple(ROBOTS)


def get_robot(name: str) -> Robot:
    """The robot named `name`; ValueError listing the valid names."""
    try:
        return ROBOTS[name]
    except KeyError:
        raise ValueError(
            f"robot {name!r} is not registered; valid robots: {', '.join(ROBOTS)} (or none: "
            "the floating peg)"
        ) from None


def check_robot(robot: str | None, engine: str) -> Robot | None:
    """The robot for `--robot` on `--sim engine` (None: the floating peg); ValueError when
    the engine does not carry it."""
    if robot is None:
        return None
    r = get_robot(robot)
    if engine not in r.engines:
        raise ValueError(
            f"--robot {r.name} runs on --sim {' or '.join(r.engines)} only; --sim {engine} "
            "does not carry the arm yet (leave --robot out for the floating peg)"
        )
    return r


class _RobotAction(argparse.Action):
    """Stores `--robot NAME` and adds {"robot": NAME} to `engine_options` (beside --sim's),
    what the env factories take."""

    def __call__(self, parser, namespace, value, option_string=None) -> None:
        setattr(namespace, self.dest, value)
        options = dict(getattr(namespace, "engine_options", None) or {})
        options["robot"] = value
        namespace.engine_options = options


class _ReadingsAction(argparse.Action):
    """Stores `--readings a,b` and adds {"readings": ("a", "b")} to `engine_options`."""

    def __call__(self, parser, namespace, value, option_string=None) -> None:
        from sim.task.config import READINGS

        names = tuple(v for v in value.split(",") if v)
        unknown = [v for v in names if v not in READINGS]
        if unknown or not names or len(set(names)) != len(names):
            parser.error(
                f"--readings {value!r}: give some of {', '.join(READINGS)}, comma-separated, "
                "each once"
            )
        setattr(namespace, self.dest, names)
        options = dict(getattr(namespace, "engine_options", None) or {})
        options["readings"] = names
        namespace.engine_options = options


def add_robot_argument(p: argparse.ArgumentParser) -> None:
    """`--robot`, the embodiment flag of train, eval and the benches, and `--readings`,
    what the robot adds to the observation."""
    p.add_argument(
        "--robot",
        choices=robot_names(),
        action=_RobotAction,
        help="a robot holds the peg and follows the same velocity actions through its "
        "controller (default: the paper's floating peg); needs the [robot] extra",
    )
    p.add_argument(
        "--readings",
        metavar="NAMES",
        action=_ReadingsAction,
        help="readings appended to the observation, comma-separated: peg (its own pose in "
        "the module frame, 9 values), and with --robot: wrist (force/torque at the flange, 6), "
        "joints (positions and velocities, 14)",
    )
