"""The env on the device: the task of sim/env.py on MuJoCo Warp, with the pegs' states, the
actions, the observations and the task's arithmetic all on the simulator's device as torch
tensors, so a torch agent on that device steps it with no copy through the host.

PegInHoleVecEnv with `engine="mujoco-warp"` keeps the env state and the task's arithmetic on
the host: each control step copies the states down and back and scores them in one compiled
single-threaded pass, which at thousands of worlds costs as much as the physics. Here the
Warp arrays of the states, the commands and the per-world model fields are seen as torch
tensors (`wp.to_torch`, no copy), and every per-step quantity is computed from them by
sim/task/rules_torch.py: commands and their noise, the physics (one captured CUDA graph), the
unstable test, observations, rewards, success and failure, and the resets of finished
episodes (module rotation, spawn, contact draws), all batched over the envs and free of
host synchronisation. The host reads the contact counters every `check_every` steps.

The contract is PegInHoleVecEnv's, on tensors: `reset(seed)` and `step(actions)` return
tensors on the device (observations float32 (n, 18), rewards float32, flags bool, the info
dict's arrays as tensors). What differs: the random draws come from torch's generator on the
device, so the episodes are not those of the host env for the same seed (the arithmetic is
held equal to the host's by tests/test_warp_env.py); Table I modules only (an assembly
step's turned entrance is refused); no saved env state (a resumed run starts from a reset).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch

from sim.assets.loading import ModuleAsset
from sim.env import PegInHoleVecEnv, train_config
from sim.task import kernel as K
from sim.task import rules as T
from sim.task import rules_torch as TT
from sim.task.config import TaskConfig

ENGINE = "mujoco-warp"
"""The registered engine (sim/engines/registry.py) this env steps."""


class WarpTorchVecEnv:
    """`num_envs` peg-in-hole envs, one MuJoCo Warp world each, on torch tensors on the
    simulator's device (see module doc). The arguments are PegInHoleVecEnv's; `device` a
    Warp device ("cuda:0", "cpu"; None: the GPU if there is one); `check_every`: control
    steps between reads of the contact counters (MuJoCo Warp drops what does not fit)."""

    obs_dim = T.OBS_DIM
    act_dim = T.ACT_DIM
    stateful = False
    """Its state is on the device and not saved: a resumed run starts from a reset."""
    tensor_io = True
    """Takes and returns torch tensors on `device` (rl/host_view.py gives numpy users a view)."""

    def __init__(
        self,
        dataset: str | Path | list[ModuleAsset],
        num_envs: int | None = None,
        config: TaskConfig | None = None,
        *,
        module_ids: list[str] | None = None,
        assignment_seed: int = 0,
        rotate_modules: bool = False,
        device: str | None = None,
        check_every: int = 64,
    ) -> None:
        if config is not None and config.near_starts is not None:
            raise ValueError(
                "near_starts (--near-starts): starts near the hole for a share of the episodes "
                "run in the host env only (PegInHoleVecEnv: --sim mujoco or physx)"
            )
        if config is not None and config.inside_starts is not None:
            raise ValueError(
                "inside_starts (--inside-starts): starts inside the hole run in the host env "
                "only (PegInHoleVecEnv: --sim mujoco or physx)"
            )
        if config is not None and config.dist_axis_weight != 0.0:
            raise ValueError(
                "dist_axis_weight (--axis-shaping): the reward's axis term runs in the host "
                "env only (PegInHoleVecEnv: --sim mujoco or physx)"
            )
        if config is not None and config.module_replay is not None:
            raise ValueError(
                "module_replay (--module-replay): modules replayed by their failures run in "
                "the host env only (PegInHoleVecEnv: --sim mujoco); the env on the device "
                "takes its modules in turn"
            )
        if config is not None and config.curriculum_success is not None:
            raise ValueError(
                "curriculum_success (--curriculum-success): the success-gated curriculum "
                "runs in the host env only (PegInHoleVecEnv: --sim mujoco or physx); the env "
                "on the device takes curriculum_steps (--curriculum-steps)"
            )
        # the host env builds the engine and the per-module tables; this env then keeps its
        # own copies on the device and steps the engine itself
        base = PegInHoleVecEnv(
            dataset, num_envs, config, module_ids=module_ids, assignment_seed=assignment_seed,
            rotate_modules=rotate_modules, engine=ENGINE, warp_device=device,
        )  # fmt: skip
        # per-module constants, rows in base.module_row order (the modules the envs can hold)
        known = np.flatnonzero(base.module_row >= 0)
        entrance = base.module_tables["entrance"]
        flat = np.all(entrance[:, :3, :3] == np.eye(3), axis=(1, 2)) & (entrance[:, 2, 3] == 0)
        if not flat.all():
            raise ValueError(
                f"module {base.module_ids[known[np.argmin(flat)]]!r}: the env on the device takes "
                "Table I modules (entrance on the mounting surface, module axes); use "
                "PegInHoleVecEnv for assembly steps"
            )
        self.base = base
        self.sim = sim = base.sim
        self.cfg = cfg = base.cfg
        self.num_envs = n = base.num_envs
        self.control_dt = base.control_dt
        self.module_ids = base.module_ids
        self.rotate_modules = base.rotate_modules
        self.protocol: dict[str, Any] = {}
        wp = sim.wp
        self._wp = wp
        self.device = dev = torch.device(wp.device_to_torch(sim.device))
        self.check_every = int(check_every)
        f64 = torch.float64

        def t(a: Any, dtype: torch.dtype = f64) -> torch.Tensor:
            return torch.as_tensor(np.ascontiguousarray(a), dtype=dtype, device=dev)

        self._known_ids = [base.module_ids[k] for k in known]
        self._mod_row = t(base.module_row, torch.int64)
        mf = base.module_frames
        self._mframes = TT.TorchFrames.of(
            K.Frames(
                rows=mf.rows,
                origin=mf.origin_in,
                bottom_pos=mf.bottom_pos,
                bottom_quat_conj=mf.bottom_quat_conj,
                bottom=base.module_tables["bottom"],
                vertices=base.module_tables["peg_vertices"],
                hole_radius=base.module_tables["hole_radius"],
                reach=base.module_tables["peg_reach"],
            ),
            dev,
        )
        self._m_entrance_pos = t(entrance[:, :3, 3])
        self._m_entrance_quat = t(base.module_entrance_quat)
        # the engine's per-world fields and each module's values of them
        self._fields = {f: wp.to_torch(getattr(sim.model, f)) for f in sim.host}
        self._tables = {
            f: torch.stack(
                [torch.as_tensor(sim.cast(f, sim.per_module[m][f])) for m in self._known_ids]
            )
            .reshape(len(known), *view.shape[1:])  # geom_aabb: (6,) on the host, (2, 3) here
            .to(dev)
            for f, view in self._fields.items()
        }
        poses = [sim.pose_rows(m) for m in self._known_ids]
        self._pose_tables = (
            t(np.stack([p[0] for p in poses]), torch.float32),
            t(np.stack([p[1] for p in poses]), torch.float32),
        )
        d = sim.data
        self._xpos, self._xmat = wp.to_torch(d.geom_xpos), wp.to_torch(d.geom_xmat)
        self._qpos, self._qvel = wp.to_torch(d.qpos), wp.to_torch(d.qvel)
        self._ctrl, self._time = wp.to_torch(d.ctrl), wp.to_torch(d.time)
        self._counters = [wp.to_torch(a) for a in (d.ncollision, d.nacon, d.nefc)]
        self._peak = torch.zeros(3, dtype=torch.int64, device=dev)

        # the task's constants
        self._params = K.StepParams.of(cfg)
        self._checks = K.Checks.of(cfg.physics)
        self._scale = t([cfg.max_lin_vel] * 3 + [cfg.max_ang_vel] * 3)
        self._act_noise = t([cfg.act_lin_noise] * 3 + [cfg.act_ang_noise] * 3)

        # module assignment (rotation: a ring of the modules no env holds, as base.module_queue)
        first, queue = base.first_assignment
        self._first = (t(first, torch.int64), t(np.asarray(queue, dtype=np.int64), torch.int64))
        self.env_module = self._first[0].clone()
        self.module_queue = self._first[1].clone()

        self.global_step = 0
        self.gen = torch.Generator(device=dev)
        z = lambda dtype=f64: torch.zeros(n, dtype=dtype, device=dev)  # noqa: E731
        self._steps = z(torch.int64)
        self._unstable = z(torch.int64)
        self._episode = TT.TorchEpisode(
            d0=torch.ones(n, dtype=f64, device=dev),
            c_prev=z(),
            returns=z(),
            last_obs=torch.zeros((n, T.OBS_DIM), dtype=torch.float32, device=dev),
        )
        self._frames = self._env_frames()
        self._saved: list[torch.Tensor] = []
        self._fresh_fields = True

    # ------------------------------------------------------------------ helpers

    @property
    def unstable_count(self) -> int:
        """Episodes cut short because their physics went unstable (reads the device)."""
        return int(self._unstable.sum())

    def curriculum_scale(self) -> float:
        """Fraction of the full spawn ranges in use now (1 without a curriculum)."""
        return self.cfg.curriculum_scale(self.global_step)

    def _env_frames(self) -> TT.TorchFrames:
        rows = self._mod_row[self.env_module]
        m = self._mframes
        return TT.TorchFrames(**{k: getattr(m, k)[rows] for k in m.__dataclass_fields__})

    def rotate_envs(self, mask: torch.Tensor) -> None:
        """Envs in `mask`, in index order, hand their modules to the back of the queue and
        take the front ones: base.rotate_envs's FIFO, batched. With S = queue ++ (the handed-back
        modules in env order), the j-th env in the mask takes S[j] and the queue becomes
        S[k : k + L] (k envs, L queued modules)."""
        n, q = self.num_envs, self.module_queue
        length = len(q)
        pos = torch.cumsum(mask.long(), 0) - 1
        k = mask.long().sum()
        handed = torch.zeros(n + 1, dtype=torch.int64, device=self.device)
        handed.scatter_(0, torch.where(mask, pos, n), self.env_module)

        def s(i: torch.Tensor) -> torch.Tensor:
            return torch.where(
                i < length, q[i.clamp(0, length - 1)], handed[(i - length).clamp(0, n)]
            )

        new = s(pos)
        self.module_queue = s(k + torch.arange(length, device=self.device))
        self.env_module = torch.where(mask, new, self.env_module)

    def _use_modules(self, mask: torch.Tensor) -> None:
        """The worlds in `mask` take their (new) modules' fields and fixed-geom poses."""
        rows = self._mod_row[self.env_module]
        for f, view in self._fields.items():
            m = mask.view(-1, *[1] * (view.dim() - 1))
            view.copy_(torch.where(m, self._tables[f][rows], view))
        for view, table in zip((self._xpos, self._xmat), self._pose_tables, strict=True):
            m = mask.view(-1, *[1] * (view.dim() - 1))
            view.copy_(torch.where(m, table[rows], view))
        self._frames = self._env_frames()

    def _observe(self) -> torch.Tensor:
        """(n, 18) float32 observations of every env from its current pose."""
        pos, quat = self._qpos[:, :3].double(), self._qpos[:, 3:7].double()
        e = self._draw_noise()
        f = self._frames
        return TT.observe(pos, quat, f.rows, f.origin, e, self._params)

    def _draw_noise(self) -> torch.Tensor:
        n = self.num_envs
        if not self.cfg.noise:
            return torch.zeros((n, 6), dtype=torch.float32, device=self.device)
        return torch.randn((n, 6), generator=self.gen, device=self.device, dtype=torch.float32)

    def _reset(self, mask: torch.Tensor) -> None:
        """New episodes in the envs of `mask`: module rotation, spawn, contact draws,
        bookkeeping (PegInHoleVecEnv._reset_envs, on the device)."""
        if self.rotate_modules:
            self.rotate_envs(mask)
        if self.rotate_modules or self._fresh_fields:
            self._use_modules(mask)
            self._fresh_fields = False
        f, rows = self._frames, self._mod_row[self.env_module]
        pos, quat = TT.sample_spawn(
            self.gen,
            self._m_entrance_pos[rows],
            self._m_entrance_quat[rows],
            f.vertices,
            self.curriculum_scale(),
            self.cfg,
        )
        quat = quat / quat.norm(dim=1, keepdim=True)
        m = mask[:, None]
        self._qpos.copy_(torch.where(m, torch.cat([pos, quat], 1).float(), self._qpos))
        self._qvel.copy_(torch.where(m, torch.zeros_like(self._qvel), self._qvel))
        # dynamic friction and restitution as the host env draws them (static is MuJoCo's
        # unused); the peg geom's priority makes its values the contact's
        u = torch.rand(
            (3, self.num_envs), generator=self.gen, device=self.device, dtype=torch.float64
        )
        lo, hi = self.cfg.friction_range
        friction = lo + (hi - lo) * u[1]
        lo, hi = self.cfg.restitution_range
        e = (lo + (hi - lo) * u[2]).clamp(0.0, 1.0)
        p = self.cfg.physics
        zeta = p.dampratio - e * (p.dampratio - p.min_dampratio)
        g = self.sim.peg_geom
        fr, sr = self._fields["geom_friction"], self._fields["geom_solref"]
        fr[:, g, 0] = torch.where(mask, friction.float(), fr[:, g, 0])
        solref = torch.stack([p.contact_timeconst / zeta, zeta], 1).float()
        sr[:, g] = torch.where(m, solref, sr[:, g])
        ep = self._episode
        d0 = TT.seat_distance(pos, quat, f.bottom_pos, f.bottom_quat_conj, self._params)
        ep.d0.copy_(torch.where(mask, d0.clamp(min=1e-9), ep.d0))
        zero = torch.zeros_like(ep.c_prev)
        ep.c_prev.copy_(torch.where(mask, zero, ep.c_prev))
        ep.returns.copy_(torch.where(mask, zero, ep.returns))
        self._steps.copy_(torch.where(mask, torch.zeros_like(self._steps), self._steps))

    def _physics(self) -> torch.Tensor:
        """One control step of every world; returns the unstable flags (n,)."""
        self._time.zero_()  # float32 time: each control step counts from 0
        cuda = self.device.type == "cuda"
        if cuda:  # torch's queued writes first; Warp runs on its own stream
            torch.cuda.current_stream(self.device).synchronize()
        if not self._saved:
            self._saved = [v.clone() for v in (self._qpos, self._qvel, self._ctrl)]
        self.sim.device_substeps(restore=self._restore)
        if cuda:
            self._wp.synchronize_device(self.sim.device)
        state = torch.cat([self._time[:, None], self._qpos, self._qvel], 1).double()
        unstable = TT.check_unstable(state, self._checks)
        c = self._checks
        return unstable | ((state[:, 0] - c.control_step).abs() > 0.5 * c.timestep)

    def _restore(self) -> None:
        """Undo the compiling pass of the first graph capture (WarpBatchSim.device_substeps):
        after that pass, before the capture, on either side of the streams."""
        self._wp.synchronize_device(self.sim.device)
        for view, saved in zip((self._qpos, self._qvel, self._ctrl), self._saved, strict=True):
            view.copy_(saved)
        self._time.zero_()
        if self.device.type == "cuda":
            torch.cuda.synchronize(self.device)

    def _check_capacity(self) -> None:
        """Raise as WarpBatchSim does when the last steps' contacts or constraint rows
        filled what was allocated (the peak since the last check)."""
        pairs, nacon, nefc = (int(v) for v in self._peak.tolist())
        self._peak.zero_()
        d = self.sim.data
        if max(pairs, nacon) >= d.naconmax or nefc >= d.njmax:
            raise RuntimeError(
                f"MuJoCo Warp ran out of room: {pairs} collision pairs and {nacon} contacts "
                f"of {d.naconmax} allocated, {nefc} constraint rows of {d.njmax} a world; "
                "build the env with a larger nconmax / njmax"
            )

    # ------------------------------------------------------------------ API

    def reset(self, seed: int | None = None) -> torch.Tensor:
        """Reset every env; `seed` makes everything after it reproducible (a rotating env
        also starts the modules' order again)."""
        if seed is not None:
            self.gen.manual_seed(int(seed))
            if self.rotate_modules:
                self.env_module = self._first[0].clone()
                self.module_queue = self._first[1].clone()
                self._fresh_fields = True
        everyone = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        self._reset(everyone)
        self._episode.last_obs = self._observe()
        return self._episode.last_obs.clone()

    def set_peg_poses(self, idx: np.ndarray | torch.Tensor, poses: np.ndarray) -> None:
        """Put the pegs of envs idx at `poses` (k, 4, 4), at rest, and restart their episodes
        from there (PegInHoleVecEnv.set_peg_poses: for tests and hand-made starts)."""
        from assetgen.core.rotations import matrix_to_quat

        idx = torch.as_tensor(np.atleast_1d(np.asarray(idx)), device=self.device)
        poses = np.asarray(poses, dtype=float)
        quat = matrix_to_quat(poses[:, :3, :3])
        quat = quat / np.linalg.norm(quat, axis=1, keepdims=True)
        quat = torch.as_tensor(quat, device=self.device)
        pos = torch.as_tensor(poses[:, :3, 3], device=self.device)
        self._qpos[idx] = torch.cat([pos, quat], 1).float()
        self._qvel[idx] = 0.0
        f, ep = self._frames, self._episode
        d0 = TT.seat_distance(pos, quat, f.bottom_pos[idx], f.bottom_quat_conj[idx], self._params)
        ep.d0[idx] = d0.clamp(min=1e-9)
        ep.c_prev[idx] = 0.0
        ep.returns[idx] = 0.0
        self._steps[idx] = 0
        mask = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        mask[idx] = True
        ep.last_obs = torch.where(mask[:, None], self._observe(), ep.last_obs)

    def step(
        self, actions: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, dict[str, torch.Tensor]]:
        n, cfg = self.num_envs, self.cfg
        a = torch.as_tensor(actions, device=self.device)
        if a.shape != (n, 6):
            raise ValueError(
                f"actions must have shape (num_envs, 6) = ({n}, 6), got {tuple(a.shape)}"
            )
        e = self._draw_noise() if cfg.noise else None
        velocity = TT.command(a, e, self._scale, self._act_noise)
        self._ctrl.copy_(velocity.float())
        unstable = self._physics()
        for i, c in enumerate(self._counters):
            self._peak[i] = torch.maximum(self._peak[i], c.max().long())
        self.global_step += n
        self._steps += 1
        if self.global_step // n % self.check_every == 1 or self.check_every == 1:
            self._check_capacity()
        pos, quat = self._qpos[:, :3], self._qpos[:, 3:7]
        ep = self._episode
        obs, reward, success, failure = TT.score(
            pos, quat, unstable, self._draw_noise(), self._frames, ep, self._params
        )
        terminated = success | failure
        truncated = ~terminated & ((self._steps >= cfg.max_steps) | unstable)
        done = terminated | truncated
        self._unstable += unstable.long()
        info = {
            "final_obs": obs.clone(),
            "success": success,
            "failure": failure,
            "unstable": unstable,
            "episode_return": ep.returns.clone(),
            "episode_length": self._steps.clone(),
            "time_to_success": torch.where(
                success, self._steps * self.control_dt, torch.full_like(ep.returns, float("nan"))
            ),
            "module": self.env_module.clone(),
            "peg_pose": self._qpos.double().clone(),
        }
        self._reset(done)
        obs = torch.where(done[:, None], self._observe(), obs)
        ep.last_obs = obs
        return obs.clone(), reward.float(), terminated, truncated, info

    def close(self) -> None:
        self.sim.close()


def make_device_train_env(
    dataset: str, num_envs: int, seed: int, engine: str = ENGINE, **task: Any
) -> WarpTorchVecEnv:
    """sim.env.make_train_env's env on the device: the same task (`task`: train_config's
    keywords), modules in turns."""
    if engine != ENGINE:
        raise ValueError(f"engine = {engine!r}: the env on the device runs on {ENGINE}")
    # WarpTorchVecEnv refuses what runs in the host env only (a success-gated curriculum, ...)
    root, config = train_config(dataset, **task)
    return WarpTorchVecEnv(root, num_envs, config, assignment_seed=seed, rotate_modules=True)
