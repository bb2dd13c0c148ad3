"""PPO, SAC and DreamerV3 on Pendulum-v1: shows the algorithms learn (mean return above
-200, i.e. solved) within budgets like those of published implementations (SAC ~2e4 steps,
PPO a few 1e5, DreamerV3 ~1e4), on CPU.

    python -m benchmarks.pendulum --algo ppo|sac|dreamer [--seed 0] [--steps N] [--threads 1]
                                [--episodes 20] [--out DIR]

Trains with the settings below (PENDULUM) through the shared runner, then evaluates
the deterministic policy on `--episodes` fresh episodes (evaluation/protocol.py); prints the figures
and, last, one JSON line.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import torch

from evaluation.protocol import evaluate
from rl.agents import reset_hook
from rl.dreamer.config import DreamerConfig
from rl.gym_vec import GymVecEnv
from rl.ppo import PPOConfig
from rl.presets import Setup
from rl.random_agent import RandomConfig
from rl.run_state import load_agent
from rl.runner import console, train
from rl.sac import SACConfig

PENDULUM: dict[str, Setup] = {
    "ppo": Setup(
        PPOConfig(
            hidden=(64, 64),
            learning_rate=1e-3,
            gamma=0.95,
            horizon=256,
            minibatch_size=256,
            epochs=10,
            entropy_coef=0.0,
            normalize_obs=True,
            reward_scale=0.1,
        ),
        num_envs=8,
        total_steps=300_000,
        checkpoint_steps=100_000,
    ),
    "sac": Setup(
        SACConfig(
            hidden=(256, 256),
            learning_rate=1e-3,
            gamma=0.99,
            batch_size=256,
            buffer_size=100_000,
            warmup_steps=2_000,
            gradient_steps=1.0,
            entropy_coef=0.1,
            learn_entropy=True,
            steps_per_iteration=200,
        ),
        num_envs=1,
        total_steps=20_000,
        checkpoint_steps=10_000,
    ),
    # DreamerV3 with the official algorithm and a model small enough for one CPU thread:
    # a gradient step (16 x 16 replayed steps, 256 imagined trajectories of 15 steps)
    # takes ~0.1 s there; one gradient step per env step (train ratio 256)
    "dreamer": Setup(
        DreamerConfig(
            units=64,
            deter=64,
            stoch=8,
            classes=8,
            batch_size=16,
            batch_length=16,
            train_ratio=256.0,
            model_lr=3e-4,
            actor_lr=1e-4,
            critic_lr=1e-4,
            replay_capacity=100_000,
            warmup_steps=1_000,
            steps_per_iteration=200,
        ),
        num_envs=1,
        total_steps=8_000,
        checkpoint_steps=2_000,
    ),
    "random": Setup(RandomConfig(200), num_envs=8, total_steps=16_000, checkpoint_steps=16_000),
}
"""Pendulum-v1 settings by algorithm: budgets like published examples."""

SOLVED = -200.0
"""Mean episode return above which Pendulum-v1 counts as solved here."""


def bench(
    algo: str,
    seed: int = 0,
    steps: int | None = None,
    episodes: int = 20,
    out: Path | None = None,
    progress: bool = True,
) -> dict:
    """Train `algo` on Pendulum-v1 and evaluate it; returns the figures as a dict."""
    setup = PENDULUM[algo]
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(out) if out is not None else Path(tmp) / "run"
        env = GymVecEnv("Pendulum-v1", setup.num_envs)
        t0 = time.perf_counter()
        result = train(
            algo,
            env,
            setup,
            steps=steps,
            seed=seed,
            out_dir=run,
            progress=progress,
            tensorboard=False,
            device="cpu",
        )
        train_s = time.perf_counter() - t0
        agent, _ = load_agent(run, "cpu")
    ev_env = GymVecEnv("Pendulum-v1", episodes)
    ev = evaluate(agent.policy, ev_env, 1, seed=10_000 + seed, reset=reset_hook(agent))
    return {
        "algo": algo,
        "env": "Pendulum-v1",
        "seed": seed,
        "status": result["status"],
        "env_steps": result["env_steps"],
        "train_seconds": round(train_s, 1),
        "eval_episodes": ev["episodes"],
        "eval_mean_return": round(ev["mean_return"], 1),
        "eval_std_return": round(ev["std_return"], 1),
        "solved": ev["mean_return"] > SOLVED,
        "torch_threads": torch.get_num_threads(),
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m benchmarks.pendulum",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--algo", choices=sorted(PENDULUM), required=True)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--steps", type=int, help="env steps (default: PENDULUM's total_steps)")
    p.add_argument("--episodes", type=int, default=20, help="evaluation episodes")
    p.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1)")
    p.add_argument("--out", type=Path, help="keep the run here (default: a temporary folder)")
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args(argv)
    torch.set_num_threads(args.threads)
    res = bench(args.algo, args.seed, args.steps, args.episodes, args.out, not args.no_progress)
    width = max(len(k) for k in res)
    for k, v in res.items():
        console.print(f"{k:<{width}}  {v}")
    print(json.dumps(res))
    return 0 if res["solved"] else 1


if __name__ == "__main__":
    sys.exit(main())
