"""The contact stress benchmark's runs (sim/bench/stress/cases.py) on PhysX, the referee engine.

The same runs of each module (pushes, impacts, friction, rebound), their commands and their
figures (`sim.bench.stress.figures.run_figures`), stepped in PhysX (sim/engines/physx/batch.py):
`batch` runs of a module at a time, one env each, the drives' targets set before every physics
step, the state and the deepest contact penetration read after it. MuJoCo's contact sensor gives
the distance of its contacts; PhysX's contact points give their separation, the same quantity.

    assetgen bench contacts DATASET --sim physx [--limit N]
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sim.assets.loading import ModuleAsset
from sim.bench.stress.cases import Run, StressConfig, module_runs, press_as_force
from sim.bench.stress.figures import run_figures
from sim.engines.physx.config import PhysxConfig
from sim.task.config import TaskConfig


def run_module_physx(
    asset: ModuleAsset,
    cfg: StressConfig,
    task: TaskConfig,
    physx: PhysxConfig,
    batch: int = 16,
) -> list[dict]:
    """Every run of one module on PhysX; one record (its figures) a run."""
    from sim.engines.physx.batch import PhysxBatchSim

    runs, geo = module_runs(asset, cfg)
    sim = PhysxBatchSim([asset] * min(batch, len(runs)), task, physx)
    h = physx.timestep
    kv = sim.kv[0]
    press_as_force(runs, cfg, kv)
    groups: dict[int, list[Run]] = {}
    for r in runs:
        groups.setdefault(round(r.duration / h), []).append(r)
    records: list[dict] = []
    for nstep, group in groups.items():
        for k in range(0, len(group), sim.num_envs):
            records += _run_batch(sim, group[k : k + sim.num_envs], nstep, geo, cfg, h, kv)
    sim.close()
    return [{"module": asset.id, **r} for r in records]


def _run_batch(sim, runs: list[Run], nstep: int, geo, cfg: StressConfig, h: float, kv: float):
    n = len(runs)
    times = np.arange(nstep) * h
    ctrl = np.zeros((sim.num_envs, nstep, 6))
    for i, r in enumerate(runs):
        ctrl[i] = r.ctrl(times)
        sim.set_drive(i, r.variant != "free")
        mu = float(r.variant[3:]) if r.variant.startswith("mu=") else task_friction(sim)
        sim.set_material([i], [mu], [mu], [0.0])
        sim.set_state(i, r.qpos, r.qvel)
    for i in range(n, sim.num_envs):  # idle envs: parked at rest high above their plates
        sim.set_drive(i, True)
        sim.set_state(i, np.array([0, 0, 0.2, 1, 0, 0, 0.0]), np.zeros(6))
    pos = np.empty((n, nstep, 3))
    quat = np.empty((n, nstep, 4))
    vel = np.empty((n, nstep, 3))
    ang = np.empty((n, nstep, 3))
    sensor = np.zeros((n, nstep, 2))
    for t in range(nstep):
        sim.set_velocity_targets(ctrl[:, t])
        sim.physics_step()
        s = sim.read_state()
        pos[:, t], quat[:, t], vel[:, t], ang[:, t] = (
            s[:n, 1:4],
            s[:n, 4:8],
            s[:n, 8:11],
            s[:n, 11:],
        )
        pen = sim.penetration()[:n]
        # the sensor's layout: (found, distance)
        sensor[:, t, 0] = pen > 0
        sensor[:, t, 1] = -pen
    return run_figures(runs, pos, quat, vel, ang, sensor, geo, cfg, h, kv)


def task_friction(sim) -> float:
    """The friction of the pushes and impacts: the exported files' (the USD material's
    dynamic coefficient), as MuJoCo's runs use the model's."""
    return float(sim.usd[0].dynamic_friction)


def stress_physx(
    assets: list[ModuleAsset],
    cfg: StressConfig,
    task: TaskConfig,
    physx: PhysxConfig | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[dict]:
    """Every run of every module on PhysX (see run_module_physx)."""
    physx = physx or PhysxConfig()
    records: list[dict] = []
    for k, asset in enumerate(assets):
        records += run_module_physx(asset, cfg, task, physx)
        if progress is not None:
            progress(k + 1, len(assets))
    return records
