"""Throughput of the vector env next to raw `mujoco.rollout` on the same models (or, on
PhysX, next to the referee's own control steps without the env layer).

Wiring for the CLI: `bench_main(args)` for
    assetgen bench sim [--envs 1024] [--steps 200] [--dataset test] [--threads N]
                       [--sim mujoco|physx] [--json]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from mujoco import rollout

from sim.config import EVAL_CONFIG, TaskConfig
from sim.env import PegInHoleVecEnv


def bench_sim(
    dataset: str | Path,
    envs: int = 1024,
    steps: int = 200,
    *,
    config: TaskConfig = EVAL_CONFIG,
    nthread: int | None = None,
    shard_size: int = 8,
    rounds: int = 10,
    seed: int = 0,
) -> dict:
    """Env steps/s with random actions at `envs` envs next to raw `mujoco.rollout` steps/s
    on the same models for the same physics steps (no env layer: no observation, reward,
    noise or reset), taken in `rounds` interleaved rounds (a busy neighbour hits both the
    same). Each raw round starts from the env's current states. Returns env_steps_per_s,
    rollout_steps_per_s (env-step equivalents), physics_steps_per_s, env_over_rollout, the
    same per CPU-second (*_per_cpu_s: all threads' time; steadier on a shared machine),
    and the setup."""
    t0 = time.perf_counter()
    env = PegInHoleVecEnv(
        dataset,
        envs,
        config,
        nthread=nthread,
        assignment_seed=seed,
        shard_size=shard_size,
    )
    build_s = time.perf_counter() - t0
    sim = env.sim
    substeps = env.cfg.physics.substeps
    scale = np.array([config.max_lin_vel] * 3 + [config.max_ang_vel] * 3)
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    for _ in range(min(10, steps)):  # warm-up
        env.step(rng.uniform(-1, 1, (envs, 6)))
    per_round = max(1, steps // rounds)
    actions = [rng.uniform(-1, 1, (envs, 6)) for _ in range(per_round)]
    controls = [sim.shard_control(a * scale).copy() for a in actions]
    out = np.empty((len(sim.models), substeps, sim.shard_state.shape[1]))
    wall = {"env": 0.0, "raw": 0.0}
    cpu = {"env": 0.0, "raw": 0.0}
    with rollout.Rollout(nthread=sim.nthread if sim.nthread > 1 else 0) as pool:
        for _ in range(rounds):
            t, c = time.perf_counter(), time.process_time()
            for a in actions:
                env.step(a)
            wall["env"] += time.perf_counter() - t
            cpu["env"] += time.process_time() - c
            state = sim.shard_state.copy()
            t, c = time.perf_counter(), time.process_time()
            for u in controls:
                pool.rollout(
                    sim.models, sim.datas, state, u, nstep=substeps, state=out, skip_checks=True
                )
                state = out[:, -1].copy()
            wall["raw"] += time.perf_counter() - t
            cpu["raw"] += time.process_time() - c
    env.close()
    n = envs * per_round * rounds
    return {
        "envs": envs,
        "steps": per_round * rounds,
        "threads": sim.nthread,
        "shard_size": sim.shard_size,
        "modules": len(env.module_ids),
        "build_s": build_s,
        "env_steps_per_s": n / wall["env"],
        "rollout_steps_per_s": n / wall["raw"],
        "physics_steps_per_s": n * substeps / wall["raw"],
        "env_over_rollout": wall["raw"] / wall["env"],
        "env_steps_per_cpu_s": n / cpu["env"],
        "rollout_steps_per_cpu_s": n / cpu["raw"],
    }


def bench_physx(
    dataset: str | Path,
    envs: int = 1024,
    steps: int = 200,
    *,
    config: TaskConfig = EVAL_CONFIG,
    rounds: int = 10,
    seed: int = 0,
) -> dict:
    """bench_sim on PhysX (the referee): one env per module of the dataset's first `envs`,
    env steps/s with random actions next to the same control steps of the PhysX scene alone
    (drive targets, the physics steps, the state read; no observation, reward, noise or
    reset), in `rounds` interleaved rounds. The same keys as bench_sim's where they apply;
    the raw figures are PhysX's."""
    from assetgen.dataset.reader import Dataset
    from sim.assets import load_dataset

    if envs < 1:
        raise ValueError(f"envs = {envs}: give at least 1")
    t0 = time.perf_counter()
    ids = Dataset(dataset).ids[:envs]
    env = PegInHoleVecEnv(load_dataset(dataset, ids), len(ids), config, assignment_seed=seed,
                          engine="physx")  # fmt: skip
    build_s = time.perf_counter() - t0
    n_env = env.num_envs
    scale = np.array([config.max_lin_vel] * 3 + [config.max_ang_vel] * 3)
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    for _ in range(min(10, steps)):  # warm-up
        env.step(rng.uniform(-1, 1, (n_env, 6)))
    per_round = max(1, steps // rounds)
    actions = [rng.uniform(-1, 1, (n_env, 6)) for _ in range(per_round)]
    wall = {"env": 0.0, "raw": 0.0}
    cpu = {"env": 0.0, "raw": 0.0}
    for _ in range(rounds):
        t, c = time.perf_counter(), time.process_time()
        for a in actions:
            env.step(a)
        wall["env"] += time.perf_counter() - t
        cpu["env"] += time.process_time() - c
        t, c = time.perf_counter(), time.process_time()
        for a in actions:
            env.sim.step(a * scale)
        wall["raw"] += time.perf_counter() - t
        cpu["raw"] += time.process_time() - c
    substeps = env.sim.substeps
    env.close()
    n = n_env * per_round * rounds
    return {
        "engine": "physx",
        "envs": n_env,
        "steps": per_round * rounds,
        "threads": 1,
        "modules": n_env,
        "timestep": env.sim.physx.timestep,
        "build_s": build_s,
        "env_steps_per_s": n / wall["env"],
        "rollout_steps_per_s": n / wall["raw"],
        "physics_steps_per_s": n * substeps / wall["raw"],
        "env_over_rollout": wall["raw"] / wall["env"],
        "env_steps_per_cpu_s": n / cpu["env"],
        "rollout_steps_per_cpu_s": n / cpu["raw"],
    }


def bench_main(args: argparse.Namespace) -> int:
    """`assetgen bench sim`: args.envs, and optionally args.steps, args.dataset (default
    `test`), args.threads, args.shard_size, args.json. Prints a short table (or JSON)."""
    from assetgen.dataset.spec import resolve

    root, _ = resolve(getattr(args, "dataset", None) or "test")
    engine = getattr(args, "sim", None) or "mujoco"
    if engine == "physx":
        res = bench_physx(root, getattr(args, "envs", None) or 1024,
                          getattr(args, "steps", None) or 200)  # fmt: skip
    else:
        res = bench_sim(
            root,
            getattr(args, "envs", None) or 1024,
            getattr(args, "steps", None) or 200,
            nthread=getattr(args, "threads", None),
            shard_size=getattr(args, "shard_size", None) or 8,
        )
    if getattr(args, "json", False):
        print(json.dumps(res))
        return 0
    rows = [
        ("envs / modules / threads", f"{res['envs']} / {res['modules']} / {res['threads']}"),
        *([("envs per model (shard)", str(res["shard_size"]))] if "shard_size" in res else []),
        ("env steps/s (random actions)", f"{res['env_steps_per_s']:,.0f}"),
        (
            "raw PhysX control steps/s" if engine == "physx" else "raw rollout steps/s",
            f"{res['rollout_steps_per_s']:,.0f}",
        ),
        ("physics steps/s", f"{res['physics_steps_per_s']:,.0f}"),
        ("env / raw", f"{res['env_over_rollout']:.2f}"),
        (
            "per CPU-second: env / raw",
            f"{res['env_steps_per_cpu_s']:,.0f} / {res['rollout_steps_per_cpu_s']:,.0f}",
        ),
        ("build time", f"{res['build_s']:.1f} s"),
    ]
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    return 0
