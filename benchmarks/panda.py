"""The Panda holding the peg, measured: the controller's tracking in free space, the share of
the task's spawn poses the arm reaches on a split, and its cost against the floating peg.

    python -m benchmarks.panda tracking [--dataset test] [--controller ik|impedance]
    python -m benchmarks.panda expert [--modules 64] [--controller ik|impedance]
    python -m benchmarks.panda reach --dataset test [--poses 4] [--modules N]
    python -m benchmarks.panda cost [--envs 32] [--steps 50]

tracking: each axis commanded alone at 0.1 m/s (linear) or 1 rad/s (angular) for 0.5 s from
the home pose over the module's entrance; prints the velocity's error after 0.1, 0.2 and
0.3 s and the time to come within 5 %, the largest velocity across the commanded axis, and
the joints' largest torque.
expert: the direct scripted expert, one evaluation episode on each of the first --modules
modules of the dataset (the evaluation's noise and spawns; spawns out of reach drawn again),
through the arm and floating in the same run; prints success, failure and truncation shares
and the reachable share of the spawn draws.
reach: per module, the peg sizes the fingers must hold (refusals named) and `--poses` spawn
poses drawn as the task draws them (full ranges); prints the reached share, overall and with
the spawn tilt within 45 degrees, and the joints that stop the arm.
cost: env steps per second of the arm and of the floating peg (BatchSim), same modules, same
commands, one thread each, in one run; prints their ratio.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections import Counter
from dataclasses import replace

import mujoco
import numpy as np

from assetgen.core.mujoco_config import physics_for
from sim.assets.loading import dataset_root, load_dataset
from sim.task import rules as T
from sim.task.config import TaskConfig


def _task(clearance: float) -> TaskConfig:
    return replace(TaskConfig(), physics=physics_for(clearance))


def _held(assets: list) -> list:
    """The modules whose pegs the Panda holds (it refuses some by name)."""
    from sim.robots.panda.scene import refusal

    return [a for a in assets if refusal(a) is None]


def _settings(controller: str):
    from sim.robots.panda.model import ArmSettings

    return ArmSettings(controller=controller).validate()


def tracking(dataset: str, modules: int, controller: str = "impedance") -> dict:
    from sim.robots.panda.sim import PandaSim

    assets = _held(load_dataset(dataset_root(dataset)))[:modules]
    rows = {}
    for axis in range(6):
        sim = PandaSim(assets, _task(assets[0].clearance), nthread=1,
                       settings=_settings(controller))  # fmt: skip
        target = 0.1 if axis < 3 else 1.0
        v = np.zeros((len(assets), 6))
        v[:, axis] = target
        speeds = []
        for _ in range(25):
            sim.step(v)
            w = np.zeros((len(assets), 3))
            for i, s in enumerate(sim.state):
                mujoco.mju_rotVecQuat(w[i], s[11:14], s[4:8])
            speeds.append(np.concatenate([sim.state[:, 8:11], w], axis=1))
        got = np.array(speeds)  # (steps, envs, 6)
        err = np.abs(got[:, :, axis] - target) / target
        within = (err < 0.05).all(axis=1)
        settle = next((k for k in range(len(within)) if within[k:].all()), None)
        across = np.abs(np.delete(got, axis, axis=2)[:, :, : 3 if axis >= 3 else 2])
        rows["xyz"[axis % 3] + ("" if axis < 3 else " rot")] = {
            "error_at_0.1s": float(err[4].max()),
            "error_at_0.2s": float(err[9].max()),
            "error_at_0.3s": float(err[14].max()),
            "settle_s": None if settle is None else round((settle + 1) * 0.02, 2),
            "largest_across": float(across[5:].max()),
        }
    return {"modules": len(assets), "controller": controller, "axes": rows}


def expert(dataset: str, modules: int, controller: str = "impedance", seed: int = 0) -> dict:
    from sim.env import PegInHoleVecEnv, eval_config
    from sim.task.expert import direct_expert_action

    assets = load_dataset(dataset_root(dataset))[:modules]
    config = replace(eval_config(), physics=physics_for(min(a.clearance for a in assets)))
    out: dict = {"dataset": str(dataset), "modules": len(assets), "controller": controller}
    for robot in ("panda", None):
        # one env a module the robot holds (it refuses some by name: `refused`)
        env = PegInHoleVecEnv(assets, None, config, assignment_seed=seed, robot=robot,
                              robot_settings=_settings(controller))  # fmt: skip
        obs = env.reset(seed=seed)
        result = np.zeros(env.num_envs, dtype=int)  # 1 success, 2 failure, 3 truncated
        t0 = time.perf_counter()
        for _ in range(env.cfg.max_steps):
            obs, _, term, trunc, info = env.step(direct_expert_action(obs))
            new = (term | trunc) & (result == 0)
            result[new] = np.where(info["success"][new], 1, np.where(term[new], 2, 3))
            if (result > 0).all():
                break
        out["panda" if robot else "floating"] = {
            "modules": env.num_envs,
            "refused": sorted(env.refused),
            "success": float(np.mean(result == 1)),
            "failure": float(np.mean(result == 2)),
            "truncated": float(np.mean(result == 3)),
            "reachable_share_of_spawn_draws": 1.0 - env.spawn_redraws / env.spawn_draws,
            "seconds": round(time.perf_counter() - t0, 1),
        }
        env.close()
    return out


def reach(dataset: str, poses: int, modules: int | None, seed: int) -> dict:
    from sim.robots.panda.scene import refusal
    from sim.robots.panda.sim import PandaSim

    assets = load_dataset(dataset_root(dataset))
    if modules:
        assets = assets[:modules]
    rng = np.random.default_rng(seed)
    cfg = TaskConfig()
    refused: dict[str, str] = {}
    reached = tilted_ok = tilted_n = total = 0
    stops: Counter[str] = Counter()
    unreached_modules: Counter[str] = Counter()
    t0 = time.perf_counter()
    for a in assets:
        why = refusal(a)
        if why is not None:
            refused[a.id] = why
            continue
        sim = PandaSim([a], _task(a.clearance), nthread=1, seed=seed)
        eq = np.zeros(4)
        mujoco.mju_mat2Quat(eq, a.entrance[:3, :3].ravel())
        pos, quat = T.sample_spawn(
            rng, np.repeat(a.entrance[None, :3, 3], poses, 0), np.repeat(eq[None], poses, 0),
            np.repeat(a.peg.vertices[None], poses, 0), 1.0, cfg,
        )  # fmt: skip
        for k in range(poses):
            ok = bool(sim.place(np.array([0]), pos[k : k + 1], quat[k : k + 1])[0])
            total += 1
            reached += ok
            # the spawn's tilt from the entrance frame
            rel = np.zeros(4)
            conj = np.array([eq[0], -eq[1], -eq[2], -eq[3]])
            mujoco.mju_mulQuat(rel, conj, quat[k])
            tilt = 2 * math.degrees(math.acos(min(1.0, abs(rel[0]))))
            if tilt <= 45:
                tilted_n += 1
                tilted_ok += ok
            if not ok:
                why = sim.unreached[0].rsplit("stopped by ", 1)[-1]
                stops.update(w.strip() for w in why.split(","))
                unreached_modules[a.id] += 1
        sim.close()
    return {
        "dataset": str(dataset),
        "modules": len(assets),
        "refused_modules": refused,
        "poses": total,
        "reached_share": reached / max(total, 1),
        "reached_share_tilt_within_45deg": tilted_ok / max(tilted_n, 1),
        "poses_tilt_within_45deg": tilted_n,
        "stopped_by": dict(stops.most_common()),
        "modules_with_an_unreached_pose": len(unreached_modules),
        "seconds": round(time.perf_counter() - t0, 1),
    }


def cost(dataset: str, envs: int, steps: int) -> dict:
    from sim.engines.mujoco.batch import BatchSim
    from sim.robots.panda.sim import PandaSim

    assets = load_dataset(dataset_root(dataset))[:envs]
    task = _task(assets[0].clearance)
    rng = np.random.default_rng(0)
    scale = np.array([0.05] * 3 + [0.5] * 3)  # gentle twists: m/s, rad/s
    commands = [rng.uniform(-1, 1, (len(assets), 6)) * scale for _ in range(steps)]
    # the same start for both: 0.2 m over the entrance, upright
    pos = np.array([a.entrance[:3, 3] + 0.2 * a.entrance[:3, 2] for a in assets])
    quat = np.zeros((len(assets), 4))
    for i, a in enumerate(assets):
        mujoco.mju_mat2Quat(quat[i], a.entrance[:3, :3].ravel())
    out = {}
    for name, make in (
        ("floating", lambda: BatchSim(assets, task, nthread=1, shard_size=8)),
        ("panda", lambda: PandaSim(assets, task, nthread=1)),
    ):
        sim = make()
        sim.set_pose(np.arange(len(assets)), pos, quat)
        sim.step(commands[0])  # untimed: the compiled layout kernels load on the first step
        t = time.perf_counter()
        for v in commands:
            sim.step(np.asarray(v, float))
        out[name] = len(assets) * steps / (time.perf_counter() - t)
        sim.close()
    return {
        "envs": len(assets),
        "steps": steps,
        "env_steps_per_s": {k: round(v) for k, v in out.items()},
        "panda_over_floating": round(out["panda"] / out["floating"], 3),
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.panda", description=__doc__)
    p.add_argument("what", choices=["tracking", "expert", "reach", "cost"])
    p.add_argument("--controller", choices=["impedance", "ik"], default="impedance")
    p.add_argument("--dataset", default="test")
    p.add_argument("--poses", type=int, default=4, help="spawn poses per module (reach)")
    p.add_argument("--modules", type=int, help="the first N modules only")
    p.add_argument("--envs", type=int, default=32)
    p.add_argument("--steps", type=int, default=50)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    if args.what == "tracking":
        result = tracking(args.dataset, args.modules or 4, args.controller)
    elif args.what == "expert":
        result = expert(args.dataset, args.modules or 64, args.controller, args.seed)
    elif args.what == "reach":
        result = reach(args.dataset, args.poses, args.modules, args.seed)
    else:
        result = cost(args.dataset, args.envs, args.steps)
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
