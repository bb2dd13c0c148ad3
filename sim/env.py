"""The peg-in-hole vector environment: numpy arrays of shape (num_envs, ...), automatic reset.

Contract (what rl/ relies on):
    env.num_envs, env.obs_dim (18), env.act_dim (6), env.control_dt (s)
    env.reset(seed: int | None = None) -> obs (num_envs, 18) float32
    env.step(actions (num_envs, 6)) -> obs, reward, terminated, truncated, info
        obs         (num_envs, 18) float32; for an env whose episode just ended, the first
                    observation of its next episode (automatic reset in the same step)
        reward      (num_envs,) float64
        terminated  (num_envs,) bool: success or failure
        truncated   (num_envs,) bool: step limit reached, or the physics went unstable
        info        dict of (num_envs, ...) arrays, valid where terminated | truncated:
            final_obs        (num_envs, 18) float32: the last observation of that episode
            success          (num_envs,) bool
            failure          (num_envs,) bool
            unstable         (num_envs,) bool: reset after non-finite or runaway physics
                             (truncated)
            episode_return   (num_envs,) float64
            episode_length   (num_envs,) int64, control steps
            time_to_success  (num_envs,) float64, seconds; NaN where not a success
            module           (num_envs,) int64: index of the env's module in env.module_ids
            peg_pose         (num_envs, 7) float64: true pose (position, quaternion w x y z)
                             of the peg at the end of this step, before any reset; valid
                             for every env (for recording episodes)
            assisted         (num_envs,) bool: the episode started inside the hole
                             (TaskConfig.inside_starts); not a task episode
Actions are clipped to [-1, 1] and scaled to max_lin_vel / max_ang_vel: the target linear
and angular velocity of the peg's bottom-face centre in the module frame.
"""

from __future__ import annotations

import math
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

from assetgen.core.mujoco_config import physics_for, physics_from_record
from assetgen.core.recorded_path import recorded_path
from assetgen.core.rotations import matrix_to_quat, quat_conj, quat_mul
from sim.assets.loading import ModuleAsset, check_physics, dataset_root
from sim.assets.task_modules import load_modules
from sim.cameras.config import CameraConfig
from sim.cameras.noise import corrupt
from sim.engines.base import EngineOptions
from sim.engines.physx.config import PhysxConfig
from sim.engines.registry import DEFAULT_ENGINE, get_engine
from sim.robots.registry import check_robot
from sim.task import kernel as K
from sim.task import rules as T
from sim.task.config import ENV_READINGS, READINGS, TaskConfig, reading_noise
from sim.task.curriculum import SuccessCurriculum
from sim.task.module_replay import ModuleReplay
from sim.task.takeoff_gate import TakeoffGate


