"""Throughput of the vector env on any registered engine, next to the engine's own control
steps without the env layer (on MuJoCo, raw `mujoco.rollout` of the same models).

Wiring for the CLI: `bench_main(args)` for
    assetgen bench sim [--envs 1024] [--steps 200] [--dataset test] [--threads N]
                       [--sim ENGINE] [--json]
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sim.engines.registry import DEFAULT_ENGINE, get_engine
from sim.env import PegInHoleVecEnv
from sim.task.config import EVAL_CONFIG, TaskConfig


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


def bench_engine(
    dataset: str | Path,
    envs: int = 1024,
    steps: int = 200,
    *,
    engine: str = DEFAULT_ENGINE,
    config: TaskConfig = EVAL_CONFIG,
    nthread: int | None = None,
    shard_size: int = 8,
    rounds: int = 10,
    seed: int = 0,
    device_env: bool = True,
    robot: str | None = None,
) -> dict:
    """Env steps/s of the vector env on `engine` with random actions at `envs` envs, next to
    the engine's own control steps without the env layer (raw: no observation, reward, noise
    or reset; on MuJoCo, `mujoco.rollout` of the same models from the env's states), taken in
    `rounds` interleaved rounds (a busy neighbour hits both the same). An engine that serves
    one env per module gets the dataset's first `envs` modules. Returns env_steps_per_s,
    rollout_steps_per_s (raw, env-step equivalents), physics_steps_per_s, env_over_rollout,
    the same per CPU-second (*_per_cpu_s: all threads' time; steadier on a shared machine),
    the warm-up's seconds (on a device, the kernels' compilation), the setup and the engine's
    own figures. With a device env (sim/engines/registry.py) and `device_env`, the direct
    expert's rate and bench_device_env's figures too. robot: a registered robot holds the
    pegs (None: the floating peg)."""
    from assetgen.dataset.reader import Dataset
    from sim.assets.loading import load_dataset

    spec = get_engine(engine)
    if envs < 1:
        raise ValueError(f"envs = {envs}: give at least 1")
    t0 = time.perf_counter()
    if spec.one_env_per_module:
        ids = Dataset(dataset).ids[:envs]
        env = PegInHoleVecEnv(load_dataset(dataset, ids), len(ids), config, assignment_seed=seed,
                              engine=spec.name)  # fmt: skip
    else:
        env = PegInHoleVecEnv(dataset, envs, config, nthread=nthread, assignment_seed=seed,
                              shard_size=shard_size, engine=spec.name, robot=robot)  # fmt: skip
    build_s = time.perf_counter() - t0
    sim = env.sim
    scale = np.array([config.max_lin_vel] * 3 + [config.max_ang_vel] * 3)
    t0 = time.perf_counter()
    actions = _random_actions(env, steps, rounds, seed)
    warmup_s = time.perf_counter() - t0
    raw_round = sim.raw_round([a * scale for a in actions])

    def env_round() -> None:
        for a in actions:
            env.step(a)

    wall, cpu = _interleaved(rounds, env_round, lambda _: raw_round())
    n = env.num_envs * len(actions) * rounds
    res = {
        "engine": spec.name,
        **({} if robot is None else {"robot": robot}),
        "envs": env.num_envs,
        "steps": len(actions) * rounds,
        "threads": 1,
        "modules": len(env.module_ids),
        "substeps": sim.substeps,
        "build_s": build_s,
        "warmup_s": warmup_s,
        **sim.bench_figures(),
        **_rates(n, sim.substeps, wall, cpu),
    }
    if spec.device_env is not None and device_env:
        from sim.task.expert import direct_expert_action

        k = len(actions) * rounds
        obs = env.reset(seed=seed)  # the direct expert, observation to action on the host
        t = time.perf_counter()
        for _ in range(k):
            obs = env.step(direct_expert_action(obs))[0]
        res["expert_env_steps_per_s"] = env.num_envs * k / (time.perf_counter() - t)
        env.close()
        res |= bench_device_env(spec.name, dataset, envs, k, config=config, seed=seed)
    else:
        env.close()
    return res


def bench_device_env(
    engine: str,
    dataset: str | Path,
    envs: int,
    steps: int,
    *,
    config: TaskConfig = EVAL_CONFIG,
    seed: int = 0,
    hidden: tuple[int, ...] = (512, 512),
) -> dict:
    """`engine`'s device env (sim/engines/registry.py) at `envs` envs over `steps` control steps:
    env steps/s with random actions drawn on the device, and with a policy network's
    forward pass on the device in the loop (an MLP of `hidden` ELU layers, the `paper`
    preset's, observation to action as a PPO rollout takes them: no learner updates)."""
    import torch

    t0 = time.perf_counter()
    make = get_engine(engine).load("device_env")
    env = make(dataset, envs, config, assignment_seed=seed, rotate_modules=True)
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
        **{f"device_env_{k}": v for k, v in env.sim.bench_figures().items() if k.endswith("_mb")},
    }
    env.close()
    return out


def bench_main(args: argparse.Namespace) -> int:
    """`assetgen bench sim`: args.envs, and optionally args.steps, args.dataset (default
    `test`), args.threads, args.shard_size, args.json. Prints a short table (or JSON)."""
    from assetgen.dataset.spec import resolve

    root, _ = resolve(getattr(args, "dataset", None) or "test")
    spec = get_engine(getattr(args, "sim", None))
    res = bench_engine(
        root,
        getattr(args, "envs", None) or 1024,
        getattr(args, "steps", None) or 200,
        engine=spec.name,
        nthread=getattr(args, "threads", None),
        shard_size=getattr(args, "shard_size", None) or 8,
        robot=getattr(args, "robot", None),
    )
    if getattr(args, "json", False):
        print(json.dumps(res))
        return 0
    rows = [
        ("envs / modules / threads", f"{res['envs']} / {res['modules']} / {res['threads']}"),
        *([("envs per model (shard)", str(res["shard_size"]))] if "shard_size" in res else []),
        ("env steps/s (random actions)", f"{res['env_steps_per_s']:,.0f}"),
        (f"raw {spec.label} control steps/s", f"{res['rollout_steps_per_s']:,.0f}"),
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
        ("warm-up (first steps; on a device, compiling)", f"{res['warmup_s']:.1f} s"),
    ]
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    return 0
