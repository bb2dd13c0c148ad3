"""The maths of DreamerV3: symlog, two-hot distributions over symlog-spaced bins, unimix
categoricals with straight-through samples, the bounded normal policy, KL balancing with
free bits, lambda-returns and the percentile return normaliser. Shapes: `...` is any
leading batch shape."""

from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F


def symlog(x: torch.Tensor) -> torch.Tensor:
    """symlog(x) = sign(x) ln(|x| + 1): compresses large magnitudes, identity near 0."""
    return torch.sign(x) * torch.log1p(x.abs())


def symexp(x: torch.Tensor) -> torch.Tensor:
    """symexp(x) = sign(x) (exp(|x|) - 1), the inverse of symlog."""
    return torch.sign(x) * torch.expm1(x.abs())


class TwoHot:
    """A distribution over real numbers by `bins` logits on bins evenly spaced in symlog
    space over [-bin_range, bin_range] (the reward head and the critic).

    A target y is encoded as two-hot weights on the two bins b_k <= symlog(y) < b_(k+1):
    w_k = (b_(k+1) - symlog(y)) / (b_(k+1) - b_k), w_(k+1) = 1 - w_k (targets outside the
    range go wholly to the end bin). The loss is the cross-entropy -sum_i w_i log p_i; the
    prediction is symexp(sum_i p_i b_i).
    """

    def __init__(self, bins: int = 255, bin_range: float = 20.0) -> None:
        self.bins = torch.linspace(-bin_range, bin_range, bins)

    def encode(self, y: torch.Tensor) -> torch.Tensor:
        """Two-hot weights (..., bins) of targets y (...)."""
        b = self.bins.to(y.device, y.dtype)
        x = symlog(y).clamp(b[0], b[-1])
        k = torch.searchsorted(b, x.contiguous(), right=True).clamp(1, len(b) - 1) - 1
        lo, hi = b[k], b[k + 1]
        w_hi = (x - lo) / (hi - lo)
        out = torch.zeros(*y.shape, len(b), device=y.device, dtype=y.dtype)
        out.scatter_(-1, k.unsqueeze(-1), (1.0 - w_hi).unsqueeze(-1))
        out.scatter_add_(-1, (k + 1).unsqueeze(-1), w_hi.unsqueeze(-1))
        return out

    def decode(self, weights: torch.Tensor) -> torch.Tensor:
        """symexp(sum_i w_i b_i) of weights or probabilities (..., bins) -> (...)."""
        return symexp(weights @ self.bins.to(weights.device, weights.dtype))

    def mean(self, logits: torch.Tensor) -> torch.Tensor:
        """The prediction symexp(E_p[b]) of logits (..., bins) -> (...)."""
        return self.decode(torch.softmax(logits.float(), -1))

    def log_prob(self, logits: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        """sum_i w_i(y) log softmax(logits)_i: logits (..., bins), y (...) -> (...)."""
        return (self.encode(y.float()) * F.log_softmax(logits.float(), -1)).sum(-1)


def unimix_logits(logits: torch.Tensor, unimix: float) -> torch.Tensor:
    """Log-probabilities of (1 - unimix) softmax(logits) + unimix / classes (last axis),
    in float32 whatever the logits' dtype (distributions stay float32 under bfloat16)."""
    logits = logits.float()
    if unimix <= 0:
        return F.log_softmax(logits, -1)
    probs = (1.0 - unimix) * torch.softmax(logits, -1) + unimix / logits.shape[-1]
    return torch.log(probs)


def sample_straight_through(log_probs: torch.Tensor) -> torch.Tensor:
    """A one-hot sample (..., classes) whose gradient is that of the probabilities:
    onehot + p - sg(p) (straight-through estimator)."""
    probs = log_probs.exp()
    # inverse-CDF sampling, one uniform number per latent: torch.multinomial draws an
    # exponential number per class and took a tenth of a cpu-preset gradient step
    u = torch.rand(probs.shape[:-1], device=probs.device, dtype=probs.dtype)
    cdf = probs.detach().cumsum(-1)
    idx = (cdf < u.unsqueeze(-1) * cdf[..., -1:]).sum(-1).clamp(max=probs.shape[-1] - 1)
    onehot = F.one_hot(idx, probs.shape[-1]).to(probs.dtype)
    return onehot + probs - probs.detach()


def mode_onehot(log_probs: torch.Tensor) -> torch.Tensor:
    """The most likely class of each categorical, one-hot (..., classes)."""
    return F.one_hot(log_probs.argmax(-1), log_probs.shape[-1]).to(log_probs.dtype)


def categorical_kl(log_p: torch.Tensor, log_q: torch.Tensor) -> torch.Tensor:
    """KL(p || q) = sum_c p_c (log p_c - log q_c) of categoricals (..., stoch, classes),
    summed over the `stoch` latent variables -> (...)."""
    return (log_p.exp() * (log_p - log_q)).sum((-2, -1))


def kl_losses(
    post: torch.Tensor, prior: torch.Tensor, free_nats: float
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """KL balancing with free bits, from log-probabilities (..., stoch, classes):

        dyn = max(free, KL(sg(post) || prior))    trains the prior (the dynamics)
        rep = max(free, KL(post || sg(prior)))    trains the posterior (the encoder)

    Returns (dyn, rep, the unclipped KL(post || prior)), each (...). Both terms have the
    same value; they differ in where the gradients flow. The clip is applied to each term
    on its own, so below `free` nats neither pulls the model (the official `free: 1.0`)."""
    dyn = categorical_kl(post.detach(), prior)
    rep = categorical_kl(post, prior.detach())
    return dyn.clamp(min=free_nats), rep.clamp(min=free_nats), dyn.detach()


class BoundedNormal:
    """The official "bounded normal" policy: N(tanh(m), s) with
    s = (max_std - min_std) sigmoid(raw + 2) + min_std, per action dim; the mode is
    tanh(m) and samples are clipped to [-1, 1] by the caller before they reach the env."""

    def __init__(self, out: torch.Tensor, min_std: float, max_std: float) -> None:
        m, raw = out.float().chunk(2, -1)
        self.mean = torch.tanh(m)
        self.std = (max_std - min_std) * torch.sigmoid(raw + 2.0) + min_std

    def rsample(self) -> torch.Tensor:
        """A reparameterised sample mean + std eps, eps ~ N(0, 1) (..., act_dim)."""
        return self.mean + self.std * torch.randn_like(self.mean)

    def mode(self) -> torch.Tensor:
        return self.mean

    def log_prob(self, a: torch.Tensor) -> torch.Tensor:
        """log N(a; mean, std) summed over action dims (...)."""
        z = (a - self.mean) / self.std
        return (-0.5 * z**2 - torch.log(self.std) - 0.5 * math.log(2 * math.pi)).sum(-1)

    def entropy(self) -> torch.Tensor:
        """sum_i log std_i + (1 + log 2 pi) / 2 (...)."""
        return (torch.log(self.std) + 0.5 * (1.0 + math.log(2 * math.pi))).sum(-1)


def lambda_returns(
    reward: torch.Tensor, cont: torch.Tensor, value: torch.Tensor, gamma: float, lam: float
) -> torch.Tensor:
    """lambda-returns of an imagined trajectory of H steps (time-major):

        R_t = r_(t+1) + gamma c_(t+1) ((1 - lam) v(s_(t+1)) + lam R_(t+1)),   R_H = v(s_H)

    reward (H, ...): r_(t+1), the reward on reaching s_(t+1); cont (H, ...): c_(t+1), the
    probability that the episode goes on at s_(t+1); value (H + 1, ...): v(s_0..s_H).
    Returns (H, ...)."""
    disc = gamma * cont
    interm = reward + disc * (1.0 - lam) * value[1:]
    out = [value[-1]]
    for t in reversed(range(len(reward))):
        out.append(interm[t] + disc[t] * lam * out[-1])
    return torch.stack(out[:0:-1])


class ReturnNormalizer(nn.Module):
    """The percentile return scale of DreamerV3: EMAs (decay, starting from 0) of the 5th
    and 95th percentiles of the imagined lambda-returns of each batch, and
    S = max(1, P95 - P5). Advantages are (R - v) / S: large returns are scaled down, small
    ones are not scaled up (so sparse rewards are not amplified noise). Buffers: saved in
    the state dict."""

    def __init__(self, decay: float = 0.99, low: float = 5.0, high: float = 95.0) -> None:
        super().__init__()
        self.decay, self.q = decay, (low / 100.0, high / 100.0)
        self.register_buffer("low", torch.zeros(()))
        self.register_buffer("high", torch.zeros(()))

    @torch.no_grad()
    def update(self, returns: torch.Tensor) -> None:
        """Fold the percentiles of a batch of returns into the EMAs."""
        x = returns.detach().float().flatten()
        lo, hi = torch.quantile(x, torch.tensor(self.q, device=x.device))
        self.low.mul_(self.decay).add_((1.0 - self.decay) * lo)
        self.high.mul_(self.decay).add_((1.0 - self.decay) * hi)

    def scale(self) -> torch.Tensor:
        """S = max(1, high - low)."""
        return torch.clamp(self.high - self.low, min=1.0)
