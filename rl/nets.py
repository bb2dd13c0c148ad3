"""Networks: MLPs, observation encodings (a running normaliser, a scaled symlog), the PPO
Gaussian actor-critic and the SAC tanh-squashed Gaussian actor and Q-function. Shapes: B is
the batch size."""

from __future__ import annotations

import math

import torch
from torch import nn

from rl.dreamer.distributions import symlog

LOG_2PI = math.log(2.0 * math.pi)


ACTIVATIONS: dict[str, type[nn.Module]] = {"elu": nn.ELU, "relu": nn.ReLU, "tanh": nn.Tanh}
"""Hidden-layer activations by name."""


def mlp(
    in_dim: int,
    hidden: tuple[int, ...],
    out_dim: int,
    activation: str = "elu",
    layer_norm: bool = False,
) -> nn.Sequential:
    """in_dim -> hidden... -> out_dim, `activation` (ACTIVATIONS) after every hidden layer,
    preceded by a LayerNorm when `layer_norm` (which bounds the hidden features whatever the
    input's scale: the usual cure for diverging off-policy critics, Ball et al. 2023)."""
    if activation not in ACTIVATIONS:
        raise ValueError(f"unknown activation {activation!r}; valid: {sorted(ACTIVATIONS)}")
    layers: list[nn.Module] = []
    last = in_dim
    for h in hidden:
        norm = [nn.LayerNorm(h)] if layer_norm else []
        layers += [nn.Linear(last, h), *norm, ACTIVATIONS[activation]()]
        last = h
    layers.append(nn.Linear(last, out_dim))
    return nn.Sequential(*layers)


class NonFiniteLossError(RuntimeError):
    """A loss became NaN or infinite: training must stop (the runner keeps the last good
    checkpoint)."""


def check_finite(algo: str, loss: torch.Tensor, **terms: torch.Tensor) -> None:
    """Raise NonFiniteLossError naming every term when the scalar `loss` is NaN or inf."""
    if torch.isfinite(loss):
        return
    parts = ", ".join(f"{k} {v.item():.4g}" for k, v in terms.items())
    raise NonFiniteLossError(
        f"{algo} loss is {loss.item()} ({parts}): check the env's rewards and observations "
        "for NaN/inf, or lower the learning rate"
    )


class RunningNorm(nn.Module):
    """Normalises inputs (B, dim) with a running mean and variance of all inputs seen in
    `update` (parallel Welford / Chan et al.); statistics live in buffers, so they are saved
    in the state dict. Normalised values are clipped to +- `clip`."""

    def __init__(self, dim: int, clip: float = 10.0, enabled: bool = True) -> None:
        super().__init__()
        self.enabled = enabled
        self.clip = clip
        self.register_buffer("mean", torch.zeros(dim, dtype=torch.float64))
        self.register_buffer("var", torch.ones(dim, dtype=torch.float64))
        self.register_buffer("count", torch.zeros((), dtype=torch.float64))

    @torch.no_grad()
    def update(self, x: torch.Tensor) -> None:
        """Fold a batch x (B, dim) into the statistics."""
        if not self.enabled:
            return
        x = x.to(torch.float64).reshape(-1, self.mean.shape[0])
        n = x.shape[0]
        if n == 0:
            return
        b_mean, b_var = x.mean(0), x.var(0, unbiased=False)
        total = self.count + n
        delta = b_mean - self.mean
        # M2 = M2_a + M2_b + delta^2 * n_a * n_b / (n_a + n_b)
        m2 = self.var * self.count + b_var * n + delta**2 * self.count * n / total
        self.mean += delta * n / total
        self.var.copy_(m2 / total)
        self.count.copy_(total)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """(B, dim) -> (x - mean) / sqrt(var + 1e-8), clipped; identity when disabled."""
        if not self.enabled:
            return x
        y = (x - self.mean.to(x.dtype)) / torch.sqrt(self.var.to(x.dtype) + 1e-8)
        return y.clamp(-self.clip, self.clip)


class SymlogObs(nn.Module):
    """x -> symlog(k x) when a scale k is given, else the identity; stateless, so a network
    with or without it loads the same checkpoints.

    Peg-in-hole's positions are in metres: a 1 mm error near the hole moves the input by
    1e-3, while spawns span 0.5 m. With k = 1000 (millimetres) symlog gives a millimetre
    near the hole about the weight of 10 cm far from it. This is DreamerV3's encoding of
    vector inputs; rl.dreamer's world model uses it with its `obs_scale`."""

    def __init__(self, scale: float | None = None) -> None:
        super().__init__()
        self.scale = scale

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x if self.scale is None else symlog(self.scale * x)


