"""Named training presets: for each algorithm its config, number of envs, default length
and checkpoint interval. `get_setup(preset, algo)`; an unknown name lists the valid ones.

    paper     Table II of the paper: [512, 512], 1024 envs, 100 M steps (a GPU and days)
    cpu       peg-in-hole on a 2-core CPU within an hour
    pendulum  Pendulum-v1 (python -m rl.bench_pendulum), budgets like published examples
"""

from __future__ import annotations

from dataclasses import dataclass

from rl.ppo import PPOConfig
from rl.random_agent import RandomConfig
from rl.sac import SACConfig

AlgoConfig = PPOConfig | SACConfig | RandomConfig


@dataclass(frozen=True)
class Setup:
    """One algorithm's settings within a preset."""

    config: AlgoConfig
    """The algorithm's hyperparameters."""
    num_envs: int
    """Environments stepping together (what `make_env` is asked for)."""
    total_steps: int
    """Env steps (summed over envs) when neither --steps nor --minutes is given."""
    checkpoint_steps: int
    """Env steps between periodic checkpoints (rounded up to whole iterations)."""


PRESETS: dict[str, dict[str, Setup]] = {
    "paper": {
        # Table II; PPO minibatch 8192 of 1024 x 128 = 131072 transitions (16 per epoch)
        "ppo": Setup(PPOConfig(), 1024, 100_000_000, 5_000_000),
        "sac": Setup(SACConfig(), 1024, 100_000_000, 5_000_000),
        "random": Setup(RandomConfig(), 1024, 10_000_000, 10_000_000),
    },
    "cpu": {
        "ppo": Setup(
            PPOConfig(
                hidden=(256, 256),
                learning_rate=3e-4,
                gamma=0.99,
                horizon=64,
                minibatch_size=2048,
                epochs=5,
                entropy_coef=3e-4,
                desired_kl=0.01,
            ),
            64,
            20_000_000,
            1_000_000,
        ),
        "sac": Setup(
            SACConfig(
                hidden=(256, 256),
                learning_rate=3e-4,
                gamma=0.99,
                batch_size=512,
                buffer_size=500_000,
                warmup_steps=20_000,
                gradient_steps=1.0,
                entropy_coef=1e-3,
                learn_entropy=True,
                steps_per_iteration=64,
            ),
            32,
            5_000_000,
            500_000,
        ),
        "random": Setup(RandomConfig(), 64, 200_000, 200_000),
    },
    "pendulum": {
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
            8,
            300_000,
            100_000,
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
            1,
            20_000,
            10_000,
        ),
        "random": Setup(RandomConfig(steps_per_iteration=200), 8, 16_000, 16_000),
    },
}
"""preset name -> algorithm -> Setup."""


def get_setup(preset: str, algo: str) -> Setup:
    """The Setup of `algo` in `preset`; ValueError naming the valid choices otherwise."""
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; valid presets: {sorted(PRESETS)}")
    if algo not in PRESETS[preset]:
        raise ValueError(f"unknown algorithm {algo!r}; valid algorithms: {sorted(PRESETS[preset])}")
    return PRESETS[preset][algo]
