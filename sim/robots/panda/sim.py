"""Panda arms holding the pegs: the engine interface (sim.engines.base.EngineSim) over
MuJoCo, the peg moved through the arm's joints.

Two controllers turn the commanded twist of the peg's bottom-face centre into the arm's motion
(ArmSettings.controller; docs/robot.md has the measurement that chose the first):
- impedance (the default): six actuators on the peg's site apply kv (commanded - measured
  twist), which MuJoCo maps to joint torques through the site's Jacobian at every physics
  step;
- ik: damped least squares at the policy rate (kinematics.joint_velocity) into per-physics-step
  position targets of the joints' actuators, a ramp from the measured joints.
Either way MuJoCo steps all substeps in C (`mujoco.rollout`, one model per env, no Python in
between), and the joints' torques are clamped at the Panda's published limits, so a peg
pressed into the plate meets a bounded force.

A peg is placed (`place`, the env's spawns) in the posture the arm reaches by carrying it there
from the module's aligned pose over the hole (kinematics.carry): a pose is refused where that
path passes a joint limit or an arm link through the module, so the way back to the hole is
in the arm's reach from every accepted spawn.
"""

from __future__ import annotations

import copy
import os
from dataclasses import asdict

import mujoco
import numpy as np
from mujoco import rollout

from sim.assets.loading import ModuleAsset
from sim.engines.base import EngineOptions, EngineSim
from sim.engines.mujoco.batch import check_capacity
from sim.engines.mujoco.scene import contact_solref, geom_contacts, restitution_to_dampratio
from sim.robots.panda.kinematics import carry, joint_velocity, peg_jacobian, reach
from sim.robots.panda.model import ArmSettings
from sim.robots.panda.scene import SENSOR_DIMS, SENSORS, Mount, build_arm_spec
from sim.task.config import TaskConfig

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS


class UnreachableError(ValueError):
    """A peg pose the arm cannot take."""


