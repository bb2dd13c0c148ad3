"""Named training presets: for each algorithm its config, number of envs, default length
and checkpoint interval. `get_setup(preset, algo)`; an unknown name lists the valid ones.

    paper     Table II of the paper: [512, 512], 1024 envs, 100 M steps (a GPU and days)
    cpu       peg-in-hole on a 2-core CPU within an hour
    debug     seconds on any CPU: smoke tests and a first check of an install
"""

from __future__ import annotations

from dataclasses import dataclass

from rl.configs import PPOConfig, RandomConfig, SACConfig
from rl.dreamer.config import DreamerConfig

AlgoConfig = PPOConfig | SACConfig | DreamerConfig | RandomConfig


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
    curriculum_steps: int = 50_000_000
    """Env steps over which the env's spawn ranges grow from zero to full (the paper: the
    first 50 M of 100 M); passed to `make_env`. A run shorter than this trains on a
    fraction of the ranges it is evaluated on."""


PRESETS: dict[str, dict[str, Setup]] = {
    "paper": {
        # Table II (the configs' defaults): 1024 envs, 100 M steps. PPO: minibatches of 8192
        # out of 1024 x 128 = 131072 transitions (16 per epoch). SAC: 8 gradient steps of
        # 4096 per vector step; its 2e7 buffer takes 3.5 GB (29 GB with --stack 10)
        "ppo": Setup(
            PPOConfig(), num_envs=1024, total_steps=100_000_000, checkpoint_steps=5_000_000
        ),
        "sac": Setup(
            SACConfig(), num_envs=1024, total_steps=100_000_000, checkpoint_steps=5_000_000
        ),
        # DreamerV3: the official defaults at size "small" (units 512, 2 layers, deter 512,
        # 32 x 32 latents), batch 16 x 64, train ratio 512 (512 gradient steps per vector
        # step of 1024 envs); its 2e7-step replay takes 1.9 GiB with 18-D observations and
        # 6-D actions, saved in checkpoints until it passes 1 GiB (checkpoint_replay_mb)
        "dreamer": Setup(
            DreamerConfig(), num_envs=1024, total_steps=100_000_000, checkpoint_steps=5_000_000
        ),
        "random": Setup(
            RandomConfig(), num_envs=1024, total_steps=10_000_000, checkpoint_steps=10_000_000
        ),
    },
    "cpu": {
        # sized on a 2-core CPU under physics version 1, where the curriculum spanned about
        # half of what a 60-minute run reached. Version 2's steps cost about 9 times more: PPO
        # now reaches 3.2 M env steps in 60 minutes (64 envs), so its 3 M-step curriculum
        # spans nearly the whole run (docs/results/README.md, teacher-free candidates)
        "ppo": Setup(
            PPOConfig(
                hidden=(256, 256),
                learning_rate=1e-4,
                gamma=0.99,
                horizon=64,
                minibatch_size=1024,
                epochs=5,
                entropy_coef=3e-4,
                init_log_std=-1.0,
            ),
            num_envs=64,
            total_steps=10_000_000,
            checkpoint_steps=500_000,
            curriculum_steps=3_000_000,
        ),
        "sac": Setup(
            SACConfig(
                hidden=(256, 256),
                layer_norm=True,
                max_grad_norm=10.0,
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
            num_envs=32,
            total_steps=4_000_000,
            checkpoint_steps=250_000,
            curriculum_steps=1_000_000,
        ),
        # DreamerV3 on a 2-core CPU: gradient steps take the hour (units 128 halve a step's
        # time against 256), and train ratio 8 is one gradient step per 64 env steps. Four
        # changes from the official defaults, each measured on peg-in-hole (docs/benchmarks):
        # observations in millimetres (obs_scale: in metres the world model ignores a 1 mm
        # error), rewards x 100 (reward_scale: returns of at most 1 leave the return
        # normaliser at its floor), learning rates 3e-4 / 1e-4 / 1e-4 (a hundredth of the
        # official gradient steps), reinforce gradients (the official code's current
        # choice, cheaper than backprop). The replay of 1e6 steps is saved in checkpoints
        "dreamer": Setup(
            DreamerConfig(
                units=128,
                deter=256,
                stoch=16,
                classes=16,
                batch_length=32,
                train_ratio=8.0,
                model_lr=3e-4,
                actor_lr=1e-4,
                critic_lr=1e-4,
                reward_scale=100.0,
                obs_scale=1000.0,
                actor_grad="reinforce",
                replay_capacity=1_000_000,
                warmup_steps=10_000,
                steps_per_iteration=64,
            ),
            num_envs=16,
            total_steps=1_000_000,
            checkpoint_steps=50_000,
            curriculum_steps=250_000,
        ),
        "random": Setup(RandomConfig(), num_envs=64, total_steps=200_000, checkpoint_steps=200_000),
    },
    "debug": {
        # seconds on any CPU: small nets and batches, for smoke tests and a first check of
        # an install (`assetgen train --preset debug --steps 2000 ...`); learns nothing useful
        "ppo": Setup(
            PPOConfig(hidden=(32, 32), horizon=16, minibatch_size=64, epochs=2),
            num_envs=4,
            total_steps=2_048,
            checkpoint_steps=1_024,
            curriculum_steps=0,
        ),
        "sac": Setup(
            SACConfig(
                hidden=(32, 32),
                batch_size=64,
                buffer_size=10_000,
                warmup_steps=100,
                steps_per_iteration=16,
            ),
            num_envs=4,
            total_steps=2_048,
            checkpoint_steps=1_024,
            curriculum_steps=0,
        ),
        "dreamer": Setup(
            DreamerConfig(
                units=32,
                layers=1,
                deter=32,
                stoch=4,
                classes=4,
                batch_size=4,
                batch_length=8,
                horizon=5,
                replay_capacity=10_000,
                warmup_steps=64,
                train_ratio=16.0,
                steps_per_iteration=16,
            ),
            num_envs=4,
            total_steps=1_024,
            checkpoint_steps=512,
            curriculum_steps=0,
        ),
        "random": Setup(RandomConfig(), num_envs=4, total_steps=2_048, checkpoint_steps=2_048),
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
