"""The contact stress benchmark's runs (sim/bench/stress/cases.py) on MuJoCo Warp.

The same runs of each module (pushes, impacts, friction, rebound), their commands and their
figures (`sim.bench.stress.figures.run_figures`), stepped in MuJoCo Warp
(sim/engines/warp/batch.py): every run of every module is a world of one model, all stepped
together for the longest run's length (each run's figures read its own first steps). Each
physics step's commands come from a table on the device, and the peg's state and its deepest
contact are recorded there; the host reads them once at the end. A run's model variant is set in
its own world: `mu=X` the peg's friction, `free` the actuators' gains zeroed (MuJoCo's runs
disable actuation, which MuJoCo Warp shares between worlds).

    assetgen bench contacts DATASET --sim mujoco-warp [--limit N] [--allow-cpu]
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from sim.assets.loading import ModuleAsset
from sim.bench.stress.cases import Run, StressConfig, module_runs, press_as_force
from sim.bench.stress.figures import run_figures
from sim.engines.warp.batch import NCONMAX, NJMAX, WarpBatchSim, load_warp
from sim.task.config import TaskConfig

_GAINS = ("actuator_gainprm", "actuator_biasprm")


@functools.cache
def _kernels():
    """Warp kernels: the commands of step t into every world, and the record of step t
    (state, and the deepest contact of each world: MuJoCo's contact sensor, reduced to the
    contact of least distance)."""
    wp, _ = load_warp()

    @wp.kernel
    def set_ctrl(table: wp.array3d(dtype=float), t: int, ctrl: wp.array2d(dtype=float)):
        w, j = wp.tid()
        ctrl[w, j] = table[w, t, j]

    @wp.kernel
    def record(
        qpos: wp.array2d(dtype=float),
        qvel: wp.array2d(dtype=float),
        t: int,
        out: wp.array3d(dtype=float),
    ):
        w = wp.tid()
        for j in range(7):
            out[w, t, j] = qpos[w, j]
        for j in range(6):
            out[w, t, 7 + j] = qvel[w, j]

    @wp.kernel
    def deepest(
        dist: wp.array(dtype=float),
        worldid: wp.array(dtype=int),
        nacon: wp.array(dtype=int),
        t: int,
        out: wp.array2d(dtype=float),
    ):
        i = wp.tid()
        if i < nacon[0]:
            wp.atomic_min(out, worldid[i], t, dist[i])

    return set_ctrl, record, deepest


def stress_warp(
    assets: list[ModuleAsset],
    cfg: StressConfig,
    task: TaskConfig,
    settings: object = None,
    progress: Callable[[int, int], None] | None = None,
    device: str | None = None,
    nconmax: int = NCONMAX,
    njmax: int = NJMAX,
) -> list[dict]:
    """Every run of every module on MuJoCo Warp, one world a run; one record (its figures)
    a run, as sim.bench.stress.mujoco.stress gives them. settings: unused (MuJoCo Warp takes the
    task's physics; the registry's runners share one signature). device: a Warp device
    (None: the GPU if there is one)."""
    wp, mjw = load_warp()
    plan = [(a, *module_runs(a, cfg)) for a in assets]
    worlds = [a for a, runs, _ in plan for _ in runs]
    sim = WarpBatchSim(worlds, task, device=device, nconmax=nconmax, njmax=njmax,
                       per_world=_GAINS)  # fmt: skip
    h = task.physics.timestep
    g = sim.peg_geom
    jobs: list[tuple[ModuleAsset, list[Run], object, float]] = []
    for a, module_runs_, geo in plan:
        kv = float(sim.per_module[a.id]["actuator_gainprm"][0, 0])
        press_as_force(module_runs_, cfg, kv)
        jobs.append((a, module_runs_, geo, kv))
    runs = [r for _a, rs, _g, _k in jobs for r in rs]
    nstep = max(round(r.duration / h) for r in runs)
    times = np.arange(nstep) * h
    table = np.empty((len(runs), nstep, 6), dtype=np.float32)
    for w, r in enumerate(runs):
        table[w] = r.ctrl(times)
        sim.state[w, 1:8] = r.qpos
        sim.state[w, 8:14] = r.qvel
        if r.variant == "free":
            for f in _GAINS:
                sim.host[f][w] = 0.0
        elif r.variant.startswith("mu="):
            sim.host["geom_friction"][w, g, 0] = float(r.variant[3:])
        elif r.variant != "base":
            raise ValueError(f"unknown model variant {r.variant!r}")
    set_ctrl, record, deepest = _kernels()
    n, d = len(runs), sim.data
    with wp.ScopedDevice(sim.device):
        sim._upload_model()
        sim._upload_state()
        table_d = wp.array(table, dtype=float)
        out = wp.zeros((n, nstep, 13), dtype=float)
        pen = wp.full((n, nstep), np.inf, dtype=float)
        for t in range(nstep):
            wp.launch(set_ctrl, dim=(n, 6), inputs=[table_d, t], outputs=[d.ctrl])
            mjw.step(sim.model, d)
            wp.launch(record, dim=n, inputs=[d.qpos, d.qvel, t], outputs=[out])
            contacts = [d.contact.dist, d.contact.worldid, d.nacon, t]
            wp.launch(deepest, dim=d.naconmax, inputs=contacts, outputs=[pen])
            sim._check_capacity()
        state, dist = out.numpy().astype(float), pen.numpy().astype(float)
    sim.close()
    sensor = np.stack([np.isfinite(dist), np.where(np.isfinite(dist), dist, 0.0)], axis=-1)
    records: list[dict] = []
    w0 = 0
    for k, (a, rs, geo, kv) in enumerate(jobs):
        for r in rs:  # each run's own length, as MuJoCo's runs have it
            m, w = round(r.duration / h), slice(w0, w0 + 1)
            s = state[w, :m]
            pos, quat, vel, ang = s[..., :3], s[..., 3:7], s[..., 7:10], s[..., 10:13]
            figures = run_figures([r], pos, quat, vel, ang, sensor[w, :m], geo, cfg, h, kv)
            records += [{"module": a.id, **rec} for rec in figures]
            w0 += 1
        if progress is not None:
            progress(k + 1, len(jobs))
    return records