def assign_modules(num_modules: int, num_envs: int, seed: int) -> np.ndarray:
    """(num_envs,) module index per env: env i gets module i while there are enough; the
    rest get modules in seeded random rounds (each module once per round)."""
    if num_envs <= num_modules:
        return np.arange(num_envs)
    rng = np.random.default_rng(seed)
    extra = np.concatenate(
        [rng.permutation(num_modules) for _ in range(-(-(num_envs - num_modules) // num_modules))]
    )
    return np.concatenate([np.arange(num_modules), extra[: num_envs - num_modules]])


class PegInHoleVecEnv:
    """`num_envs` peg-in-hole environments over the modules of a dataset (see module doc).

    Env i gets module i while there are enough modules (beyond that, seeded rounds). With
    `rotate_modules` and fewer envs than modules, every episode start hands the env's
    module back to a queue and takes the next one, so a small batch trains on the whole
    dataset (one model per env then; `info["module"]` names the module of each episode).
    """

    obs_dim = T.OBS_DIM
    act_dim = T.ACT_DIM

    def __init__(
        self,
        dataset: str | Path | list[ModuleAsset],
        num_envs: int | None = None,
        config: TaskConfig | None = None,
        *,
        module_ids: list[str] | None = None,
        assignment_seed: int = 0,
        nthread: int | None = None,
        shard_size: int = 8,
        rotate_modules: bool = False,
        engine: str = DEFAULT_ENGINE,
        physx: PhysxConfig | None = None,
        warp_device: str | None = None,
        robot: str | None = None,
        robot_settings: Any = None,
    ) -> None:
        spec = get_engine(engine)
        self.engine = spec.name
        """The physics engine's name (sim/engines/registry.py)."""
        holder = check_robot(robot, spec.name)
        self.robot = None if holder is None else holder.name
        """The robot holding the peg (sim/robots/registry.py), or None: the floating peg."""
        self.cfg = (config or TaskConfig()).validate()
        modules = dataset if isinstance(dataset, list) else load_modules(dataset, module_ids)
        if not modules:
            raise ValueError("no modules given: pass a dataset folder or a non-empty list")
        self.refused: dict[str, str] = {}
        """Module id -> why the robot cannot hold its peg: modules left out (a robot only)."""
        if holder is not None:
            refuses = holder.load("refuses")
            self.refused = {m.id: why for m in modules if (why := refuses(m)) is not None}
            if self.refused:
                modules = [m for m in modules if m.id not in self.refused]
                if not modules:
                    raise ValueError(next(iter(self.refused.values())))
        if self.cfg.physics is None:
            if not isinstance(dataset, list):
                check_physics(dataset)
            # the finest clearance sets the step (an assembly's stages differ)
            clearance = min(m.clearance for m in modules)
            self.cfg = replace(self.cfg, physics=physics_for(clearance))
        self.num_envs = len(modules) if num_envs is None else int(num_envs)
        if self.num_envs < 1:
            raise ValueError(f"num_envs = {num_envs}: need at least 1 environment")
        self.modules = modules
        self.module_ids = [m.id for m in modules]
        self.env_module = assign_modules(len(modules), self.num_envs, assignment_seed)
        assets = [modules[k] for k in self.env_module]
        self.rotate_modules = rotate_modules and self.num_envs < len(modules)
        self.module_queue: list[int] = []
        """Modules waiting for an env (rotation): a finished episode's module goes to the
        back, its env takes the front one, so all modules take turns evenly."""
        spare = None
        if self.rotate_modules:
            shard_size = 1  # an env changes model at its resets
            rest = np.setdiff1d(np.arange(len(modules)), self.env_module)
            self.module_queue = np.random.default_rng(assignment_seed).permutation(rest).tolist()
            spare = [modules[k] for k in self.module_queue]
        self.first_assignment = (self.env_module.copy(), list(self.module_queue))
        """The modules' order at construction, which a seeded reset restores."""
        if spec.one_env_per_module and self.rotate_modules:
            raise ValueError(
                f"engine = {spec.name!r} serves one env per module ({len(modules)} modules, "
                f"num_envs = {self.num_envs}): give num_envs >= the number of modules"
            )
        options = EngineOptions(nthread, shard_size, physx, warp_device, robot_settings)
        sim_class = spec.load("sim") if holder is None else holder.load("sim")
        self.sim = sim_class.create(assets, self.cfg, spare, options)
        self.control_dt = self.cfg.control_dt
        self.stateful = self.sim.saves_state
        """Whether get_state / set_state work (rl/vec_env.py's is_stateful): an engine whose
        state is host arrays saves it; one whose scene or device state is not saved resumes
        from a fresh reset."""
        self.protocol: dict[str, Any] = {}
        """How this env evaluates, for evaluation files (make_eval_env fills it)."""

        # per-module constants (of every module when rotating, else of the envs' modules),
        # indexed per env by _use_modules
        known = np.arange(len(modules)) if self.rotate_modules else np.unique(self.env_module)
        self.module_row = np.full(len(modules), -1)
        self.module_row[known] = np.arange(len(known))
        m_assets = [modules[k] for k in known]
        entrance = np.stack([a.entrance for a in m_assets])
        bottom = np.stack([a.bottom for a in m_assets])
        self.module_frames = T.ObsFrames.of(entrance, bottom)
        self.module_entrance_quat = matrix_to_quat(entrance[:, :3, :3])
        nv = max(len(a.peg.vertices) for a in m_assets)
        # vertices padded to a common count by repeating the first (same min/any results)
        verts = [a.peg.vertices for a in m_assets]
        peg_vertices = np.stack(
            [np.concatenate([v, np.repeat(v[:1], nv - len(v), 0)]) for v in verts]
        )
        # a point below the surface within this distance of the hole axis is in the hole
        radius = [np.linalg.norm(a.peg.vertices[:, :2], axis=1).max() for a in m_assets]
        self.module_tables = {
            "entrance": entrance,
            "bottom": bottom,
            "entrance_inv": T.inverse(entrance),
            "bottom_inv": T.inverse(bottom),
            "peg_vertices": peg_vertices,
            "peg_reach": np.linalg.norm(peg_vertices, axis=2).max(axis=1),
            "hole_radius": np.array(radius) + np.array([a.clearance for a in m_assets]) + 0.001,
        }
        self._use_modules()

        n = self.num_envs
        self.global_step = 0
        """Environment steps taken so far, summed over envs (drives the curriculum)."""
        self.curriculum = (
            None
            if self.cfg.curriculum_success is None
            else SuccessCurriculum(
                self.cfg.curriculum_success,
                self.cfg.curriculum_increment,
                self.cfg.curriculum_window,
            )
        )
        """The success-gated curriculum (TaskConfig.curriculum_success), or None."""
        self.inside_gate: TakeoffGate | None = (
            None
            if self.cfg.inside_starts_until is None
            else TakeoffGate(self.cfg.inside_starts_until, self.cfg.curriculum_window)
        )
        """Turns the inside starts off at take-off (TaskConfig.inside_starts_until), or None."""
        self.module_replay: ModuleReplay | None = None
        """Modules drawn by their failures (TaskConfig.module_replay), or None: in turn."""
        if self.cfg.module_replay is not None:
            if not self.rotate_modules:
                raise ValueError(
                    f"module_replay = {self.cfg.module_replay}: modules are replayed by their "
                    f"failures only when envs take them in turns (rotate_modules, fewer envs "
                    f"than the {len(modules)} modules; here {self.num_envs} envs)"
                )
            self.module_replay = ModuleReplay(len(modules), self.cfg.module_replay)
        self.unstable_count = 0
        """Episodes cut short because their physics went unstable."""
        self.spawn_draws = 0
        """Spawn poses drawn, redraws included."""
        self.spawn_redraws = 0
        """Spawn poses drawn again because the robot holding the peg could not reach them
        (always 0 for the floating peg): 1 - redraws / draws is the reachable share."""
        self.rng = np.random.default_rng()
        self._steps = np.zeros(n, dtype=np.int64)
        self._return = np.zeros(n)
        self._c_prev = np.zeros(n)
        self._d0 = np.ones(n)
        self._assisted = np.zeros(n, dtype=bool)  # this episode started inside the hole
        # a robot's readings after the 18 pose entries (TaskConfig.readings), with their noise
        self._reading_noise = reading_noise(self.cfg)
        self.obs_dim = self.observation_layout()[-1][1].stop
        for r in self.cfg.readings:  # an engine without them refuses here, not mid-run
            if r not in ENV_READINGS:
                self.sim.readings(r)
        self.camera = None
        """The camera drawing the image after the readings (TaskConfig.camera), or None."""
        if self.cfg.camera is not None:
            # the renderer imports MuJoCo, which an env without a camera may never load
            from sim.cameras.render import CameraRenderer

            self.camera = CameraRenderer(modules, self.cfg.camera, cache=max(64, 2 * n))
        self._obs = np.zeros((n, self.obs_dim), dtype=np.float32)
        cfg = self.cfg
        self._act_scale = np.array([cfg.max_lin_vel] * 3 + [cfg.max_ang_vel] * 3)
        self._act_noise = np.array([cfg.act_lin_noise] * 3 + [cfg.act_ang_noise] * 3)
        self._step_params = K.StepParams.of(cfg)
        self._no_noise = np.zeros((n, 6), dtype=np.float32)
        self._live: np.ndarray | None = None
        self.parks_finished = self.sim.parks_idle
        """Whether set_live parks envs (an engine that skips idle envs) or is ignored."""

    # ------------------------------------------------------------------ helpers

    def _use_modules(self) -> None:
        """Per-env constants from the per-module ones, for the envs' current modules."""
        rows = self.module_row[self.env_module]
        self.entrance = self.module_tables["entrance"][rows]
        self.bottom = self.module_tables["bottom"][rows]
        self.entrance_inv = self.module_tables["entrance_inv"][rows]
        self.bottom_inv = self.module_tables["bottom_inv"][rows]
        self.peg_vertices = self.module_tables["peg_vertices"][rows]
        self.peg_reach = self.module_tables["peg_reach"][rows]
        self.hole_radius = self.module_tables["hole_radius"][rows]
        self._frames = self.module_frames[rows]
        self._kframes = self._kernel_frames(self._frames, self.bottom)
        self._entrance_quat = self.module_entrance_quat[rows]
        # Actions are velocities in the entrance frame. A Table I entrance is the module's
        # axes, so its actions pass as they are (bit for bit); an assembly step's entrance
        # may be turned (the bolt goes in along -x), so an agent trained on Table I inserts
        # it unchanged.
        turn = self.entrance[:, :3, :3]
        self._act_turn = (
            None if np.array_equal(turn, np.broadcast_to(np.eye(3), turn.shape)) else turn
        )
        # The failure rule measures heights from the module's z = 0 plane, Table I's mounting
        # surface. An env whose entrance is not on that plane with the module's axes (an
        # assembly step) is scored with its poses and frames in its entrance frame, so the
        # rule measures from the surface its part enters; observation, reward and success
        # are relative poses and do not change. Table I envs are scored as before.
        flat = np.all(turn == np.eye(3), axis=(1, 2)) & (self.entrance[:, 2, 3] == 0.0)
        self._local = np.flatnonzero(~flat)
        self._scored = None
        if len(self._local):
            entrance, bottom = self.entrance.copy(), self.bottom.copy()
            entrance[self._local] = np.eye(4)
            bottom[self._local] = self.entrance_inv[self._local] @ self.bottom[self._local]
            self._scored = self._kernel_frames(T.ObsFrames.of(entrance, bottom), bottom)

    def _kernel_frames(self, frames: T.ObsFrames, bottom: np.ndarray) -> K.Frames:
        """The per-env tables the step's kernels read, for observation frames `frames` and
        bottom frames `bottom` (n, 4, 4)."""
        return K.Frames(
            rows=frames.rows,
            origin=frames.origin_in,
            bottom_pos=frames.bottom_pos,
            bottom_quat_conj=frames.bottom_quat_conj,
            bottom=bottom,
            vertices=self.peg_vertices,
            hole_radius=self.hole_radius,
            reach=self.peg_reach,
        )

    def rotate_envs(self, idx: np.ndarray) -> None:
        """Envs idx hand their modules to the back of the queue and take the front ones."""
        replay = self.module_replay
        for e in idx.tolist():
            self.module_queue.append(int(self.env_module[e]))
            queue = self.module_queue
            k = queue.pop(0 if replay is None else replay.pick(self.rng, queue))
            self.env_module[e] = k
            self.sim.set_module(e, self.module_ids[k])
        self._use_modules()

    def inside_share(self) -> float:
        """The share of the next episodes that start inside the hole (TaskConfig.inside_starts;
        0 once the take-off gate has closed, or without them)."""
        closed = self.inside_gate is not None and not self.inside_gate.open
        return 0.0 if self.cfg.inside_starts is None or closed else self.cfg.inside_starts

    def curriculum_scale(self) -> float:
        """Fraction of the full spawn ranges in use now (1 without a curriculum)."""
        if self.curriculum is not None:
            return self.curriculum.level
        return self.cfg.curriculum_scale(self.global_step)

    def peg_poses(self) -> np.ndarray:
        """(num_envs, 4, 4) true peg poses in the module frame."""
        return T.pose(self.sim.peg_pos, self.sim.peg_quat)

    def _observe(self, idx: np.ndarray) -> np.ndarray:
        """(k, 18) float32 observations of envs idx (indices or a mask) from their current
        poses, with this call's estimation noise (if on)."""
        idx = np.arange(self.num_envs)[idx]
        cfg = self.cfg
        e = T.pose_noise(self.rng, len(idx)) if cfg.noise else np.zeros((len(idx), 6), np.float32)
        out = np.empty((len(idx), self.obs_dim), dtype=np.float32)
        K.observe(self.sim.state, idx, self._kframes, e, self._step_params, out)
        self._add_readings(idx, out)
        return out

    def _add_readings(
        self, idx: np.ndarray, out: np.ndarray, rows: np.ndarray | slice = slice(None)
    ) -> None:
        """The readings of envs idx (TaskConfig.readings) into out[rows, 18:] (rows: where
        out holds those envs), with their noise (drawn only when there are readings: without
        them, the draws are the paper's)."""
        image_start = T.OBS_DIM + len(self._reading_noise)  # the readings lie before it
        if self.cfg.readings:
            values = np.concatenate([self._reading(r, idx) for r in self.cfg.readings], axis=1)
            if self.cfg.noise:
                values = values + self._reading_noise * self.rng.standard_normal(values.shape)
            out[rows, T.OBS_DIM : image_start] = values
        if self.camera is not None:
            pos, quat = self.sim.peg_pos[idx], self.sim.peg_quat[idx]
            images = self.camera.render(self.env_module[idx], pos, quat)
            if self.cfg.noise:
                corrupt(images, self.camera.cfg, self.rng)
            out[rows, image_start:] = images.reshape(len(images), -1)

    def _reading(self, name: str, idx: np.ndarray) -> np.ndarray:
        """(k, n) the reading `name` of envs idx, noise-free: the env's own (ENV_READINGS) or
        the engine's."""
        if name == "peg":  # position, then the rotation's first two columns
            rot = T.pose(self.sim.peg_pos[idx], self.sim.peg_quat[idx])[:, :3, :3]
            return np.concatenate([self.sim.peg_pos[idx], rot[:, :, 0], rot[:, :, 1]], axis=1)
        return self.sim.readings(name)[idx]

    def observation_layout(self) -> list[tuple[str, slice, tuple[int, ...]]]:
        """What each part of an observation holds: (name, its columns, its shape), in order:
        "pose" (the 18-D relative pose, sim/task/rules.py), each reading by its name
        (TaskConfig.readings), then "camera_<view>_<modality>" (channels, height, width)."""
        parts = [("pose", (T.OBS_DIM,))]
        parts += [(r, (sum(n for _, n in READINGS[r]),)) for r in self.cfg.readings]
        if self.cfg.camera is not None:
            c = self.cfg.camera
            parts.append((f"camera_{c.view}_{c.modality}", c.shape))
        out, start = [], 0
        for name, shape in parts:
            size = int(np.prod(shape))
            out.append((name, slice(start, start + size), shape))
            start += size
        return out

    def _start_episodes(self, idx: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> None:
        """Bookkeeping of episodes starting at poses pos (k, 3), quat (k, 4) in envs idx."""
        f = self._frames
        cfg = self.cfg
        d0 = T.seat_distance(
            pos, quat, f.bottom_pos[idx], f.bottom_quat_conj[idx], cfg.dist_pos_weight,
            cfg.dist_rot_weight, cfg.dist_axis_weight, f.rows[idx, 5],
        )  # fmt: skip
        self._d0[idx] = np.maximum(d0, 1e-9)
        self._c_prev[idx] = 0.0
        self._steps[idx] = 0
        self._return[idx] = 0.0

    def _reset_envs(self, idx: np.ndarray) -> None:
        """New episodes for envs idx: spawn, contact randomisation, bookkeeping."""
        if len(idx) == 0:
            return
        if self.rotate_modules:
            self.rotate_envs(idx)
        cfg = self.cfg
        scale: float | np.ndarray = self.curriculum_scale()
        if cfg.near_starts is not None:  # a share of the episodes starts near the hole
            near = self.rng.random(len(idx)) < cfg.near_starts
            scale = np.where(near, cfg.near_start_scale, scale)
        pos, quat = T.sample_spawn(
            self.rng,
            self.entrance[idx, :3, 3],
            self._entrance_quat[idx],
            self.peg_vertices[idx],
            scale,
            cfg,
        )
        self._assisted[idx] = False
        share = self.inside_share()
        if share:  # a share starts inside the hole (reverse curriculum)
            inside = self.rng.random(len(idx)) < share
            pos[inside], quat[inside] = self._inside_poses(idx[inside])
            self._assisted[idx] = inside
        pos, quat = self._place(idx, pos, quat, scale)
        k = len(idx)
        # static and dynamic friction are drawn as in the original; each engine takes them
        # as it models contact (BatchSim.set_material, PhysxBatchSim.set_material)
        u = self.rng.random((3, k))  # static friction, dynamic friction, restitution
        lo, hi = np.array([cfg.friction_range, cfg.friction_range, cfg.restitution_range]).T
        static, dynamic, restitution = lo[:, None] + (hi - lo)[:, None] * u
        self.sim.set_material(idx, static, dynamic, restitution)
        self._start_episodes(idx, pos, quat)

    def _inside_poses(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (k, 3) and quaternions (k, 4) of pegs of envs idx inside their holes:
        turned as on the seat, their bottoms on the axis between the entrance and twice the
        success radius above the seat (TaskConfig.inside_starts)."""
        seat, entrance = self.bottom[idx, :3, 3], self.entrance[idx, :3, 3]
        depth = np.linalg.norm(entrance - seat, axis=1)
        low = np.minimum(2.0 * self.cfg.success_radius / np.maximum(depth, 1e-9), 1.0)
        u = low + (1.0 - low) * self.rng.random(len(idx))
        return seat + u[:, None] * (entrance - seat), matrix_to_quat(self.bottom[idx, :3, :3])

    MAX_SPAWN_DRAWS = 200
    """Draws of one env's spawn pose before a robot that reaches none of them is refused."""

    def _place(
        self, idx: np.ndarray, pos: np.ndarray, quat: np.ndarray, scale: float | np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Put the pegs of envs idx at their drawn spawn poses; where a robot holding the peg
        cannot reach one, draw that env's pose again (counted in spawn_redraws). The
        floating peg takes every pose, and draws nothing more."""
        self.spawn_draws += len(idx)
        placed = self.sim.place(idx, pos, quat)
        if placed is None:
            return pos, quat
        for _ in range(self.MAX_SPAWN_DRAWS):
            if placed.all():
                return pos, quat
            miss = np.flatnonzero(~placed)
            self.spawn_draws += len(miss)
            self.spawn_redraws += len(miss)
            s = scale[miss] if np.ndim(scale) > 0 else scale
            p, q = T.sample_spawn(self.rng, self.entrance[idx[miss], :3, 3],
                                  self._entrance_quat[idx[miss]], self.peg_vertices[idx[miss]],
                                  s, self.cfg)  # fmt: skip
            pos[miss], quat[miss] = p, q
            placed[miss] = self.sim.place(idx[miss], p, q)
        e = int(idx[np.flatnonzero(~placed)[0]])
        why = getattr(self.sim, "unreached", {}).get(e, "")
        raise ValueError(
            f"{self.robot}: none of {self.MAX_SPAWN_DRAWS} spawn poses of env {e} "
            f"(module {self.module_ids[self.env_module[e]]}) is in reach; the last: {why}"
        )

    def set_peg_poses(self, idx: np.ndarray, poses: np.ndarray) -> None:
        """Put the pegs of envs idx at `poses` (k, 4, 4), at rest, and restart their
        episodes from there (for tests, demonstrations and hand-made starts)."""
        idx = np.atleast_1d(np.asarray(idx))
        quat = matrix_to_quat(poses[:, :3, :3])
        self.sim.set_pose(idx, poses[:, :3, 3], quat)
        self._assisted[idx] = False
        self._start_episodes(idx, poses[:, :3, 3], quat)
        self._obs[idx] = self._observe(idx)

    # ------------------------------------------------------------------ API

    def restart_modules(self) -> None:
        """Put every env back on its first module and the queue in its first order (a
        rotating env; others never change modules)."""
        if not self.rotate_modules:
            return
        first, queue = self.first_assignment
        self.module_queue = list(queue)
        for e, k in enumerate(first.tolist()):
            if self.env_module[e] != k:
                self.env_module[e] = k
                self.sim.set_module(e, self.module_ids[k])

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Reset every env; `seed` makes everything after it reproducible (a rotating env
        also starts the modules' order again)."""
        if seed is not None:
            self.rng = np.random.default_rng(seed)
            self.restart_modules()
        self._reset_envs(np.arange(self.num_envs))
        self._obs = self._observe(np.arange(self.num_envs))
        return self._obs.copy()

    PARK_HEIGHT = 0.3
    """How far above its hole's entrance (m, along the entrance's axis) an env that no longer
    counts holds its peg: out of contact, it costs its shard almost nothing to step."""

    def set_live(self, live: np.ndarray | None) -> None:
        """Envs whose episodes still count (num_envs,) bool, or None (all): an evaluation's
        envs that have played all their attempts are let go. With MuJoCo's BatchSim, an env
        that stops counting is parked: its peg held at rest PARK_HEIGHT above its hole, its
        commands zero, its episode never ending, and a shard with no live env is not stepped
        at all; an env that counts again (and every parked env at None) starts a new
        episode. The draws of a run that parks envs differ from one that does not. Other
        engines ignore it."""
        if not self.parks_finished:
            return
        old = self._live if self._live is not None else np.ones(self.num_envs, dtype=bool)
        if live is None:
            new = np.ones(self.num_envs, dtype=bool)
        else:
            new = np.asarray(live, dtype=bool)
            if new.shape != (self.num_envs,):
                raise ValueError(f"live must have shape ({self.num_envs},), got {new.shape}")
        park = np.flatnonzero(old & ~new)
        if len(park):
            e = self.entrance[park]
            self.sim.set_pose(park, e[:, :3, 3] + self.PARK_HEIGHT * e[:, :3, 2],
                              self._entrance_quat[park])  # fmt: skip
        wake = np.flatnonzero(~old & new)
        if len(wake):
            self._reset_envs(wake)
            self._obs[wake] = self._observe(wake)
        self._live = None if new.all() else new.copy()

    def _check_actions(self, actions: np.ndarray) -> np.ndarray:
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != (self.num_envs, T.ACT_DIM):
            raise ValueError(
                f"actions must have shape (num_envs, 6) = ({self.num_envs}, 6), got "
                f"{np.shape(actions)}"
            )
        # one reduction on the common path (NaN and inf propagate; a sum of huge finite
        # actions that overflows is looked at row by row too and passes)
        bad = [] if np.isfinite(a.sum()) else np.flatnonzero(~np.isfinite(a).all(axis=1))
        if len(bad):
            envs = bad.tolist()
            raise ValueError(
                f"actions of envs {envs[:20]}{' ...' if len(envs) > 20 else ''} contain NaN "
                "or inf; actions must be finite (they are clipped to [-1, 1])"
            )
        return a

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
        cfg = self.cfg
        n = self.num_envs
        actions = self._check_actions(actions)
        # the command noise, then this step's pose-estimation errors, in one draw: the same
        # stream as two draws, the second after the physics
        e = self.rng.standard_normal((2 * n, 6), dtype=np.float32) if cfg.noise else None
        act_e, noise = (e[:n], e[n:]) if e is not None else (self._no_noise, self._no_noise)
        velocity = np.empty((n, T.ACT_DIM))
        K.command(actions, act_e, cfg.noise, self._act_scale, self._act_noise, velocity)
        if self._act_turn is not None:
            velocity[:, :3] = np.einsum("nij,nj->ni", self._act_turn, velocity[:, :3])
            velocity[:, 3:] = np.einsum("nij,nj->ni", self._act_turn, velocity[:, 3:])
        live = self._live
        if live is None:
            unstable = self.sim.step(velocity)
        else:
            velocity[~live] = 0.0  # parked pegs stay where they are
            unstable = self.sim.step(velocity, live)
        self.global_step += n
        self._steps += 1
        obs = np.empty((n, self.obs_dim), dtype=np.float32)
        reward = np.empty(n)
        success = np.empty(n, dtype=bool)
        failure = np.empty(n, dtype=bool)
        frames, state = self._kframes, self.sim.state
        if self._scored is not None:
            frames = self._scored
            state = state.copy()
            i, e = self._local, self.entrance[self._local]
            state[i, 1:4] = np.einsum("nji,nj->ni", e[:, :3, :3], state[i, 1:4] - e[:, :3, 3])
            state[i, 4:8] = quat_mul(quat_conj(self._entrance_quat[i]), state[i, 4:8])
        episode = K.Episode(
            d0=self._d0, c_prev=self._c_prev, returns=self._return, last_obs=self._obs
        )
        out = K.Outcome(obs=obs, reward=reward, success=success, failure=failure)
        K.score(state, unstable, noise, frames, episode, self._step_params, out)
        if live is not None:  # a parked env's episode never ends
            success &= live
            failure &= live
            unstable &= live
        terminated = success | failure
        truncated = ~terminated & ((self._steps >= cfg.max_steps) | unstable)
        if live is not None:
            truncated &= live
        done = terminated | truncated
        if unstable.any():
            self.unstable_count += int(unstable.sum())
        if self.cfg.readings or self.camera is not None:
            # an unstable env keeps its last observation, readings and image included
            stable = np.flatnonzero(~unstable)
            self._add_readings(stable, obs, stable)
        info = {
            "final_obs": obs.copy(),
            "success": success,
            "failure": failure,
            "unstable": unstable,
            "episode_return": self._return.copy(),
            "episode_length": self._steps.copy(),
            "time_to_success": np.where(success, self._steps * self.control_dt, np.nan),
            "module": self.env_module.copy(),
            "peg_pose": self.sim.state[:, 1:8].copy(),
            "assisted": self._assisted.copy(),
        }
        counted = done & ~self._assisted  # an episode started inside the hole counts nowhere
        if self.curriculum is not None:  # before the resets: they spawn at the new scale
            self.curriculum.update(counted, success)
        if self.inside_gate is not None:  # before the resets: they draw by the gate's decision
            self.inside_gate.update(counted, success, self.global_step)
        if self.module_replay is not None:  # before the resets: they pick by the new scores
            self.module_replay.update(self.env_module, counted, success)
        idx = np.flatnonzero(done)
        if len(idx):
            self._reset_envs(idx)
            obs[idx] = self._observe(idx)
        self._obs = obs
        return obs.copy(), reward, terminated, truncated, info

    # ------------------------------------------------------------------ exact resume

    def get_state(self) -> dict:
        """Everything needed to continue identically (rl/vec_env.py's StatefulVecEnv):
        physics, per-env contact draws, episode bookkeeping, RNG, counters. (MuJoCo's solver
        warm start is not state here: every control step starts it cold.)"""
        if not self.stateful:
            raise ValueError(f"engine = {self.engine!r}: saving the env's state is MuJoCo's only")
        friction, solref = self.sim.contact_params()
        return {
            "shard_state": self.sim.shard_state_now(),
            "friction": friction,
            "solref": solref,
            "steps": self._steps.copy(),
            "return": self._return.copy(),
            "c_prev": self._c_prev.copy(),
            "d0": self._d0.copy(),
            "assisted": self._assisted.copy(),
            "obs": self._obs.copy(),
            "rng": self.rng.bit_generator.state,
            "global_step": int(self.global_step),
            "unstable_count": int(self.unstable_count),
            "env_module": self.env_module.copy(),
            "queue": np.array(self.module_queue, dtype=np.int64),
            # the envs set_live parked (an evaluation's tail): restored as they are, not parked
            # again, so that a resumed evaluation steps exactly as an uncut one
            **({} if self._live is None else {"live": self._live.copy()}),
            **({} if self.curriculum is None else {"curriculum": self.curriculum.state()}),
            **({} if self.inside_gate is None else {"inside_gate": self.inside_gate.state()}),
            **({} if self.module_replay is None else {"module_replay": self.module_replay.state()}),
        }

    def set_state(self, state: dict) -> None:
        """Restore a `get_state` result on an env built the same way (same modules,
        num_envs, shard_size); raises ValueError naming a mismatched array."""
        want = {
            "shard_state": self.sim.shard_state.shape,
            "friction": (self.num_envs,),
            "solref": (self.num_envs, 2),
            "steps": (self.num_envs,),
            "obs": self._obs.shape,
        }
        for k, shape in want.items():
            if np.shape(state[k]) != shape:
                raise ValueError(
                    f"env state {k!r} has shape {np.shape(state[k])}, this env needs {shape}: "
                    "build the env with the same dataset, num_envs and shard_size"
                )
        if "env_module" not in state:
            raise ValueError("env state without 'env_module': saved by an older version")
        if ("curriculum" in state) != (self.curriculum is not None):
            raise ValueError(
                "env state and env differ in their curriculum (success-gated or by env "
                "steps): build the env with the same curriculum_success"
            )
        if ("module_replay" in state) != (self.module_replay is not None):
            raise ValueError(
                "env state and env differ in their module replay: build the env with the "
                "same module_replay"
            )
        env_module = np.asarray(state["env_module"], dtype=np.int64)
        if env_module.shape != self.env_module.shape or (
            not self.rotate_modules and not np.array_equal(env_module, self.env_module)
        ):
            raise ValueError(
                "env state 'env_module' differs from this env's module assignment: build the "
                "env with the same dataset, num_envs, seed and module rotation"
            )
        if self.rotate_modules:
            self.module_queue = np.asarray(state["queue"], dtype=np.int64).tolist()
            for e, k in enumerate(env_module.tolist()):
                self.sim.set_module(e, self.module_ids[k])
            self.env_module[:] = env_module
            self._use_modules()
        self.sim.shard_state[:] = state["shard_state"]
        self.sim.gather()
        self.sim.set_contact_params(np.asarray(state["friction"]), np.asarray(state["solref"]))
        self._steps[:] = state["steps"]
        self._return[:] = state["return"]
        self._c_prev[:] = state["c_prev"]
        self._d0[:] = state["d0"]
        self._assisted[:] = state.get("assisted", False)  # saved before inside starts: none
        self._obs[:] = state["obs"]
        rng = np.random.default_rng()
        rng.bit_generator.state = state["rng"]
        self.rng = rng
        self.global_step = int(state["global_step"])
        self.unstable_count = int(state["unstable_count"])
        live = state.get("live")
        self._live = None if live is None else np.asarray(live, dtype=bool).copy()
        if self.curriculum is not None:
            self.curriculum.load(state["curriculum"])
        if self.module_replay is not None:
            self.module_replay.load(state["module_replay"])
        if self.inside_gate is not None:
            self.inside_gate.load(state["inside_gate"])

    def close(self) -> None:
        self.sim.close()
        if self.camera is not None:
            self.camera.close()


def train_config(
    dataset: str,
    curriculum_steps: int | None = None,
    keep_physics: bool = False,
    curriculum_success: float | None = None,
    module_replay: float | None = None,
    near_starts: float | None = None,
    axis_shaping: float | None = None,
    readings: tuple[str, ...] = (),
    inside_starts: float | None = None,
    inside_starts_until: float | None = None,
    camera: CameraConfig | None = None,
) -> tuple[Path, TaskConfig]:
    """The dataset's folder and the training task's config: the paper's task with its
    curriculum over `curriculum_steps` env steps (default: the paper's 50 M), or gated by
    the training episodes' `curriculum_success` rate (sim/task/curriculum.py), the physics of
    the dataset's files checked (see make_train_env)."""
    root = dataset_root(dataset)
    config = TaskConfig(physics=check_physics(root, keep_physics))
    if curriculum_steps is not None:
        config = replace(config, curriculum_steps=int(curriculum_steps))
    if curriculum_success is not None:
        config = replace(config, curriculum_success=float(curriculum_success)).validate()
    if module_replay is not None:
        config = replace(config, module_replay=float(module_replay)).validate()
    if near_starts is not None:
        config = replace(config, near_starts=float(near_starts)).validate()
    if inside_starts is not None:
        config = replace(config, inside_starts=float(inside_starts)).validate()
    if inside_starts_until is not None:
        config = replace(config, inside_starts_until=float(inside_starts_until)).validate()
    if axis_shaping is not None:
        config = replace(config, dist_axis_weight=float(axis_shaping)).validate()
    if readings:
        config = replace(config, readings=tuple(readings)).validate()
    if camera is not None:
        config = replace(config, camera=camera).validate()
    return root, config


def make_train_env(
    dataset: str,
    num_envs: int,
    seed: int,
    curriculum_steps: int | None = None,
    keep_physics: bool = False,
    engine: str = DEFAULT_ENGINE,
    curriculum_success: float | None = None,
    module_replay: float | None = None,
    near_starts: float | None = None,
    axis_shaping: float | None = None,
    robot: str | None = None,
    readings: tuple[str, ...] = (),
    inside_starts: float | None = None,
    inside_starts_until: float | None = None,
    camera: CameraConfig | None = None,
) -> PegInHoleVecEnv:
    """rl's `make_env(dataset, num_envs, seed, curriculum_steps=N)` for training: the
    paper's task with its curriculum over `curriculum_steps` env steps (default: the
    paper's 50 M); `seed` orders the modules. With fewer envs than modules, the envs take
    the modules in turns (a new module at every episode), so training sees all of them.
    A dataset written for other physics is refused unless `keep_physics` (then it is
    simulated with the physics its files carry). engine: a registered engine's name (physx,
    the referee, serves one env per module, so num_envs must cover the dataset's modules;
    for training on mujoco-warp the command line takes sim/engines/warp/env.py's env, the
    task on the device). near_starts, inside_starts, inside_starts_until: TaskConfig's;
    axis_shaping: TaskConfig.dist_axis_weight; robot: a registered robot holds the peg (None:
    it floats); readings, camera: what it adds to the observation (TaskConfig.readings,
    TaskConfig.camera). dataset may join several with `+`
    (`train+profile_train+multi_peg_train`): their modules train together, as one set, where
    their files carry the same physics."""
    options = (curriculum_steps, keep_physics, curriculum_success, module_replay, near_starts,
               axis_shaping, readings, inside_starts, inside_starts_until, camera)  # fmt: skip
    parts = [train_config(name, *options) for name in str(dataset).split("+")]
    root, config = parts[0]
    if len(parts) > 1:
        if any(c.physics != config.physics for _, c in parts):
            raise ValueError(
                f"--dataset {dataset}: its datasets were written for different physics; "
                "regenerate the older ones (`assetgen sample --dataset NAME --overwrite`)"
            )
        root = [m for r, _ in parts for m in load_modules(r)]
        ids = [m.id for m in root]
        if len(set(ids)) < len(ids):
            raise ValueError(
                f"--dataset {dataset}: two of its datasets hold modules of the same id; join "
                "datasets of different families (Table I's ids are 000000, a profile's "
                "000000/peg)"
            )
    return PegInHoleVecEnv(
        root,
        num_envs,
        config,
        assignment_seed=seed,
        rotate_modules=True,
        engine=engine,
        robot=robot,
    )


def eval_config(noise_scale: float = 1.0) -> TaskConfig:
    """The evaluation protocol's task config (noise on, curriculum off), its four noise
    standard deviations times `noise_scale` (2: twice the paper's)."""
    from sim.task.config import EVAL_CONFIG

    if not (math.isfinite(noise_scale) and noise_scale >= 0):
        raise ValueError(f"noise_scale = {noise_scale}: give a factor >= 0 (1: the paper's noise)")
    c = EVAL_CONFIG
    return replace(
        c,
        obs_pos_noise=c.obs_pos_noise * noise_scale,
        obs_rot_noise=c.obs_rot_noise * noise_scale,
        act_lin_noise=c.act_lin_noise * noise_scale,
        act_ang_noise=c.act_ang_noise * noise_scale,
    )


def make_eval_env(
    dataset: str,
    num_envs: int | None,
    seed: int,
    noise_scale: float = 1.0,
    modules: int | None = None,
    keep_physics: bool = False,
    engine: str = DEFAULT_ENGINE,
    physx: PhysxConfig | None = None,
    robot: str | None = None,
    readings: tuple[str, ...] = (),
    camera: CameraConfig | None = None,
    robot_settings: Any = None,
) -> PegInHoleVecEnv:
    """rl's `make_env` for evaluation: noise on, curriculum off (full spawn ranges), and the
    paper's protocol of one env per module. num_envs is an upper bound (None: none): fewer
    envs than modules would leave modules out (ValueError), more would repeat some.
    noise_scale multiplies the four noise standard deviations (robustness: 2 = twice the
    paper's). The env's `protocol` dict names the dataset (folder and content hash), the
    control period and the noise scale, for the evaluation file. modules: the dataset's
    first `modules` modules only (a training run's probe; the protocol uses all).
    keep_physics: as for make_train_env. engine: a registered engine's name (physx with the PhysX
    settings `physx`). robot: a registered robot holds the peg (None: it floats), with its
    own settings `robot_settings` (None: its defaults); readings, camera: what it adds to the
    observation (TaskConfig.readings, TaskConfig.camera)."""
    from assetgen.dataset.reader import Dataset, content_hash

    root = dataset_root(dataset)
    config = replace(eval_config(noise_scale), physics=check_physics(root, keep_physics))
    if readings:
        config = replace(config, readings=tuple(readings)).validate()
    if camera is not None:
        config = replace(config, camera=camera).validate()
    ids = None
    if modules is not None:
        if modules < 1:
            raise ValueError(f"modules = {modules}: evaluate at least 1 module")
        ids = Dataset(root).ids[:modules]
    modules = load_modules(root, ids)
    if num_envs is not None and num_envs < len(modules):
        raise ValueError(
            f"num_envs = {num_envs} is less than the dataset's {len(modules)} modules: a "
            "checkpoint is evaluated with one env per module; raise num_envs"
        )
    env = PegInHoleVecEnv(
        modules,
        None,  # one env per module the robot (if any) holds
        config,
        assignment_seed=seed,
        engine=engine,
        physx=physx,
        robot=robot,
        robot_settings=robot_settings,
    )
    ds = Dataset(root)
    env.protocol = {
        "dataset_folder": recorded_path(root),
        "dataset_hash": content_hash(ds.records),
        "control_dt": env.control_dt,
        "noise_scale": noise_scale,
        "physics_version": physics_from_record(ds.info.get("physics"))[0],
        "timestep": env.cfg.physics.timestep,
        "engine": engine,
        # envs done with their attempts: parked and skipped (set_live), or stepped to the end
        # as before (evaluation files without this field); the two draw differently
        "finished_envs": "parked" if env.parks_finished else "stepped",
    }
    if robot is not None:  # the floating peg's files keep their fields as they were
        env.protocol["robot"] = env.robot
        if env.refused:
            env.protocol["refused_modules"] = sorted(env.refused)
    if readings:
        env.protocol["readings"] = list(readings)
    if camera is not None:
        env.protocol["camera"] = asdict(camera)
    if ids is not None:
        env.protocol["modules"] = len(ids)  # a subset: the first N of the dataset's modules
    env.protocol.update(env.sim.protocol())  # the engine's own settings, if any
    return env
