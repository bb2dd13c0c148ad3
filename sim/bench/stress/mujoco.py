"""The contact stress benchmark's runs (sim/bench/stress/cases.py) on MuJoCo.

Each module is stepped open loop (the commands are fixed in advance) through `mujoco.rollout` in
C threads, one model per module: the simulator's own model of it (sim.engines.mujoco.scene,
under the given PhysicsConfig) or its exported `peg_in_hole.xml` (the physics the file carries).
A contact sensor on the peg reads MuJoCo's own contact distance at every physics step.

The module's model with the contact sensor (module_model), every run of one module
(run_module), of every module (stress), and `stress` in the registry's runner signature
(stress_on_mujoco, which sim/engines/registry.py names).

    assetgen bench contacts DATASET [--limit N] [--set FIELD=VALUE ...] [--source sim|mjcf]
"""

from __future__ import annotations

import copy
import os
from collections.abc import Callable

import mujoco
import numpy as np
from mujoco import rollout

from sim.assets.loading import ModuleAsset
from sim.bench.stress.cases import Run, StressConfig, module_runs, press_as_force
from sim.bench.stress.figures import run_figures
from sim.engines.mujoco.scene import build_spec
from sim.task.config import PhysicsConfig, TaskConfig

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS


# ----------------------------------------------------------------------------- models


def add_contact_sensor(spec: mujoco.MjSpec, body: str) -> None:
    """The deepest contact of `body` each step: sensordata (found, dist)."""
    s = spec.add_sensor()
    s.name = "peg_contact"
    s.type = mujoco.mjtSensor.mjSENS_CONTACT
    s.objtype = mujoco.mjtObj.mjOBJ_BODY
    s.objname = body
    fields = (mujoco.mjtConDataField.mjCONDATA_FOUND, mujoco.mjtConDataField.mjCONDATA_DIST)
    s.intprm[0] = sum(1 << int(f) for f in fields)
    s.intprm[1] = 1  # reduce: the contact of least distance
    s.intprm[2] = 1  # one contact


def module_model(
    asset: ModuleAsset, physics: PhysicsConfig, task: TaskConfig, mjcf: str | None = None
) -> mujoco.MjModel:
    """The module's model with the contact sensor: the simulator's (sim.engines.mujoco.scene) under
    `physics`, or the exported file `mjcf` as it is (its own physics)."""
    if mjcf is None:
        spec = build_spec(
            [asset], physics, max_lin_vel=task.max_lin_vel, max_ang_vel=task.max_ang_vel
        )
    else:
        spec = mujoco.MjSpec.from_file(mjcf)
    add_contact_sensor(spec, "peg")
    return spec.compile()


def _actuators_off(m: mujoco.MjModel) -> None:
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_ACTUATION)


def model_variant(
    base: mujoco.MjModel,
    name: str,
    free: Callable[[mujoco.MjModel], None] = _actuators_off,
) -> mujoco.MjModel:
    """A run's model (cases.Run.variant): `base` itself, a copy whose peg has the sliding
    friction of `mu=X`, or (`free`) a copy that `free` lets go of the peg in."""
    if name == "base":
        return base
    m = copy.copy(base)
    if name == "free":
        free(m)
    elif name.startswith("mu="):
        peg = m.body("peg")
        m.geom_friction[peg.geomadr[0] : peg.geomadr[0] + peg.geomnum[0], 0] = float(name[3:])
    else:
        raise ValueError(f"unknown model variant {name!r}")
    return m


# ----------------------------------------------------------------------------- running


def run_module(
    asset: ModuleAsset,
    model: mujoco.MjModel,
    cfg: StressConfig,
    pool: rollout.Rollout,
    nthread: int,
) -> list[dict]:
    """Every run of one module; one record (its figures) a run."""
    runs, geo = module_runs(asset, cfg)
    h = model.opt.timestep
    kv = float(model.actuator_gainprm[0, 0])
    press_as_force(runs, cfg, kv)
    scratch = mujoco.MjData(model)
    nstate = mujoco.mj_stateSize(model, STATE_SPEC)
    joint = model.body("peg").jntadr[0]
    qadr, vadr = model.jnt_qposadr[joint], model.jnt_dofadr[joint]
    records: list[dict] = []
    groups: dict[tuple[str, int], list[Run]] = {}
    for r in runs:
        groups.setdefault((r.variant, round(r.duration / h)), []).append(r)
    datas = [mujoco.MjData(model) for _ in range(nthread)]
    for (variant, nstep), group in groups.items():
        m = model_variant(model, variant)
        state0 = np.empty((len(group), nstate))
        ctrl = np.empty((len(group), nstep, model.nu))
        times = np.arange(nstep) * h
        for i, r in enumerate(group):
            mujoco.mj_resetData(m, scratch)
            scratch.qpos[qadr : qadr + 7] = r.qpos
            scratch.qvel[vadr : vadr + 6] = r.qvel
            mujoco.mj_getState(m, scratch, state0[i], STATE_SPEC)
            ctrl[i] = r.ctrl(times)
        state = np.empty((len(group), nstep, nstate))
        sensor = np.empty((len(group), nstep, model.nsensordata))
        pool.rollout(
            [m] * len(group),
            datas,
            state0,
            ctrl,
            nstep=nstep,
            state=state,
            sensordata=sensor,
            skip_checks=True,
        )
        lin = 1 + model.nq + vadr
        records += run_figures(
            group,
            state[:, :, 1 + qadr : 4 + qadr],
            state[:, :, 4 + qadr : 8 + qadr],
            state[:, :, lin : lin + 3],
            state[:, :, lin + 3 : lin + 6],
            sensor,
            geo,
            cfg,
            h,
            kv,
        )
    return [{"module": asset.id, **r} for r in records]


def stress(
    assets: list[ModuleAsset],
    physics: PhysicsConfig,
    cfg: StressConfig = StressConfig(),
    *,
    task: TaskConfig | None = None,
    mjcf: list[str] | None = None,
    nthread: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[dict]:
    """Every run of every module: one record a run (see `run_module`). `mjcf`: the modules'
    exported files, to run those instead of the simulator's models."""
    task = task or TaskConfig(physics=physics)
    nthread = max(1, nthread or os.cpu_count() or 1)
    records: list[dict] = []
    with rollout.Rollout(nthread=nthread if nthread > 1 else 0) as pool:
        for k, asset in enumerate(assets):
            model = module_model(asset, physics, task, None if mjcf is None else mjcf[k])
            records += run_module(asset, model, cfg, pool, nthread)
            if progress is not None:
                progress(k + 1, len(assets))
    return records


def stress_on_mujoco(
    assets: list[ModuleAsset],
    cfg: StressConfig,
    task: TaskConfig,
    settings: PhysicsConfig | None = None,
    progress: Callable[[int, int], None] | None = None,
    *,
    mjcf: list[str] | None = None,
    nthread: int | None = None,
) -> list[dict]:
    """`stress` in the registry's runner signature (sim/engines/registry.py): the physics is
    the task's (settings: unused)."""
    return stress(assets, task.physics, cfg, mjcf=mjcf, nthread=nthread, progress=progress)
