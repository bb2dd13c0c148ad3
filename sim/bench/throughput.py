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
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from mujoco import rollout

from sim.task.config import EVAL_CONFIG, TaskConfig
from sim.env import PegInHoleVecEnv


def _random_actions(env: PegInHoleVecEnv, steps: int, rounds: int, seed: int) -> list:
    """Reset `env`, warm it up with random actions, and return one round's random actions
    (steps // rounds of them, at least one)."""
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    for _ in range(min(10, steps)):  # warm-up
        env.step(rng.uniform(-1, 1, (env.num_envs, 6)))
    return [rng.uniform(-1, 1, (env.num_envs, 6)) for _ in range(max(1, steps // rounds))]


def _interleaved(
    rounds: int,
    env_round: Callable[[], None],
    raw_round: Callable[[Any], None],
    before_raw: Callable[[], Any] = lambda: None,
) -> tuple[dict[str, float], dict[str, float]]:
    """Wall and CPU seconds of `rounds` env rounds and raw rounds taken in turn (a busy
    neighbour hits both the same); each raw round gets what `before_raw`, run untimed after
    the env round, returns."""
    wall = {"env": 0.0, "raw": 0.0}
    cpu = {"env": 0.0, "raw": 0.0}

    def timed(key: str, run: Callable[..., None], *args: Any) -> None:
        t, c = time.perf_counter(), time.process_time()
        run(*args)
        wall[key] += time.perf_counter() - t
        cpu[key] += time.process_time() - c

    for _ in range(rounds):
        timed("env", env_round)
        timed("raw", raw_round, before_raw())
    return wall, cpu


def _rates(n: int, substeps: int, wall: dict, cpu: dict) -> dict[str, float]:
    """The figures of `n` env steps (each `substeps` physics steps) timed by _interleaved."""
    return {
        "env_steps_per_s": n / wall["env"],
        "rollout_steps_per_s": n / wall["raw"],
        "physics_steps_per_s": n * substeps / wall["raw"],
        "env_over_rollout": wall["raw"] / wall["env"],
        "env_steps_per_cpu_s": n / cpu["env"],
        "rollout_steps_per_cpu_s": n / cpu["raw"],
    }


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
    actions = _random_actions(env, steps, rounds, seed)
    controls = [sim.shard_control(a * scale).copy() for a in actions]
    out = np.empty((len(sim.models), substeps, sim.shard_state.shape[1]))

    def env_round() -> None:
        for a in actions:
            env.step(a)

    with rollout.Rollout(nthread=sim.nthread if sim.nthread > 1 else 0) as pool:

        def raw_round(state: np.ndarray) -> None:  # from the env's current states
            for u in controls:
                pool.rollout(
                    sim.models, sim.datas, state, u, nstep=substeps, state=out, skip_checks=True
                )
                state = out[:, -1].copy()

        wall, cpu = _interleaved(rounds, env_round, raw_round, sim.shard_state.copy)
    env.close()
    n = envs * len(actions) * rounds
    return {
        "envs": envs,
        "steps": len(actions) * rounds,
        "threads": sim.nthread,
        "shard_size": sim.shard_size,
        "modules": len(env.module_ids),
        "build_s": build_s,
        **_rates(n, substeps, wall, cpu),
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
    from sim.assets.loading import load_dataset

    if envs < 1:
        raise ValueError(f"envs = {envs}: give at least 1")
    t0 = time.perf_counter()
    ids = Dataset(dataset).ids[:envs]
    env = PegInHoleVecEnv(load_dataset(dataset, ids), len(ids), config, assignment_seed=seed,
                          engine="physx")  # fmt: skip
    build_s = time.perf_counter() - t0
    scale = np.array([config.max_lin_vel] * 3 + [config.max_ang_vel] * 3)
    actions = _random_actions(env, steps, rounds, seed)

    def env_round() -> None:
        for a in actions:
            env.step(a)

    def raw_round(_: Any) -> None:
        for a in actions:
            env.sim.step(a * scale)

    wall, cpu = _interleaved(rounds, env_round, raw_round)
    env.close()
    n = env.num_envs * len(actions) * rounds
    return {
        "engine": "physx",
        "envs": env.num_envs,
        "steps": len(actions) * rounds,
        "threads": 1,
        "modules": env.num_envs,
        "timestep": env.sim.physx.timestep,
        "build_s": build_s,
        **_rates(n, env.sim.substeps, wall, cpu),
    }


def bench_warp(
    dataset: str | Path,
    envs: int = 1024,
    steps: int = 200,
    *,
    config: TaskConfig = EVAL_CONFIG,
    rounds: int = 10,
    seed: int = 0,
    device_env: bool = True,
) -> dict:
    """bench_sim on MuJoCo Warp: env steps/s at `envs` envs (one world each; with fewer envs
    than modules the envs take the modules in turns, as in training), with random actions and
    with the direct scripted expert, next to the simulator's own control steps without the
    env layer (raw: the commands and states up, the substeps on the device, the states
    back). The same keys as bench_sim's where they apply, and the device memory in use;
    with `device_env`, bench_warp_device's figures too (the env on the device)."""
    from sim.task.expert import direct_expert_action

    t0 = time.perf_counter()
    env = PegInHoleVecEnv(dataset, envs, config, assignment_seed=seed, rotate_modules=True,
                          engine="mujoco-warp")  # fmt: skip
    sim = env.sim
    build_s = time.perf_counter() - t0
    scale = np.array([config.max_lin_vel] * 3 + [config.max_ang_vel] * 3)
    t0 = time.perf_counter()
    actions = _random_actions(env, steps, rounds, seed)  # the warm-up compiles the kernels
    compile_s = time.perf_counter() - t0

    def env_round() -> None:
        for a in actions:
            env.step(a)

    def raw_round(_: Any) -> None:
        for a in actions:
            sim.step(a * scale)

    wall, cpu = _interleaved(rounds, env_round, raw_round)
    n = envs * len(actions) * rounds
    res = {
        "engine": "mujoco-warp",
        "device": sim.device,
        "envs": envs,
        "threads": 1,
        "steps": len(actions) * rounds,
        "modules": len(env.module_ids),
        "timestep": env.cfg.physics.timestep,
        "substeps": env.cfg.physics.substeps,
        "build_s": build_s,
        "compile_s": compile_s,
        **_rates(n, env.cfg.physics.substeps, wall, cpu),
    }
    k = len(actions) * rounds
    # the direct expert, observation to action on the host
    obs = env.reset(seed=seed)
    t = time.perf_counter()
    for _ in range(k):
        obs = env.step(direct_expert_action(obs))[0]
    res["expert_env_steps_per_s"] = envs * k / (time.perf_counter() - t)
    res["device_memory_mb"] = sim.device_memory_mb()
    env.close()
    if device_env:
        res |= bench_warp_device(dataset, envs, k, config=config, seed=seed)
    return res


def bench_warp_device(
    dataset: str | Path,
    envs: int,
    steps: int,
    *,
    config: TaskConfig = EVAL_CONFIG,
    seed: int = 0,
    hidden: tuple[int, ...] = (512, 512),
) -> dict:
    """The env on the device (sim/engines/warp/env.py) at `envs` envs over `steps` control steps:
    env steps/s with random actions drawn on the device, and with a policy network's
    forward pass on the device in the loop (an MLP of `hidden` ELU layers, the `paper`
    preset's, observation to action as a PPO rollout takes them: no learner updates)."""
    import torch

    from sim.engines.warp.env import WarpTorchVecEnv

    t0 = time.perf_counter()
    env = WarpTorchVecEnv(dataset, envs, config, assignment_seed=seed, rotate_modules=True)
    build_s = time.perf_counter() - t0
    dev = env.device
    gen = torch.Generator(device=dev).manual_seed(seed)

    def actions() -> torch.Tensor:
        return torch.rand((envs, 6), generator=gen, device=dev) * 2 - 1

    def sync() -> None:
        if dev.type == "cuda":
            torch.cuda.synchronize(dev)

    obs = env.reset(seed=seed)
    for _ in range(min(10, steps)):  # warm-up: the graph's capture, torch's kernels
        obs = env.step(actions())[0]
    sync()
    t = time.perf_counter()
    for _ in range(steps):
        env.step(actions())
    sync()
    random_s = time.perf_counter() - t
    layers: list[torch.nn.Module] = []
    width = env.obs_dim
    for h in hidden:
        layers += [torch.nn.Linear(width, h), torch.nn.ELU()]
        width = h
    net = torch.nn.Sequential(*layers, torch.nn.Linear(width, env.act_dim)).to(dev)
    with torch.no_grad():
        sync()
        t = time.perf_counter()
        for _ in range(steps):
            mean = net(obs)
            obs = env.step((mean + 0.3 * torch.randn_like(mean)).clamp(-1, 1))[0]
        sync()
        policy_s = time.perf_counter() - t
    out = {
        "device_env_build_s": build_s,
        "device_env_steps_per_s": envs * steps / random_s,
        "device_policy_env_steps_per_s": envs * steps / policy_s,
        "device_env_memory_mb": env.sim.device_memory_mb(),
    }
    env.close()
    return out


def bench_main(args: argparse.Namespace) -> int:
    """`assetgen bench sim`: args.envs, and optionally args.steps, args.dataset (default
    `test`), args.threads, args.shard_size, args.json. Prints a short table (or JSON)."""
    from assetgen.dataset.spec import resolve

    root, _ = resolve(getattr(args, "dataset", None) or "test")
    engine = getattr(args, "sim", None) or "mujoco"
    if engine == "mujoco-warp":
        res = bench_warp(root, getattr(args, "envs", None) or 1024,
                         getattr(args, "steps", None) or 200)  # fmt: skip
    elif engine == "physx":
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
            {"physx": "raw PhysX control steps/s", "mujoco-warp": "raw Warp control steps/s"}.get(
                engine, "raw rollout steps/s"
            ),
            f"{res['rollout_steps_per_s']:,.0f}",
        ),
        *[
            (label, f"{res[key]:,.0f}")
            for label, key in (
                ("env steps/s (direct expert)", "expert_env_steps_per_s"),
                ("device memory, MB", "device_memory_mb"),
                ("env on the device: env steps/s (random)", "device_env_steps_per_s"),
                ("env on the device: env steps/s (policy)", "device_policy_env_steps_per_s"),
            )
            if key in res
        ],
        ("physics steps/s", f"{res['physics_steps_per_s']:,.0f}"),
        ("env / raw", f"{res['env_over_rollout']:.2f}"),
        (
            "per CPU-second: env / raw",
            f"{res['env_steps_per_cpu_s']:,.0f} / {res['rollout_steps_per_cpu_s']:,.0f}",
        ),
        ("build time", f"{res['build_s']:.1f} s"),
        *(
            [("kernel compile (first steps)", f"{res['compile_s']:.1f} s")]
            if "compile_s" in res
            else []
        ),
    ]
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    return 0
