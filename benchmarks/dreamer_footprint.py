"""DreamerV3's memory and step times under a preset, without training it.

    python -m benchmarks.dreamer_footprint [--preset cpu] [--envs 1024] [--threads 1]
                                           [--grad-steps 5] [--policy-steps 20]

Builds the preset's agent for peg-in-hole's observation and action sizes, then measures:
the replay's size when full (`SequenceReplay.nbytes`), the process's resident memory before
and after every replay page is written and a few gradient steps have run (what a training
run holds once its replay is full), the median time of a gradient step on a replay of random
steps, and the median time of one deterministic policy step for `--envs` envs (what an
evaluation pays per control step on top of the simulator). Random data: the figures are
sizes and times, not learning. Prints the figures and, last, one JSON line.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time

import numpy as np
import torch

from rl.dreamer.agent import Dreamer
from rl.presets import get_setup
from sim.task import rules as T


def _rss_mb() -> float:
    """The process's resident memory now, MB (Linux /proc; the peak where it is missing)."""
    try:
        with open("/proc/self/statm") as f:
            pages = int(f.read().split()[1])
        return pages * resource.getpagesize() / 1e6
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3


def _fill(agent: Dreamer, rng: np.random.Generator) -> None:
    """Fill the replay with random steps through its own `load`, so every page is resident."""
    replay = agent.replay
    arrays = {}
    for key, (shape, dtype) in replay.specs.items():
        full = (replay.num_envs, replay.per_env, *shape)
        arrays[key] = (
            rng.random(full) < 0.01
            if dtype == np.bool_
            else rng.standard_normal(full, dtype=np.float32)
        )
    full_count = [replay.per_env] * replay.num_envs
    replay.load(arrays, {"pos": [0] * replay.num_envs, "count": full_count})


def footprint(
    preset: str = "cpu", envs: int = 1024, grad_steps: int = 5, policy_steps: int = 20
) -> dict:
    """The figures of the module docstring, as a dict (sizes in MB, times in s or ms)."""
    setup = get_setup(preset, "dreamer")
    rng = np.random.default_rng(0)
    torch.manual_seed(0)
    base = _rss_mb()
    agent = Dreamer(T.OBS_DIM, T.ACT_DIM, setup.num_envs, setup.config)
    built = _rss_mb()
    _fill(agent, rng)
    filled = _rss_mb()
    times = []
    for _ in range(grad_steps + 1):  # the first step pays one-time set-up: not counted
        t0 = time.perf_counter()
        agent._train_step()
        times.append(time.perf_counter() - t0)
    trained = _rss_mb()
    policy = Dreamer(T.OBS_DIM, T.ACT_DIM, envs, setup.config)  # acts only: no replay
    policy.wm.load_state_dict(agent.wm.state_dict())
    policy.ac.load_state_dict(agent.ac.state_dict())
    obs = rng.standard_normal((envs, T.OBS_DIM)).astype(np.float32)
    ms = []
    for _ in range(policy_steps + 1):
        t0 = time.perf_counter()
        policy.policy(obs, deterministic=True)
        ms.append(1e3 * (time.perf_counter() - t0))
    return {
        "preset": preset,
        "train_envs": setup.num_envs,
        "replay_steps": agent.replay.per_env * agent.replay.num_envs,
        "replay_mb": agent.replay.nbytes / 1e6,
        "rss_start_mb": base,
        "rss_agent_mb": built,
        "rss_replay_full_mb": filled,
        "rss_after_grad_steps_mb": trained,
        "grad_step_s": float(np.median(times[1:])),
        "policy_envs": envs,
        "policy_step_ms": float(np.median(ms[1:])),
        "torch_threads": torch.get_num_threads(),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="cpu", help="a preset of rl/presets.py (default cpu)")
    ap.add_argument("--envs", type=int, default=1024, help="envs of the policy step (1024)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (default 1)")
    ap.add_argument("--grad-steps", type=int, default=5, help="gradient steps timed (5)")
    ap.add_argument("--policy-steps", type=int, default=20, help="policy steps timed (20)")
    args = ap.parse_args(argv)
    for name in ("envs", "threads", "grad_steps", "policy_steps"):
        if getattr(args, name) < 1:
            ap.error(f"--{name.replace('_', '-')} = {getattr(args, name)}; expected >= 1")
    torch.set_num_threads(args.threads)
    try:
        r = footprint(args.preset, args.envs, args.grad_steps, args.policy_steps)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"preset {r['preset']}: replay of {r['replay_steps']:,} steps, {r['replay_mb']:.0f} MB")
    print(
        f"resident memory: {r['rss_start_mb']:.0f} MB at start, {r['rss_agent_mb']:.0f} with "
        f"the agent, {r['rss_replay_full_mb']:.0f} with the replay full, "
        f"{r['rss_after_grad_steps_mb']:.0f} after the gradient steps"
    )
    print(f"gradient step: {r['grad_step_s']:.3f} s (median, {r['torch_threads']} thread(s))")
    print(f"policy step for {r['policy_envs']} envs: {r['policy_step_ms']:.1f} ms (median)")
    print(json.dumps(r))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
