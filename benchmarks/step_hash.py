"""A hash of the simulator's outputs over many env steps: the same hash before and after a
change means the change left every observation, reward and episode end bit-identical.

    python -m benchmarks.step_hash DATASET [--envs 16] [--steps 300] [--engine mujoco]

It steps the vector env twice from a seeded reset with seeded random actions, once with the
evaluation protocol's noise and once without, and hashes every observation, reward,
termination and truncation (SHA-256, first 16 hex digits). Floating-point results depend on
the installed MuJoCo and numpy and on the processor, so compare hashes made on one machine.
"""

from __future__ import annotations

import argparse
import hashlib
from dataclasses import replace

import numpy as np


def step_hash(dataset: str, envs: int = 16, steps: int = 300, engine: str = "mujoco") -> str:
    """The hash of `steps` control steps of `envs` envs on `dataset`, noise on and off."""
    from sim import EVAL_CONFIG, PegInHoleVecEnv

    h = hashlib.sha256()
    for noise in (True, False):
        config = replace(EVAL_CONFIG, noise=noise)
        env = PegInHoleVecEnv(dataset, envs, config, assignment_seed=0, engine=engine)
        rng = np.random.default_rng(1)
        h.update(env.reset(seed=0).tobytes())
        for _ in range(steps):
            obs, reward, terminated, truncated, _ = env.step(rng.uniform(-1, 1, (envs, 6)))
            for a in (obs, reward, terminated, truncated):
                h.update(np.ascontiguousarray(a).tobytes())
        env.close()
    return h.hexdigest()[:16]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("dataset", help="a dataset folder")
    p.add_argument("--envs", type=int, default=16)
    p.add_argument("--steps", type=int, default=300)
    p.add_argument("--engine", default="mujoco", help="a registered engine's name")
    args = p.parse_args(argv)
    print(step_hash(args.dataset, args.envs, args.steps, args.engine))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
