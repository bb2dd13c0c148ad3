"""Proximal Policy Optimisation (Schulman et al. 2017), clipped objective, GAE, one file.

The runner drives it: `act(obs)` then `process_step(...)` for `horizon` steps, then
`update(last_obs)`. Truncated episodes are bootstrapped from the value of
info["final_obs"]; terminated ones are not.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch

from rl.configs import PPOConfig
from rl.nets import ActorCritic, check_finite


def gae(
    rewards: torch.Tensor,
    values: torch.Tensor,
    next_values: torch.Tensor,
    terminated: torch.Tensor,
    done: torch.Tensor,
    gamma: float,
    lam: float,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Generalised advantage estimation over a rollout; every input is (T, N).

    next_values[t] is V of the state after step t in the same episode: V(obs_(t+1)), or
    V(final_obs_t) where the episode was truncated at t (ignored where terminated).
    terminated: no bootstrap at t; done = terminated | truncated: the recursion stops at t.
    Returns (advantages, returns), both (T, N).
    """
    adv = torch.zeros_like(rewards)
    last = torch.zeros_like(rewards[0])
    not_term = 1.0 - terminated.to(rewards.dtype)
    not_done = 1.0 - done.to(rewards.dtype)
    for t in reversed(range(rewards.shape[0])):
        # TD error: delta_t = r_t + gamma (1 - term_t) V(s'_t) - V(s_t)
        delta = rewards[t] + gamma * not_term[t] * next_values[t] - values[t]
        # A_t = delta_t + gamma lambda (1 - done_t) A_(t+1)
        last = delta + gamma * lam * not_done[t] * last
        adv[t] = last
    return adv, adv + values  # R_t = A_t + V(s_t): the value target


def bounds_loss(mean: torch.Tensor, soft_bound: float = 1.1) -> torch.Tensor:
    """E over the batch of sum_i max(|mu_i| - soft_bound, 0)^2: zero for means within the
    soft bound. mean (B, act_dim) -> a scalar."""
    excess = (mean.abs() - soft_bound).clamp_min(0.0)
    return excess.pow(2).sum(-1).mean()