class ActorCritic(nn.Module):
    """PPO networks: a Gaussian policy with a state-independent log std, and a value MLP.

    pi(a | s) = N(mu(s), diag(exp(log_std))^2); actions are sampled unbounded and clipped to
    [-1, 1] by the caller when sent to the env (the log-probability is of the raw sample).
    """

    def __init__(
        self,
        obs_dim: int,
        act_dim: int,
        hidden: tuple[int, ...],
        init_log_std: float,
        normalize_obs: bool,
        activation: str = "elu",
        obs_symlog_scale: float | None = None,
    ) -> None:
        super().__init__()
        self.encode = SymlogObs(obs_symlog_scale)
        self.obs_norm = RunningNorm(obs_dim, enabled=normalize_obs)
        self.actor = mlp(obs_dim, hidden, act_dim, activation)
        self.critic = mlp(obs_dim, hidden, 1, activation)
        self.log_std = nn.Parameter(torch.full((act_dim,), float(init_log_std)))
        # small last layer: initial actions near 0 (the usual PPO initialisation)
        nn.init.orthogonal_(self.actor[-1].weight, 0.01)
        nn.init.zeros_(self.actor[-1].bias)

    def features(self, obs: torch.Tensor) -> torch.Tensor:
        """What both MLPs see: the encoded observation, normalised."""
        return self.obs_norm(self.encode(obs))

    def value(self, obs: torch.Tensor) -> torch.Tensor:
        """V(s): obs (B, obs_dim) -> (B,)."""
        return self.critic(self.features(obs)).squeeze(-1)

    def dist(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(mean (B, act_dim), std (act_dim,)) of pi(. | s)."""
        return self.actor(self.features(obs)), self.log_std.exp()

    @staticmethod
    def log_prob(mean: torch.Tensor, std: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """log N(a; mu, sigma) summed over action dims: (B,)
        = sum_i [ -(a_i - mu_i)^2 / (2 sigma_i^2) - log sigma_i - log(2 pi) / 2 ]."""
        z = (action - mean) / std
        return (-0.5 * z**2 - torch.log(std) - 0.5 * LOG_2PI).sum(-1)

    @staticmethod
    def entropy(std: torch.Tensor) -> torch.Tensor:
        """Entropy of the diagonal Gaussian: sum_i [ log sigma_i + (1 + log 2 pi) / 2 ]."""
        return (torch.log(std) + 0.5 * (1.0 + LOG_2PI)).sum(-1)


class SquashedGaussianActor(nn.Module):
    """SAC policy: a = tanh(u), u ~ N(mu(s), sigma(s)^2), log sigma clamped to [-5, 2].

    log pi(a | s) = log N(u; mu, sigma) - sum_i log(1 - tanh(u_i)^2), the last term
    computed stably as 2 (log 2 - u - softplus(-2u)).
    """

    def __init__(
        self,
        obs_dim: int,
        act_dim: int,
        hidden: tuple[int, ...],
        activation: str = "relu",
        layer_norm: bool = False,
        obs_symlog_scale: float | None = None,
    ) -> None:
        super().__init__()
        self.encode = SymlogObs(obs_symlog_scale)
        self.net = mlp(obs_dim, hidden, 2 * act_dim, activation, layer_norm)

    def forward(
        self, obs: torch.Tensor, deterministic: bool = False, noise: torch.Tensor | None = None
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """obs (B, obs_dim) -> action (B, act_dim) in (-1, 1), log pi(a | s) (B,). noise:
        the standard normal draw (B, act_dim) to use instead of a fresh one."""
        mean, log_std = self.net(self.encode(obs)).chunk(2, dim=-1)
        log_std = log_std.clamp(-5.0, 2.0)
        std = log_std.exp()
        eps = torch.randn_like(mean) if noise is None else noise
        u = mean if deterministic else mean + std * eps
        logp = ActorCritic.log_prob(mean, std, u)
        logp = logp - (2.0 * (math.log(2.0) - u - nn.functional.softplus(-2.0 * u))).sum(-1)
        return torch.tanh(u), logp


class QNetwork(nn.Module):
    """Q(s, a): obs (B, obs_dim), action (B, act_dim) -> (B,)."""

    def __init__(
        self,
        obs_dim: int,
        act_dim: int,
        hidden: tuple[int, ...],
        activation: str = "relu",
        layer_norm: bool = False,
        obs_symlog_scale: float | None = None,
    ) -> None:
        super().__init__()
        self.encode = SymlogObs(obs_symlog_scale)  # the observation only, not the action
        self.net = mlp(obs_dim + act_dim, hidden, 1, activation, layer_norm)

    def forward(self, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat([self.encode(obs), action], dim=-1)).squeeze(-1)
