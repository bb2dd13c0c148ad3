"""The contact stress benchmark (sim/bench/stress) with the Panda holding the peg.

The same cases as the floating peg's (cases.py: pushes, impacts, friction, rebounds), from the
same start poses and with the same commands, but the commands go to the arm's impedance
controller (sim/robots/panda/sim.py), so the peg meets the module with the arm's inertia and
its force caps behind it (50 N and 10 N m, against the floating peg's 9.1 N at a full
command). Each run starts with the arm in the posture that carries the peg to the run's start
pose from its aligned pose over the hole (kinematics.carry, without the contact check: the
runs start in the hole), its joints moving at the start twist. The `free` runs (the floating
peg's actuators off) keep gravity compensation and the posture spring and switch the twist
actuators off: an arm cannot let go of its peg mid-air.

    assetgen bench contacts DATASET --robot panda [--limit N] [--cases ...]
"""

from __future__ import annotations

import os
from collections.abc import Callable

import mujoco
import numpy as np
from mujoco import rollout

from sim.assets.loading import ModuleAsset
from sim.bench.stress.cases import Run, StressConfig, module_runs, press_as_force
from sim.bench.stress.figures import run_figures
from sim.bench.stress.mujoco import add_contact_sensor, model_variant
from sim.robots.panda.kinematics import carry, peg_jacobian, reach
from sim.robots.panda.model import ArmSettings
from sim.robots.panda.scene import SENSOR_DIMS, Mount, build_arm_spec
from sim.task.config import PhysicsConfig, TaskConfig

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS
ALIGNED_HEIGHT = 0.05
"""The aligned pose's height over the entrance, m (as PandaSim.ALIGNED_HEIGHT)."""


def arm_model(asset: ModuleAsset, physics: PhysicsConfig, settings: ArmSettings) -> mujoco.MjModel:
    """The arm holding the module's peg, with the contact sensor after the scene's sensors."""
    spec = build_arm_spec(asset, physics, Mount(), settings, visual=False)
    add_contact_sensor(spec, "peg")
    return spec.compile()


def _twist_off(m: mujoco.MjModel) -> None:
    """The `free` runs: the twist actuators off; gravity compensation and posture stay."""
    m.actuator_gainprm[:, 0] = 0.0
    m.actuator_biasprm[:, 2] = 0.0


def _start_state(
    m: mujoco.MjModel, d: mujoco.MjData, aligned: np.ndarray, run: Run
) -> np.ndarray | None:
    """The arm's full physics state at the run's start pose and twist, or None where the arm
    cannot carry the peg there."""
    q, _ = carry(m, d, aligned, run.qpos[:3], run.qpos[3:], collide=False)
    if q is None:
        return None
    mujoco.mj_resetData(m, d)
    d.qpos[:7] = q
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    jac = peg_jacobian(m, d)
    w = np.zeros(3)  # the run's angular velocity is in the peg frame; the Jacobian's is not
    mujoco.mju_rotVecQuat(w, run.qvel[3:], run.qpos[3:])
    d.qvel[:7] = np.linalg.lstsq(jac, np.concatenate([run.qvel[:3], w]), rcond=None)[0]
    state = np.empty(mujoco.mj_stateSize(m, STATE_SPEC))
    mujoco.mj_getState(m, d, state, STATE_SPEC)
    return state


def run_module(
    asset: ModuleAsset,
    task: TaskConfig,
    cfg: StressConfig,
    settings: ArmSettings,
    pool: rollout.Rollout,
    nthread: int,
    seed: int = 0,
) -> tuple[list[dict], int]:
    """Every run of one module that the arm can start: one record a run, and how many runs
    it could not start."""
    model = arm_model(asset, task.physics, settings)
    runs, geo = module_runs(asset, cfg)
    h = model.opt.timestep
    press_as_force(runs, cfg, settings.kv_lin)
    d = mujoco.MjData(model)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, asset.bottom[:3, :3].ravel())
    above = asset.entrance[:3, 3] + asset.bottom[:3, 2] * ALIGNED_HEIGHT
    aligned, _ = reach(model, d, above, quat, np.random.default_rng(seed))
    if aligned is None:
        return [], len(runs)
    off = np.cumsum((0, *SENSOR_DIMS))
    records: list[dict] = []
    skipped = 0
    groups: dict[tuple[str, int], list[Run]] = {}
    for r in runs:
        groups.setdefault((r.variant, round(r.duration / h)), []).append(r)
    datas = [mujoco.MjData(model) for _ in range(nthread)]
    for (variant, nstep), group in groups.items():
        m = model_variant(model, variant, free=_twist_off)
        starts = [_start_state(m, d, aligned, r) for r in group]
        skipped += sum(s is None for s in starts)
        group = [r for r, s in zip(group, starts, strict=True) if s is not None]
        if not group:
            continue
        state0 = np.array([s for s in starts if s is not None])
        times = np.arange(nstep) * h
        ctrl = np.array([r.ctrl(times) for r in group])
        sensor = np.empty((len(group), nstep, model.nsensordata))
        pool.rollout([m] * len(group), datas, state0, ctrl, nstep=nstep, sensordata=sensor,
                     skip_checks=True)  # fmt: skip
        pos, q = sensor[:, :, off[0] : off[1]], sensor[:, :, off[1] : off[2]]
        lin, ang = sensor[:, :, off[2] : off[3]], sensor[:, :, off[3] : off[4]]
        body = np.empty_like(ang)  # the floating peg's angular velocity is in its own frame
        for i in range(len(group)):
            for k in range(nstep):
                conj = q[i, k] * (1.0, -1.0, -1.0, -1.0)
                mujoco.mju_rotVecQuat(body[i, k], ang[i, k], conj)
        contact = sensor[:, :, off[-1] : off[-1] + 2]
        records += run_figures(group, pos, q, lin, body, contact, geo, cfg, h, settings.kv_lin)
    return [{"module": asset.id, **r} for r in records], skipped


def stress_on_panda(
    assets: list[ModuleAsset],
    cfg: StressConfig,
    task: TaskConfig,
    settings: ArmSettings | None = None,
    progress: Callable[[int, int], None] | None = None,
    *,
    nthread: int | None = None,
) -> list[dict]:
    """Every run of every module with the arm holding the peg (the stress runner's signature,
    sim/bench/stress/command.py). A run the arm cannot start is left out and counted in the
    first record of its module (`arm_unstarted`)."""
    settings = (settings or ArmSettings()).validate()
    nthread = max(1, nthread or os.cpu_count() or 1)
    records: list[dict] = []
    with rollout.Rollout(nthread=nthread if nthread > 1 else 0) as pool:
        for k, asset in enumerate(assets):
            got, skipped = run_module(asset, task, cfg, settings, pool, nthread)
            if got:
                got[0]["arm_unstarted"] = skipped
            records += got
            if progress is not None:
                progress(k + 1, len(assets))
    return records
