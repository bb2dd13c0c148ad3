"""The paper's evaluation protocol: every module of a dataset, K attempts each, noise on,
curriculum off; success rate and time to success. Optionally records episodes (peg poses
over time) as .npz files for the browser preview.

Wiring for the CLI: `eval_main(args)` for
    assetgen eval --agent scripted|random --dataset D [--attempts 10] [--seed 0]
                  [--envs 1024] [--record DIR] [--record-limit N] [--json]
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from assetgen.core.atomic_file import strict_json, write_json
from sim.assets import load_dataset
from sim.config import EVAL_CONFIG, TaskConfig
from sim.env import PegInHoleVecEnv
from sim.expert import expert_action

Agent = Callable[[np.ndarray], np.ndarray]
"""An agent maps observations (n, 18) to actions (n, 6)."""


def make_agent(name: str, seed: int = 0) -> Agent:
    """A built-in agent by name: `scripted` (sim/expert.py) or `random` (uniform actions)."""
    if name == "scripted":
        return expert_action
    if name == "random":
        rng = np.random.default_rng(seed)
        return lambda obs: rng.uniform(-1.0, 1.0, (len(obs), 6))
    raise ValueError(f"unknown agent {name!r}; built-in agents: ['random', 'scripted']")


def _record(
    folder: Path, n: int, module: str, attempt: int, poses: list, rewards: list, success: bool
) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(
        folder / f"episode_{n:05d}_{module}_{attempt}.npz",
        module_id=np.array(module),
        poses=np.asarray(poses[1:], dtype=np.float32),
        spawn_pose=np.asarray(poses[0], dtype=np.float32),
        reward=np.asarray(rewards, dtype=np.float32),
        success=np.array(success),
    )


def evaluate(
    dataset: str | Path,
    agent: str | Agent = "scripted",
    attempts: int = 10,
    *,
    config: TaskConfig = EVAL_CONFIG,
    seed: int = 0,
    max_envs: int = 1024,
    module_ids: list[str] | None = None,
    record: str | Path | None = None,
    record_limit: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Run `attempts` episodes on every module; return the results as a JSON-ready dict.

    Keys: success_rate, median_time_to_success_s, episodes, time_to_success_s (list, one
    per success), failure_rate, truncation_rate, unstable, mean_return, per_module
    ({id: success rate}), seconds. Modules run `max_envs` at a time, one env per module,
    each env playing its attempts back to back. `record` writes one .npz per episode
    (module_id, poses (T, 7) position + quaternion per control step, spawn_pose (7,),
    reward (T,), success) into that folder, at most `record_limit` episodes (default: the
    first attempt of each module).
    """
    if attempts < 1:
        raise ValueError(f"attempts = {attempts}: need at least 1")
    modules = load_dataset(dataset, module_ids)
    config = replace(config, curriculum_steps=0)  # the protocol: full spawn ranges
    act = make_agent(agent, seed) if isinstance(agent, str) else agent
    rec_dir = Path(record) if record is not None else None
    if rec_dir is not None and record_limit is None:
        record_limit = len(modules)
    t0 = time.perf_counter()
    succ: dict[str, list[bool]] = {}
    tts: list[float] = []
    n_fail = n_trunc = n_unstable = n_rec = 0
    returns: list[float] = []
    for start in range(0, len(modules), max_envs):
        chunk = modules[start : start + max_envs]
        env = PegInHoleVecEnv(chunk, len(chunk), config)
        n = env.num_envs
        done_count = np.zeros(n, dtype=np.int64)
        obs = env.reset(seed=seed + start)
        traj: list[list] = [[p] for p in env.sim.state[:, 1:8].copy()]
        rews: list[list] = [[] for _ in range(n)]
        while (done_count < attempts).any():
            obs, reward, term, trunc, info = env.step(act(obs))
            live = done_count < attempts
            if rec_dir is not None and n_rec < (record_limit or 0):
                for i in np.flatnonzero(live):
                    traj[i].append(info["peg_pose"][i])
                    rews[i].append(reward[i])
            for i in np.flatnonzero((term | trunc) & live):
                mid = env.module_ids[env.env_module[i]]
                ok = bool(info["success"][i])
                succ.setdefault(mid, []).append(ok)
                returns.append(float(info["episode_return"][i]))
                if ok:
                    tts.append(float(info["time_to_success"][i]))
                n_fail += bool(info["failure"][i])
                n_unstable += bool(info["unstable"][i])
                n_trunc += bool(trunc[i])
                if rec_dir is not None and n_rec < (record_limit or 0):
                    _record(rec_dir, n_rec, mid, int(done_count[i]), traj[i], rews[i], ok)
                    n_rec += 1
                traj[i] = [env.sim.state[i, 1:8].copy()]
                rews[i] = []
                done_count[i] += 1
                if progress is not None:
                    progress(len(returns), len(modules) * attempts)
        env.close()
    episodes = len(returns)
    wins = sum(sum(v) for v in succ.values())
    return {
        "success_rate": wins / episodes,
        "median_time_to_success_s": float(np.median(tts)) if tts else float("nan"),
        "episodes": episodes,
        "time_to_success_s": tts,
        "failure_rate": n_fail / episodes,
        "truncation_rate": n_trunc / episodes,
        "unstable": n_unstable,
        "mean_return": float(np.mean(returns)),
        "per_module": {k: float(np.mean(v)) for k, v in sorted(succ.items())},
        "seconds": time.perf_counter() - t0,
    }


def eval_main(args: argparse.Namespace) -> int:
    """`assetgen eval`: args.agent, args.dataset, args.attempts, and optionally args.seed,
    args.envs, args.record, args.record_limit, args.json. Prints a short table (or JSON)."""
    from assetgen.dataset.spec import resolve

    root, _ = resolve(args.dataset)
    res = evaluate(
        root,
        args.agent,
        args.attempts,
        seed=getattr(args, "seed", 0) or 0,
        max_envs=getattr(args, "envs", None) or 1024,
        record=getattr(args, "record", None),
        record_limit=getattr(args, "record_limit", None),
    )
    strict = strict_json(res)
    out = getattr(args, "out", None)
    if out is not None:
        write_json(out, {"agent": args.agent, "dataset": str(root), **strict})
    if getattr(args, "json", False):
        print(json.dumps(strict))
        return 0
    tts = np.asarray(res["time_to_success_s"])
    q = np.percentile(tts, [10, 50, 90]) if len(tts) else [float("nan")] * 3
    rows = [
        ("agent", args.agent),
        ("dataset", str(root)),
        ("episodes", res["episodes"]),
        ("success rate", f"{100 * res['success_rate']:.2f} %"),
        ("time to success p10/p50/p90", f"{q[0]:.2f} / {q[1]:.2f} / {q[2]:.2f} s"),
        ("failure rate", f"{100 * res['failure_rate']:.2f} %"),
        ("truncated", f"{100 * res['truncation_rate']:.2f} %"),
        ("unstable episodes", res["unstable"]),
        ("wall time", f"{res['seconds']:.1f} s"),
    ]
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    return 0
