"""The one interface every physics engine fills in: the batched simulation that
sim.env.PegInHoleVecEnv steps, with capability flags in place of probes.

An engine simulates `num_envs` peg-in-hole scenes, each a module and its peg. The env reads
and writes the pegs through `state` (num_envs, 14) = [time, position (3), quaternion w x y z
(4), free-joint velocity (6)] in each module's frame, and drives them with `step`: one control
step at commanded velocities of the peg's bottom-face centre. What an engine can do beyond
that is said by its class's flags, so no caller asks which engine it holds.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

if TYPE_CHECKING:
    from sim.assets.loading import ModuleAsset
    from sim.task.config import TaskConfig


@dataclass(frozen=True)
class EngineOptions:
    """What the caller may choose of an engine at construction; each engine reads the fields
    that apply to it and ignores the rest."""

    nthread: int | None = None
    """CPU threads (MuJoCo; None: one per core)."""
    shard_size: int = 8
    """Envs sharing one model (MuJoCo on the CPU; 1 with module rotation)."""
    physx: Any = None
    """PhysX's settings (sim.engines.physx.config.PhysxConfig; None: the defaults)."""
    device: str | None = None
    """A Warp device for MuJoCo Warp ("cuda:0", "cpu"; None: the GPU if there is one)."""
    robot_settings: Any = None
    """A robot's own settings (sim.robots.panda.model.ArmSettings; None: its defaults)."""


class EngineSim(ABC):
    """`num_envs` peg-in-hole scenes stepped together (see the module doc).

    Subclasses set the capability flags and implement the abstract methods; `create` builds
    one from the env's assets and options.
    """

    saves_state: ClassVar[bool] = False
    """Whether the env's exact state can be saved and restored (`shard_state`,
    `contact_params`, `set_contact_params`): a run resumes exactly, not from a fresh reset."""
    parks_idle: ClassVar[bool] = False
    """Whether `step(velocity, live)` leaves envs that no longer count unstepped (the env's
    set_live then holds their pegs out of contact); otherwise `live` is ignored."""
    rotates_modules: ClassVar[bool] = True
    """Whether an env can change module (`set_module`), so fewer envs than modules can take
    the modules in turn; otherwise the engine serves one env per module."""

    num_envs: int
    state: np.ndarray
    substeps: int
    """Physics steps per control step."""

    @classmethod
    @abstractmethod
    def create(
        cls,
        env_assets: list[ModuleAsset],
        task: TaskConfig,
        spare_assets: list[ModuleAsset] | None,
        options: EngineOptions,
    ) -> EngineSim:
        """The engine's scenes for `env_assets` (one per env), with `spare_assets` further
        modules an env may be put on (module rotation)."""

    @property
    def peg_pos(self) -> np.ndarray:
        """(num_envs, 3) peg frame origin in the module frame, m (a view)."""
        return self.state[:, 1:4]

    @property
    def peg_quat(self) -> np.ndarray:
        """(num_envs, 4) peg frame orientation (w, x, y, z) in the module frame (a view)."""
        return self.state[:, 4:8]

    @property
    def qvel(self) -> np.ndarray:
        """(num_envs, 6) free-joint velocity (a view)."""
        return self.state[:, 8:14]

    def set_pose(self, idx: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> None:
        """Place pegs `idx` at rest: pos (k, 3), quat (k, 4) in their module frames."""
        self.state[idx, 1:4] = pos
        self.state[idx, 4:8] = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
        self.state[idx, 8:14] = 0.0

    def place(self, idx: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> np.ndarray | None:
        """set_pose where the engine can put the pegs. An engine whose pegs go anywhere (a
        floating peg) returns None: all placed. One whose pegs are held by a robot returns
        (k,) bool, False where a pose is out of its reach (that env's state is unchanged)."""
        self.set_pose(idx, pos, quat)
        return None

    @abstractmethod
    def set_material(
        self, idx: np.ndarray, static: np.ndarray, dynamic: np.ndarray, restitution: np.ndarray
    ) -> None:
        """Contact draws of envs idx: static and dynamic friction and restitution (k,) each,
        taken as the engine models contact."""

    def set_module(self, e: int, module_id: str) -> None:
        """Put env `e` on module `module_id` (one of its env or spare assets)."""
        raise NotImplementedError(f"{type(self).__name__} serves one env per module")

    @abstractmethod
    def step(self, velocity: np.ndarray, live: np.ndarray | None = None) -> np.ndarray:
        """One control step at the commanded velocities (num_envs, 6): linear (m/s) and
        angular (rad/s) of the peg's bottom-face centre in the module frame. live: envs that
        still count (see parks_idle). Returns (num_envs,) bool: envs whose physics broke
        down (non-finite state, a runaway peg, or the engine's own failure signs)."""

    def raw_round(self, velocities: list[np.ndarray]) -> Callable[[], None]:
        """For the throughput bench's raw figure: a function that runs the control steps at
        `velocities` (each (num_envs, 6)) without the env layer (no observation, reward,
        noise or reset). What it needs is prepared here, untimed. By default the engine's
        own `step`."""

        def run() -> None:
            for v in velocities:
                self.step(v)

        return run

    def readings(self, name: str) -> np.ndarray:
        """(num_envs, k) the reading `name` (sim.task.config.READINGS) at the last step; an
        engine whose peg floats has none (ValueError)."""
        raise ValueError(
            f"the {name!r} reading is a robot's (the floating peg has no wrist or joints): "
            "give --robot panda, or leave the readings out"
        )

    def device_model_bytes(self) -> int | None:
        """Bytes of the model held on the engine's device (None: the engine runs on the
        host)."""
        return None

    def bench_figures(self) -> dict[str, Any]:
        """What the throughput bench reports of this engine beyond the common figures."""
        return {}

    @abstractmethod
    def gather(self) -> None:
        """Refresh `state` from the engine's own storage."""

    def contacts(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Contacts of env i's peg in its current state: distances (k,) m (negative:
        penetration) and normal forces (k,) N. For tests and diagnostics."""
        raise NotImplementedError(f"{type(self).__name__} does not report contacts")

    def protocol(self) -> dict[str, Any]:
        """Fields this engine adds to an evaluation file's protocol (its own settings)."""
        return {}

    def close(self) -> None:  # noqa: B027 (most engines hold nothing to release)
        """Release what the engine holds."""
