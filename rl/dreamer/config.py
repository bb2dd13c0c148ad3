"""DreamerV3 hyperparameters: a frozen dataclass, importable without torch (rl/presets.py
builds presets from it at every CLI start). Defaults: the official implementation's
defaults at the "small" model size (units 512, 2 layers, deter 512), which matches Table II
of the paper ([512, 512] MLPs, world model lr 1e-4, actor-critic lr 3e-5)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class DreamerConfig:
    """DreamerV3 hyperparameters (defaults: the official implementation, size "small")."""

    units: int = 512
    """Width of every MLP layer: encoder, decoder, reward and continue heads, actor, critic,
    and the RSSM's input and output layers."""
    layers: int = 2
    """Hidden layers of every MLP (each Linear -> LayerNorm -> SiLU)."""
    deter: int = 512
    """Size of the deterministic recurrent state h (a LayerNorm GRU)."""
    stoch: int = 32
    """Number of categorical latent variables in the stochastic state z."""
    classes: int = 32
    """Classes of each latent variable (z is `stoch` one-hot vectors of `classes`)."""
    unimix: float = 0.01
    """Mixture weight of the uniform distribution in every categorical (latents):
    p = (1 - unimix) softmax(logits) + unimix / classes; keeps KL terms and log-probs finite."""
    bins: int = 255
    """Bins of the two-hot distributions of the reward head and the critic."""
    bin_range: float = 20.0
    """The bins are evenly spaced over [-bin_range, bin_range] in symlog space."""
    free_nats: float = 1.0
    """Free bits: each KL term (dynamics, representation) is clipped below this many nats."""
    dyn_scale: float = 0.5
    """Weight of the dynamics loss KL(sg(posterior) || prior) (trains the prior)."""
    rep_scale: float = 0.1
    """Weight of the representation loss KL(posterior || sg(prior)) (trains the encoder)."""
    pred_scale: float = 1.0
    """Weight of the prediction losses (observation, reward, continue)."""
    model_lr: float = 1e-4
    """Adam learning rate of the world model."""
    model_eps: float = 1e-8
    """Adam epsilon of the world model."""
    model_clip: float = 1000.0
    """Gradient-norm clip of the world model."""
    actor_lr: float = 3e-5
    """Adam learning rate of the actor."""
    critic_lr: float = 3e-5
    """Adam learning rate of the critic."""
    ac_eps: float = 1e-5
    """Adam epsilon of the actor and the critic."""
    ac_clip: float = 100.0
    """Gradient-norm clip of the actor and of the critic."""
    horizon: int = 15
    """Imagination horizon H (steps imagined from every replayed posterior state)."""
    gamma: float = 1.0 - 1.0 / 333.0
    """Discount factor (the official code's `horizon: 333`, gamma = 1 - 1/333 ~ 0.997)."""
    lam: float = 0.95
    """lambda of the lambda-returns."""
    actor_grad: str = "backprop"
    """Actor gradient for continuous actions: "backprop" (through the learned dynamics, the
    v3 release that accompanies the 2023 paper: `actor_grad_cont: backprop`) or "reinforce"
    (the normalised-advantage policy gradient, which the 2024 revision of the official code
    uses for discrete and continuous actions alike)."""
    entropy_coef: float = 3e-4
    """Weight eta of the actor's entropy bonus."""
    min_std: float = 0.1
    """Smallest standard deviation of the bounded normal policy."""
    max_std: float = 1.0
    """Largest standard deviation of the bounded normal policy."""
    reward_scale: float = 1.0
    """Env rewards are multiplied by this before they enter the replay (1: the official
    algorithm). The return normaliser divides advantages by max(1, P95 - P5): on a task
    whose episode returns are at most 1 (peg-in-hole) that floor keeps the advantages far
    below the entropy bonus, and the policy's spread grows to its maximum instead of
    learning (measured on the first runs of the `cpu` preset). A scale lifts the returns'
    range above the floor without changing what is optimal."""
    obs_scale: float = 1.0
    """Observations are multiplied by this before the symlog of the encoder's input and of
    the decoder's target (1: the official algorithm). The squared error in symlog space
    weighs an error by the observation's unit: in metres, a 1 mm error of the peg's position
    costs 1e-6 and the world model has no reason to represent it, where the task's
    clearance is 1 mm. In millimetres (1000) a 1 mm error near the hole costs ln(2)^2 = 0.48,
    while far from it symlog compresses the scale (1 mm at 100 mm costs 1e-4)."""
    slow_critic_decay: float = 0.98
    """EMA decay of the slow target critic (the official `slow_critic_fraction: 0.02`)."""
    slowreg: float = 1.0
    """Weight of the critic's regulariser towards the slow critic's predictions."""
    return_decay: float = 0.99
    """EMA decay of the return normaliser's 5th and 95th percentiles."""
    return_low: float = 5.0
    """Lower percentile of the return normaliser."""
    return_high: float = 95.0
    """Upper percentile of the return normaliser (scale S = max(1, P_high - P_low))."""
    batch_size: int = 16
    """Sequences per gradient step."""
    batch_length: int = 64
    """Steps per replayed sequence."""
    train_ratio: float = 512.0
    """Replayed steps per env step (official): gradient steps per env step =
    train_ratio / (batch_size * batch_length), fractions accumulating."""
    replay_capacity: int = 20_000_000
    """Replay capacity in steps, summed over envs (each env keeps capacity / num_envs)."""
    checkpoint_replay_mb: float = 1024.0
    """The replay is saved in checkpoints (so --resume continues exactly) while its filled
    part takes at most this many MiB; a larger one is left out (writing and hashing
    gigabytes at every checkpoint), and a run resumed from such a checkpoint refills its
    replay from fresh experience: the world model, the policy and the counters carry on,
    the resume is not exact. The paper preset's full replay takes ~1.9 GiB, so it is saved
    until about half full; the cpu preset's (~100 MiB) always."""
    warmup_steps: int = 500_000
    """Env steps (summed over envs) taken with uniform random actions before training."""
    teacher_noise: float = 0.05
    """With a teacher (`--demos`) only: std of the Gaussian noise on its warm-up actions."""
    bc_weight: float = 0.0
    """With a teacher only: weight of a behaviour-cloning term added to the actor's loss,
    the negative log-likelihood under the policy, on every replayed posterior state, of the
    teacher's action at that step's observation (the teacher labels the replayed
    observations, its own and the policy's); it pulls the mean and narrows the spread. 0:
    the published algorithm, where the teacher only plays the warm-up. The SAC runs showed
    that demonstrations in the replay alone do not carry an agent past the switch from the
    teacher, and a constant BC term does."""
    compute_dtype: str = "float32"
    """"float32", or "bfloat16": the gradient steps run under torch.autocast (matrix
    products in bfloat16; distributions, losses and the optimiser in float32), as the
    official code computes in bfloat16. On a CPU with AVX512-BF16 (AMD Zen 4, Intel Sapphire
    Rapids) a cpu-preset gradient step takes about 0.7 of its float32 time; on a CPU without
    it bfloat16 is emulated and slower, so use float32 there. Acting stays in float32."""
    steps_per_iteration: int = 64
    """Vector-env steps per runner iteration (the logging and checkpoint unit)."""

    def validate(self) -> DreamerConfig:
        checks = {
            "units >= 1 and layers >= 1": self.units >= 1 and self.layers >= 1,
            "deter, stoch, classes >= 1": min(self.deter, self.stoch, self.classes) >= 1,
            "0 <= unimix < 1": 0 <= self.unimix < 1,
            "bins >= 2": self.bins >= 2,
            "horizon >= 1": self.horizon >= 1,
            "0 < gamma <= 1": 0 < self.gamma <= 1,
            "0 <= lam <= 1": 0 <= self.lam <= 1,
            "actor_grad in (backprop, reinforce)": self.actor_grad in ("backprop", "reinforce"),
            "0 < min_std <= max_std": 0 < self.min_std <= self.max_std,
            "batch_size, batch_length >= 1": min(self.batch_size, self.batch_length) >= 1,
            "train_ratio >= 0": self.train_ratio >= 0,
            "reward_scale > 0": self.reward_scale > 0,
            "obs_scale > 0": self.obs_scale > 0,
            "teacher_noise >= 0": self.teacher_noise >= 0,
            "bc_weight >= 0": self.bc_weight >= 0,
            "steps_per_iteration >= 1": self.steps_per_iteration >= 1,
            "compute_dtype in (float32, bfloat16)": self.compute_dtype in ("float32", "bfloat16"),
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"DreamerConfig: these must hold: {bad}")
        return self
