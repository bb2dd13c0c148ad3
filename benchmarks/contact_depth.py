"""One run of the contact stress benchmark replayed to its deepest contact, measured three ways.

    python -m benchmarks.contact_depth DATASET MODULE LABEL

Replays the run LABEL (a push or an impact, as `assetgen bench contacts --json` names it, e.g.
"tilted 2") of module MODULE under the project's physics, finds the physics step whose
contacts go deepest, and at the state that step started from prints the deepest contact's
two geoms, its depth and normal as MuJoCo finds it with the project's collision (native,
multi-point), with one point a pair (`multiccd` off) and with libccd (`nativeccd` off), and
the two pieces' exact depth: the least overlap of their convex hulls over every face normal
and every cross product of an edge of each (the separating axis theorem; a depth MuJoCo
reports far beyond it is a collision artefact, not the geometry).
"""

from __future__ import annotations

import argparse
import itertools

import mujoco
import numpy as np
from scipy.spatial import ConvexHull

from assetgen.core.mujoco_config import physics_for
from sim.assets.loading import dataset_root
from sim.assets.task_modules import load_modules
from sim.bench.stress.cases import StressConfig, module_runs, press_as_force
from sim.bench.stress.mujoco import module_model
from sim.task.config import TaskConfig


def exact_depth(a: np.ndarray, b: np.ndarray) -> float:
    """The penetration depth (m) of the convex hulls of points a and b (<= 0: apart): the
    least overlap of their projections over the candidate separating axes."""
    ha, hb = ConvexHull(a), ConvexHull(b)
    axes = [e[:3] for e in ha.equations] + [e[:3] for e in hb.equations]
    edges = [{tuple(sorted((s[i], s[(i + 1) % 3]))) for s in h.simplices for i in range(3)}
             for h in (ha, hb)]  # fmt: skip
    for (i, j), (k, m) in itertools.product(*edges):
        c = np.cross(a[j] - a[i], b[m] - b[k])
        if np.linalg.norm(c) > 1e-12:
            axes.append(c / np.linalg.norm(c))
    u = np.array(axes)
    pa, pb = a @ u.T, b @ u.T
    return float(np.min(np.minimum(pa.max(0) - pb.min(0), pb.max(0) - pa.min(0))))


def _world(m: mujoco.MjModel, d: mujoco.MjData, g: int) -> np.ndarray:
    mesh = m.geom_dataid[g]
    v = m.mesh_vert[m.mesh_vertadr[mesh] : m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
    return v.astype(float) @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g]


def replay(dataset: str, module: str, label: str) -> dict:
    """The figures printed (see the module doc)."""
    (asset,) = load_modules(dataset_root(dataset), [module])
    physics = physics_for(asset.clearance)
    m = module_model(asset, physics, TaskConfig(physics=physics))
    cfg = StressConfig()
    runs, _ = module_runs(asset, cfg)
    press_as_force(runs, cfg, float(m.actuator_gainprm[0, 0]))
    chosen = [r for r in runs if r.label == label and r.variant == "base"]
    if not chosen:
        names = sorted({r.label for r in runs if r.variant == "base"})
        raise SystemExit(f"error: no push or impact {label!r} on {module}; its runs: {names}")
    (run,) = chosen[:1]
    d = mujoco.MjData(m)
    peg = m.body("peg")
    qa, va = m.jnt_qposadr[peg.jntadr[0]], m.jnt_dofadr[peg.jntadr[0]]
    d.qpos[qa : qa + 7], d.qvel[va : va + 6] = run.qpos, run.qvel
    n = round(run.duration / m.opt.timestep)
    ctrl = run.ctrl(np.arange(n) * m.opt.timestep)
    worst, start = (0.0, -1), mujoco.MjData(m)
    before = mujoco.MjData(m)
    for k in range(n):
        mujoco.mj_copyData(before, m, d)
        d.ctrl[:] = ctrl[k]
        mujoco.mj_step(m, d)
        if d.ncon and -d.contact.dist[: d.ncon].min() > worst[0]:
            worst = (-float(d.contact.dist[: d.ncon].min()), k)
            mujoco.mj_copyData(start, m, before)
    if worst[1] < 0:
        raise SystemExit(f"error: run {label!r} on {module} never touches")

    physics_flags = int(m.opt.disableflags)

    def deepest(disable: int = 0) -> tuple[float, np.ndarray, int, int]:
        m.opt.disableflags = physics_flags | disable
        mujoco.mj_copyData(d, m, start)
        mujoco.mj_forward(m, d)
        i = int(np.argmin(d.contact.dist[: d.ncon]))
        c = d.contact[i]
        return -float(c.dist), c.frame[:3].copy(), int(c.geom1), int(c.geom2)

    depth, normal, g1, g2 = deepest()
    one = deepest(int(mujoco.mjtDisableBit.mjDSBL_MULTICCD))[0]
    ccd = deepest(int(mujoco.mjtDisableBit.mjDSBL_NATIVECCD))[0]
    m.opt.disableflags = physics_flags
    mujoco.mj_copyData(d, m, start)
    mujoco.mj_forward(m, d)
    return {
        "step": worst[1],
        "geoms": (m.geom(g1).name, m.geom(g2).name),
        "project": depth,
        "normal": normal,
        "one point a pair": one,
        "libccd": ccd,
        "exact": exact_depth(_world(m, d, g1), _world(m, d, g2)),
    }


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.contact_depth", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("dataset")
    ap.add_argument("module")
    ap.add_argument("label")
    a = ap.parse_args(argv)
    r = replay(a.dataset, a.module, a.label)
    print(f"{a.dataset} {a.module} {a.label!r}: deepest at physics step {r['step']}, between "
          f"{r['geoms'][0]} and {r['geoms'][1]}")  # fmt: skip
    print(f"  MuJoCo, the project's collision   {1e3 * r['project']:.6f} mm along "
          f"{np.array2string(r['normal'], precision=3)}")  # fmt: skip
    print(f"  MuJoCo, one point a pair          {1e3 * r['one point a pair']:.6f} mm")
    print(f"  MuJoCo, libccd                    {1e3 * r['libccd']:.6f} mm")
    print(f"  exact (separating axes)           {1e3 * r['exact']:.6f} mm")


if __name__ == "__main__":
    main()