class PandaSim(EngineSim):
    """`num_envs` Panda arms, each holding its module's peg (see the module doc)."""

    saves_state = False
    parks_idle = False
    rotates_modules = True

    def __init__(
        self,
        env_assets: list[ModuleAsset],
        task: TaskConfig,
        nthread: int | None = None,
        mount: Mount | None = None,
        settings: ArmSettings | None = None,
        seed: int = 0,
        spare_assets: list[ModuleAsset] | None = None,
    ) -> None:
        self.task = task
        self.settings = settings = (settings or ArmSettings()).validate()
        self.assets = list(env_assets)
        self.num_envs = n = len(env_assets)
        p = task.physics
        self.substeps = p.substeps
        self.mount = mount or Mount()
        self._known = {a.id: a for a in list(env_assets) + list(spare_assets or ())}
        self.pool: dict[str, mujoco.MjModel] = {}
        """Module id -> its model (0.75 MB each), for every module given."""
        for mid in self._known:
            self._model(mid)
        self.models = [copy.copy(self.pool[a.id]) for a in env_assets]
        m0 = self.models[0]
        self.nthread = max(1, nthread if nthread is not None else os.cpu_count() or 1)
        self._scratch = [mujoco.MjData(m) for m in self.models]
        # `rollout` steps every env's model with one MjData per thread: those come from a
        # capacity model (batch.py's reasoning), the module with the most BVH nodes padded
        # with inert geoms to the largest geom count; every model has the arm's 7 joints and
        # no other state, so one state size serves all
        distinct = list(self.pool.values())
        big_id = max(self.pool, key=lambda k: (self.pool[k].nbvh, self.pool[k].ngeom))
        pad = max(m.ngeom for m in distinct) - self.pool[big_id].ngeom
        capacity = self.pool[big_id] if pad == 0 else self._build(big_id, pad)
        check_capacity(capacity, distinct)
        self.datas = [mujoco.MjData(capacity) for _ in range(self.nthread)]
        self._rollout = rollout.Rollout(nthread=self.nthread if self.nthread > 1 else 0)
        self.nfull = mujoco.mj_stateSize(m0, STATE_SPEC)
        self.full = np.zeros((n, self.nfull))
        self._sensor = np.zeros((n, p.substeps, m0.nsensordata))
        self._out = np.zeros((n, p.substeps, self.nfull))
        self._ctrl = np.zeros((n, p.substeps, m0.nu))
        off = np.cumsum((0, *SENSOR_DIMS))
        self._slices = {s: slice(off[i], off[i + 1]) for i, s in enumerate(SENSORS)}
        self._lead = np.array(settings.kv) / np.array(settings.kp)
        self._lo, self._hi = m0.jnt_range[:7, 0].copy(), m0.jnt_range[:7, 1].copy()
        self._rng = np.random.default_rng(seed)
        self.state = np.zeros((n, 14))
        self.state[:, 4] = 1.0
        self._aligned: dict[str, np.ndarray] = {}
        """Module id -> the joints that hold its peg aligned over its hole (_aligned_joints)."""
        self.unreached: dict[int, str] = {}
        """Env -> why its last refused pose was out of reach (place)."""
        self.wrist = np.zeros((n, 6))
        """(num_envs, 6) the wrist's force (N) and torque (N m) on the peg, peg frame, at the
        last physics step."""
        for e in range(n):
            self._place(e, *self._entrance_pose(e))

    @classmethod
    def create(cls, env_assets, task, spare_assets, options: EngineOptions) -> PandaSim:
        return cls(env_assets, task, options.nthread, settings=options.robot_settings,
                   spare_assets=spare_assets)  # fmt: skip

    def _build(self, module_id: str, pad_geoms: int = 0) -> mujoco.MjModel:
        spec = build_arm_spec(self._known[module_id], self.task.physics, self.mount,
                              self.settings, visual=False)  # fmt: skip
        for i in range(pad_geoms):  # inert: they only enlarge the model (capacity)
            g = spec.worldbody.add_geom()
            g.name = f"pad{i}"
            g.size = [0.001, 0, 0]
            g.pos = [0.0, 0.0, -10.0]
            g.contype = g.conaffinity = 0
        return spec.compile()

    def _model(self, module_id: str) -> mujoco.MjModel:
        m = self.pool.get(module_id)
        if m is None:
            m = self.pool[module_id] = self._build(module_id)
        return m

    def set_module(self, e: int, module_id: str) -> None:
        """Put env `e` on module `module_id` (one given at construction): its own copy of
        the module's model (friction and restitution are the env's); place its peg next."""
        if module_id not in self._known:
            raise ValueError(f"module {module_id!r} was not given to this PandaSim")
        self.models[e] = m = copy.copy(self.pool[module_id])
        self._scratch[e] = mujoco.MjData(m)
        self.assets[e] = self._known[module_id]

    # ------------------------------------------------------------------ poses

    def _entrance_pose(self, e: int) -> tuple[np.ndarray, np.ndarray]:
        """The pose a new env's peg waits in: aligned with its hole, 0.2 m over the entrance."""
        a = self.assets[e]
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, a.bottom[:3, :3].ravel())
        return a.entrance[:3, 3] + a.bottom[:3, 2] * 0.2, quat

    ALIGNED_HEIGHT = 0.05
    """The aligned pose's height over the entrance along the hole's axis, m."""

    def _aligned_joints(self, e: int) -> np.ndarray:
        """The joints that hold env e's peg in its hole's orientation ALIGNED_HEIGHT over
        the entrance on the hole's axis, the pose every insertion passes (inverse
        kinematics from HOME; UnreachableError naming the module and the joints where the
        arm cannot)."""
        a = self.assets[e]
        q = self._aligned.get(a.id)
        if q is None:
            quat = np.zeros(4)
            mujoco.mju_mat2Quat(quat, a.bottom[:3, :3].ravel())
            pos = a.entrance[:3, 3] + a.bottom[:3, 2] * self.ALIGNED_HEIGHT
            q, limits = reach(self.models[e], self._scratch[e], pos, quat, self._rng)
            if q is None:
                raise UnreachableError(
                    f"module {a.id}: the Panda cannot hold its peg aligned over the hole; "
                    f"stopped by {', '.join(limits) or 'its reach'}"
                )
            self._aligned[a.id] = q
        return q

    def _place(self, e: int, pos: np.ndarray, quat: np.ndarray) -> None:
        """Put env e's peg at pos, quat through the arm, in the posture reached by carrying
        the peg there from its aligned pose (kinematics.carry): the insertion's path back
        is then in the arm's reach, joint limits included (UnreachableError if not)."""
        m, d = self.models[e], self._scratch[e]
        q, limits = carry(m, d, self._aligned_joints(e), pos, quat)
        if q is None:
            raise UnreachableError(
                f"module {self.assets[e].id}: the Panda cannot hold its peg at "
                f"{np.round(pos, 3).tolist()} m, {np.round(quat, 3).tolist()}; stopped by "
                f"{', '.join(limits) or 'its reach'}"
            )
        d.qpos[:7] = q
        d.qvel[:] = 0.0
        d.ctrl[:] = 0.0 if self.settings.impedance else q
        d.time = self.full[e, 0]
        mujoco.mj_forward(m, d)
        mujoco.mj_getState(m, d, self.full[e], STATE_SPEC)
        self._read(e, d.sensordata)

    def set_pose(self, idx: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> None:
        """Put the pegs of envs idx at rest at pos (k, 3), quat (k, 4) through the arm's
        inverse kinematics (UnreachableError naming the first pose out of reach)."""
        done = self.place(idx, pos, quat)
        if not done.all():
            e = int(np.arange(self.num_envs)[idx][np.flatnonzero(~done)[0]])
            raise UnreachableError(self.unreached[e])

    def place(self, idx: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """set_pose for the poses the arm reaches; (k,) bool: which it did (the others keep
        their state, and `unreached` holds why for each env)."""
        quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
        done = np.ones(len(pos), dtype=bool)
        for j, e in enumerate(np.arange(self.num_envs)[idx]):
            try:
                self._place(int(e), pos[j], quat[j])
            except UnreachableError as err:
                done[j] = False
                self.unreached[int(e)] = str(err)
        return done

    def set_material(self, idx, static, dynamic, restitution) -> None:
        del static
        solref = contact_solref(restitution_to_dampratio(restitution, self.task.physics),
                                self.task.physics)  # fmt: skip
        for j, e in enumerate(np.arange(self.num_envs)[idx]):
            m = self.models[e]
            b = m.body("peg")
            g = slice(int(b.geomadr[0]), int(b.geomadr[0] + b.geomnum[0]))
            m.geom_friction[g, 0] = dynamic[j]
            m.geom_solref[g] = solref[j]

    # ------------------------------------------------------------------ stepping

    def _read(self, e: int, sensordata: np.ndarray) -> None:
        s = self._slices
        self.state[e, 1:4] = sensordata[s["peg_pos"]]
        q = sensordata[s["peg_quat"]]
        self.state[e, 4:8] = q
        self.state[e, 8:11] = sensordata[s["peg_linvel"]]
        # a free joint's angular velocity is in the body frame: R^T w
        w = np.zeros(3)
        conj = np.array([q[0], -q[1], -q[2], -q[3]])
        mujoco.mju_rotVecQuat(w, sensordata[s["peg_angvel"]], conj)
        self.state[e, 11:14] = w
        self.wrist[e, :3] = sensordata[s["wrist_force"]]
        self.wrist[e, 3:] = sensordata[s["wrist_torque"]]

    def joint_positions(self) -> np.ndarray:
        """(num_envs, 7) the arm's joint positions, rad."""
        return self.full[:, 1:8].copy()

    def step(self, velocity: np.ndarray, live: np.ndarray | None = None) -> np.ndarray:
        """One control step: the twists (num_envs, 6) of the pegs' bottom-face centres
        (module frame) through the controller of the module doc. Returns (num_envs,) bool:
        envs whose physics broke down (non-finite state)."""
        del live
        n = self.num_envs
        if self.settings.impedance:
            self._ctrl[:] = np.asarray(velocity, float)[:, None, :]
            return self._run()
        jac = np.empty((n, 6, 7))
        for e in range(n):
            m, d = self.models[e], self._scratch[e]
            d.qpos[:] = self.full[e, 1:8]
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            jac[e] = peg_jacobian(m, d)
        q = self.full[:, 1:8]
        qd = joint_velocity(jac, np.asarray(velocity, float), q, self.settings, self._lo,
                            self._hi, self.task.control_dt)  # fmt: skip
        h = self.task.physics.timestep
        t = h * np.arange(1, self.substeps + 1)
        self._ctrl[:] = q[:, None, :] + qd[:, None, :] * (t[None, :, None] + self._lead)
        return self._run()

    def _run(self) -> np.ndarray:
        """The substeps of every env at the controls in _ctrl; (num_envs,) bool: broke down."""
        n = self.num_envs
        self._rollout.rollout(
            self.models,
            self.datas,
            self.full,
            self._ctrl,
            nstep=self.substeps,
            state=self._out,
            sensordata=self._sensor,
            skip_checks=True,
        )
        self.full[:] = self._out[:, -1]
        for e in range(n):
            self._read(e, self._sensor[e, -1])
        return ~np.isfinite(self.full).all(axis=1)

    def readings(self, name: str) -> np.ndarray:
        """The wrist's force and torque (num_envs, 6), or the joints' positions and
        velocities (num_envs, 14)."""
        # the joints: qpos (7), then qvel (7), FULLPHYSICS's entries after the time
        found = {"wrist": self.wrist, "joints": self.full[:, 1:15]}.get(name)
        return super().readings(name) if found is None else found

    def protocol(self) -> dict:
        """The arm's settings and mount, for an evaluation file."""
        return {"arm": asdict(self.settings), "mount": asdict(self.mount)}

    def gather(self) -> None:
        """The state is read at every step (sensors); nothing to refresh."""

    def contacts(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        m, d = self.models[i], self._scratch[i]
        mujoco.mj_setState(m, d, self.full[i], STATE_SPEC)
        d.ctrl[:] = self._ctrl[i, -1]  # the controls of the last physics step (the push)
        mujoco.mj_forward(m, d)
        b = m.body("peg")
        return geom_contacts(m, d, range(int(b.geomadr[0]), int(b.geomadr[0] + b.geomnum[0])))

    def close(self) -> None:
        self._rollout.close()
