"""The hyperparameters of PPO, SAC and the random agent: frozen dataclasses, importable
without torch (DreamerV3's are rl/dreamer/config.py), so that the presets (rl/presets.py)
and the algorithm registry (rl/algorithms.py) load when the command line builds its parser.
Each algorithm's module (rl/ppo.py, rl/sac.py, rl/random_agent.py) imports its config from
here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class PPOConfig:
    """PPO hyperparameters (defaults: paper Table II and the original implementation)."""

    hidden: tuple[int, ...] = (512, 512)
    """Hidden layer widths of the actor and of the critic MLP."""
    activation: str = "elu"
    """Hidden-layer activation: elu (rsl_rl's choice), relu or tanh."""
    learning_rate: float = 3e-4
    """Adam learning rate (the start value when `desired_kl` adapts it)."""
    gamma: float = 0.997
    """Discount factor."""
    gae_lambda: float = 0.95
    """GAE lambda: the bias-variance trade-off of the advantage estimate."""
    horizon: int = 128
    """Steps per env per rollout; a rollout holds horizon * num_envs transitions."""
    minibatch_size: int = 8192
    """Transitions per gradient step (a rollout smaller than this is one minibatch)."""
    epochs: int = 8
    """Passes over each rollout."""
    clip: float = 0.2
    """Clip range epsilon of the probability ratio."""
    value_coef: float = 0.5
    """Weight of the value loss."""
    entropy_coef: float = 3e-4
    """Weight of the entropy bonus."""
    max_grad_norm: float = 0.5
    """Global gradient-norm clip."""
    init_log_std: float = 0.0
    """Initial log standard deviation of the Gaussian policy (0: std 1)."""
    normalize_obs: bool = True
    """Normalise observations with running statistics (updated after each rollout)."""
    obs_symlog_scale: float | None = None
    """If set, the networks see symlog(k obs) with k this (then normalised): 1000 reads
    positions in millimetres, fine near the hole and compressed far from it (rl.nets.SymlogObs)."""
    reward_scale: float = 1.0
    """Rewards are multiplied by this before learning (logged returns are not)."""
    desired_kl: float | None = None
    """If set, adapt the learning rate after each minibatch to keep KL(old||new) near this
    (rsl_rl's adaptive schedule: /1.5 above 2x, x1.5 below 0.5x, within [1e-5, 1e-2])."""
    bounds_loss_coef: float = 0.0
    """Weight of a penalty on policy means beyond +-1.1 (rl_games' bounds loss, used by
    Isaac Gym's insertion tasks): actions are clipped to [-1, 1], so a mean far past a bound
    costs the sampled policy nothing while its deterministic policy pushes at the limit."""
    final_std: float | None = None
    """If set, the action std is capped by a schedule that falls log-linearly from
    exp(init_log_std) at `std_decay_start` env steps to this at `std_decay_end`, and stays
    there. Noise then cannot stay part of the strategy: the mean action, which the
    deterministic policy plays, has to do the job alone by the end of training."""
    std_decay_start: int = 0
    """Env steps (summed over envs) at which the std cap starts to fall."""
    std_decay_end: int = 0
    """Env steps at which the std cap reaches `final_std`."""

    def std_cap(self, env_steps: int) -> float | None:
        """The cap on each action std after `env_steps` env steps (None: no cap)."""
        if self.final_std is None:
            return None
        span = self.std_decay_end - self.std_decay_start
        f = 1.0 if span <= 0 else (env_steps - self.std_decay_start) / span
        f = min(max(f, 0.0), 1.0)
        return math.exp((1.0 - f) * self.init_log_std + f * math.log(self.final_std))

    def validate(self) -> PPOConfig:
        checks = {
            "horizon >= 1": self.horizon >= 1,
            "minibatch_size >= 1": self.minibatch_size >= 1,
            "epochs >= 1": self.epochs >= 1,
            "0 < gamma <= 1": 0 < self.gamma <= 1,
            "0 <= gae_lambda <= 1": 0 <= self.gae_lambda <= 1,
            "learning_rate > 0": self.learning_rate > 0,
            "obs_symlog_scale is None or > 0": (
                self.obs_symlog_scale is None or self.obs_symlog_scale > 0
            ),
            "bounds_loss_coef >= 0": self.bounds_loss_coef >= 0,
            "final_std is None or > 0": self.final_std is None or self.final_std > 0,
            "0 <= std_decay_start <= std_decay_end": (
                0 <= self.std_decay_start <= self.std_decay_end
            ),
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"PPOConfig: these must hold: {bad}")
        return self


@dataclass(frozen=True)
class SACConfig:
    """SAC hyperparameters (defaults: paper Table II and the original implementation)."""

    hidden: tuple[int, ...] = (512, 512)
    """Hidden layer widths of the actor and of each Q MLP."""
    activation: str = "relu"
    """Hidden-layer activation: relu (the usual SAC choice, cheapest on CPU), elu or tanh."""
    layer_norm: bool = False
    """LayerNorm before every hidden activation of the actor and the critics: it bounds the
    hidden features whatever the input's scale, so one far-out observation cannot send the
    critics' outputs and gradients off (on in the cpu preset; whether resetting runaway pegs,
    see sim/engines/mujoco/scene.py, makes it unnecessary is not measured)."""
    obs_symlog_scale: float | None = None
    """If set, the actor and the critics see symlog(k obs) with k this: 1000 reads positions
    in millimetres, fine near the hole and compressed far from it (rl.nets.SymlogObs)."""
    max_grad_norm: float | None = None
    """Clip the gradient norm of the critics and of the actor to this (None: no clipping);
    the norms before clipping are logged either way."""
    learning_rate: float = 8e-5
    """Adam learning rate of the actor, the critics and the temperature."""
    gamma: float = 0.997
    """Discount factor."""
    tau: float = 0.005
    """Polyak factor of the target critics: theta' <- tau theta + (1 - tau) theta'."""
    batch_size: int = 4096
    """Transitions per gradient step."""
    buffer_size: int = 20_000_000
    """Replay buffer capacity, transitions."""
    warmup_steps: int = 500_000
    """Transitions (summed over envs) taken with uniform random actions, and collected
    before the first gradient step."""
    gradient_steps: float = 8.0
    """Gradient steps per vector-env step (fractions accumulate: 0.25 = one every 4)."""
    entropy_coef: float = 3e-4
    """Temperature alpha (fixed), or its initial value when `learn_entropy`."""
    learn_entropy: bool = False
    """Learn alpha so the policy's entropy tracks `target_entropy`."""
    target_entropy: float | None = None
    """Entropy target when learning alpha (None: -act_dim)."""
    exploration: str = "white"
    """The actor's noise when acting: "white", a fresh Gaussian draw every step (SAC's own);
    "pink", the same std but noise correlated over time with a 1/f spectrum, per env and
    action dimension (rl/exploration.py), so a hovering policy still wanders. Training
    batches always use white draws."""
    noise_period: int = 500
    """With exploration "pink": control steps of one noise sequence (its longest correlation;
    500: an episode's step limit)."""
    reward_scale: float = 1.0
    """Rewards are multiplied by this before learning (logged returns are not)."""
    n_step: int = 1
    """Rewards summed over this many steps before the critics' targets bootstrap (n-step
    returns, rl/nstep.py; 1: the one-step target of SAC)."""
    steps_per_iteration: int = 64
    """Vector-env steps per runner iteration (the logging and checkpoint unit)."""
    bc_weight: float = 0.5
    """With a teacher only: weight of the behaviour-cloning term at the start, relative to
    the batch's mean |Q| (TD3+BC's normalisation; 0: no BC term, the teacher then only
    plays the warm-up)."""
    bc_decay_steps: int = 1_000_000
    """With a teacher only: env steps (summed over envs) over which the BC weight falls
    linearly to zero."""
    bc_filter: bool = False
    """With a teacher only: the BC term applies only to samples where the critics value the
    teacher's action above the policy's mean action (the Q filter of Nair et al. 2018), so
    a policy that found something better than a slow teacher is not pulled back."""
    teacher_noise: float = 0.05
    """With a teacher only: standard deviation of the Gaussian noise added to its actions
    during the warm-up (clipped to [-1, 1]), so the demonstrations cover more than its one
    path. The scripted expert, one attempt on each test module: 100 % success at 0.05 (median
    3.76 s), 97.6 % at 0.1, 28 % at 0.2 (it jams)."""

    def validate(self) -> SACConfig:
        checks = {
            "batch_size >= 1": self.batch_size >= 1,
            "buffer_size >= batch_size": self.buffer_size >= self.batch_size,
            "0 < tau <= 1": 0 < self.tau <= 1,
            "0 < gamma <= 1": 0 < self.gamma <= 1,
            "gradient_steps >= 0": self.gradient_steps >= 0,
            "entropy_coef > 0": self.entropy_coef > 0,
            "steps_per_iteration >= 1": self.steps_per_iteration >= 1,
            "n_step >= 1": self.n_step >= 1,
            "exploration in ('white', 'pink')": self.exploration in ("white", "pink"),
            "noise_period >= 2": self.noise_period >= 2,
            "max_grad_norm is None or > 0": self.max_grad_norm is None or self.max_grad_norm > 0,
            "obs_symlog_scale is None or > 0": (
                self.obs_symlog_scale is None or self.obs_symlog_scale > 0
            ),
            "bc_weight >= 0": self.bc_weight >= 0,
            "bc_decay_steps >= 0": self.bc_decay_steps >= 0,
            "teacher_noise >= 0": self.teacher_noise >= 0,
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"SACConfig: these must hold: {bad}")
        return self


@dataclass(frozen=True)
class RandomConfig:
    """The random agent has nothing to learn; only the logging unit is configurable."""

    steps_per_iteration: int = 128
    """Vector-env steps per runner iteration (the logging and checkpoint unit)."""