class PPO:
    """PPO agent and its rollout storage for `num_envs` envs."""

    log_keys = (
        "policy_loss",
        "value_loss",
        "entropy",
        "approx_kl",
        "clip_fraction",
        "learning_rate",
        "action_std",
    )
    """What `update` reports (the runner's log columns)."""

    def __init__(
        self,
        obs_dim: int,
        act_dim: int,
        num_envs: int,
        cfg: PPOConfig,
        device: str | torch.device = "cpu",
    ) -> None:
        self.cfg = cfg.validate()
        self.device = torch.device(device)
        self.num_envs = num_envs
        self.net = ActorCritic(
            obs_dim,
            act_dim,
            cfg.hidden,
            cfg.init_log_std,
            cfg.normalize_obs,
            cfg.activation,
            cfg.obs_symlog_scale,
        ).to(self.device)
        self.opt = torch.optim.Adam(self.net.parameters(), lr=cfg.learning_rate, eps=1e-5)
        self.steps_per_iteration = cfg.horizon
        t, n = cfg.horizon, num_envs
        z = lambda *s: torch.zeros(*s, device=self.device)  # noqa: E731
        self.obs = z(t, n, obs_dim)
        self.actions = z(t, n, act_dim)
        self.logp = z(t, n)
        self.values = z(t, n)
        self.rewards = z(t, n)
        self.terminated = z(t, n)
        self.done = z(t, n)
        self.bootstrap = z(t, n)  # V(final_obs) where truncated, else 0
        self.truncated = z(t, n)
        self.step = 0
        self.updates = 0  # rollouts learned from: env steps = updates * horizon * num_envs

    def _t(self, a: np.ndarray | torch.Tensor) -> torch.Tensor:
        if isinstance(a, torch.Tensor):  # an env on the device (rl/host_view.py)
            return a.to(self.device, torch.float32)
        return torch.as_tensor(np.asarray(a, dtype=np.float32), device=self.device)

    @staticmethod
    def _out(a: torch.Tensor, like: np.ndarray | torch.Tensor) -> np.ndarray | torch.Tensor:
        """Actions as the observations came: a tensor stays on the device, else numpy."""
        a = a.clamp(-1.0, 1.0)
        return a if isinstance(like, torch.Tensor) else a.cpu().numpy()

    @torch.no_grad()
    def act(self, obs: np.ndarray) -> np.ndarray:
        """Sample actions for obs (N, obs_dim) and store them; returns (N, act_dim) in [-1, 1]
        (a tensor on the agent's device when obs is a tensor)."""
        o = self._t(obs)
        mean, std = self.net.dist(o)
        a = mean + std * torch.randn_like(mean)
        k = self.step
        self.obs[k], self.actions[k] = o, a
        self.logp[k] = self.net.log_prob(mean, std, a)
        self.values[k] = self.net.value(o)
        return self._out(a, obs)

    @torch.no_grad()
    def policy(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """Actions (N, act_dim) in [-1, 1] for obs (N, obs_dim), without storing anything."""
        mean, std = self.net.dist(self._t(obs))
        a = mean if deterministic else mean + std * torch.randn_like(mean)
        return self._out(a, obs)

    @torch.no_grad()
    def process_step(
        self,
        next_obs: np.ndarray,
        reward: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        info: dict[str, Any],
    ) -> None:
        """Store the outcome (N,) of the step whose actions `act` just returned (next_obs
        is not needed: the next `act` stores it, `update` gets the last one)."""
        del next_obs
        k = self.step
        self.rewards[k] = self._t(reward) * self.cfg.reward_scale
        term, trunc = self._t(terminated), self._t(truncated) * (1 - self._t(terminated))
        self.terminated[k], self.truncated[k] = term, trunc
        self.done[k] = torch.maximum(term, trunc)
        self.bootstrap[k] = 0.0
        if trunc.any():
            idx = trunc.bool()
            self.bootstrap[k, idx] = self.net.value(self._t(info["final_obs"])[idx])
        self.step += 1

    @torch.no_grad()
    def compute_returns(self, last_obs: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
        """(advantages, returns), each (horizon, N), of the stored rollout; last_obs
        (N, obs_dim) is the observation after its last step."""
        cfg = self.cfg
        if self.step != cfg.horizon:
            raise RuntimeError(f"the rollout has {self.step} of its {cfg.horizon} steps")
        # V of the state after step t: V(obs_(t+1)), V(last_obs) after the last step, and
        # V(final_obs_t) where the episode was truncated at t
        next_values = torch.cat([self.values[1:], self.net.value(self._t(last_obs))[None]])
        next_values = torch.where(self.truncated.bool(), self.bootstrap, next_values)
        return gae(
            self.rewards,
            self.values,
            next_values,
            self.terminated,
            self.done,
            cfg.gamma,
            cfg.gae_lambda,
        )

    def update(self, last_obs: np.ndarray) -> dict[str, float]:
        """GAE on the full rollout, then `epochs` passes of minibatch updates. Returns mean
        losses and diagnostics. Raises NonFiniteLossError on a NaN/inf loss."""
        cfg = self.cfg
        adv, ret = self.compute_returns(last_obs)
        self.step = 0
        b = cfg.horizon * self.num_envs
        obs = self.obs.reshape(b, -1)
        actions = self.actions.reshape(b, -1)
        old_logp, adv, ret = self.logp.reshape(b), adv.reshape(b), ret.reshape(b)
        adv = (adv - adv.mean()) / (adv.std() + 1e-8)
        mb = min(cfg.minibatch_size, b)
        sums = {
            "policy_loss": 0.0,
            "value_loss": 0.0,
            "entropy": 0.0,
            "approx_kl": 0.0,
            "clip_fraction": 0.0,
        }
        n_updates = 0
        for _ in range(cfg.epochs):
            perm = torch.randperm(b, device=self.device)
            for start in range(0, b - mb + 1, mb):
                i = perm[start : start + mb]
                mean, std = self.net.dist(obs[i])
                logp = self.net.log_prob(mean, std, actions[i])
                log_ratio = logp - old_logp[i]
                ratio = log_ratio.exp()
                # L_clip = -E[min(r A, clip(r, 1 - eps, 1 + eps) A)]
                pg = -torch.min(
                    ratio * adv[i], ratio.clamp(1 - cfg.clip, 1 + cfg.clip) * adv[i]
                ).mean()
                # L_V = E[(R - V(s))^2]
                v_loss = (ret[i] - self.net.value(obs[i])).pow(2).mean()
                entropy = self.net.entropy(std)
                loss = pg + cfg.value_coef * v_loss - cfg.entropy_coef * entropy
                if cfg.bounds_loss_coef > 0:
                    loss = loss + cfg.bounds_loss_coef * bounds_loss(mean)
                check_finite("PPO", loss, policy_loss=pg, value_loss=v_loss)
                self.opt.zero_grad(set_to_none=True)
                loss.backward()
                torch.nn.utils.clip_grad_norm_(self.net.parameters(), cfg.max_grad_norm)
                self.opt.step()
                with torch.no_grad():
                    # KL(old || new) ~ E[(r - 1) - log r] (Schulman's low-variance estimator)
                    kl = ((ratio - 1) - log_ratio).mean().item()
                    clipped = ((ratio - 1).abs() > cfg.clip).float().mean().item()
                if cfg.desired_kl is not None:
                    self._adapt_lr(kl)
                for k, v in zip(
                    sums, (pg.item(), v_loss.item(), entropy.item(), kl, clipped), strict=True
                ):
                    sums[k] += v
                n_updates += 1
        self.net.obs_norm.update(self.net.encode(obs))  # statistics change between rollouts only
        self.updates += 1
        cap = cfg.std_cap(self.updates * b)
        if cap is not None:  # the parameter itself is capped: checkpoints carry the std used
            with torch.no_grad():
                self.net.log_std.clamp_(max=math.log(cap))
        out = {k: v / n_updates for k, v in sums.items()}
        out["learning_rate"] = self.opt.param_groups[0]["lr"]
        out["action_std"] = self.net.log_std.exp().mean().item()
        return out

    def _adapt_lr(self, kl: float) -> None:
        lr = self.opt.param_groups[0]["lr"]
        if kl > 2.0 * self.cfg.desired_kl:
            lr = max(1e-5, lr / 1.5)
        elif kl < 0.5 * self.cfg.desired_kl:
            lr = min(1e-2, lr * 1.5)
        for g in self.opt.param_groups:
            g["lr"] = lr

    # ---------------------------------------------------------------- checkpoints

    def modules(self) -> dict[str, torch.nn.Module | torch.optim.Optimizer]:
        """What a checkpoint holds (name -> module or optimizer)."""
        return {"net": self.net, "opt": self.opt}

    def extra_state(self) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
        """(tensors, JSON-able values) beyond the modules: the rollouts learned from (the std
        cap's clock); rollouts end at iteration boundaries, so no storage."""
        return {}, {"updates": self.updates}

    def load_extra_state(self, tensors: dict[str, torch.Tensor], values: dict[str, Any]) -> None:
        del tensors
        self.updates = int(values.get("updates", 0))  # checkpoints before the std cap: 0
