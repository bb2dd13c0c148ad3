"""Soft Actor-Critic (Haarnoja et al. 2018): twin Q, Polyak-averaged targets, fixed or
learned entropy temperature, a replay buffer and a uniform-random warm-up. One file; its
optional n-step returns (`n_step`) keep their window in rl/nstep.py.

With a teacher (`set_teacher`, e.g. the scripted expert: `assetgen train --demos scripted`)
the warm-up is played by the teacher instead (its episodes are the demonstrations the buffer
starts from), every stored observation is labelled with the teacher's action, and the actor
loss gains a behaviour-cloning term on the deterministic action, scaled like TD3+BC's (by the
batch's mean |Q|, so its weight does not depend on the reward's scale) and decayed linearly
to zero over `bc_decay_steps`: RL then takes over from a policy that already inserts.

The runner drives it: `act(obs)` then `process_step(...)` every env step (which stores the
transitions and runs the gradient steps); `update(last_obs)` at iteration boundaries only
reports the mean losses since the last call.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import torch

from rl.configs import SACConfig
from rl.exploration import ColoredNoise
from rl.nets import QNetwork, SquashedGaussianActor, check_finite
from rl.nstep import NStepWindow


def soft_target(
    reward: torch.Tensor,
    terminated: torch.Tensor,
    next_q1: torch.Tensor,
    next_q2: torch.Tensor,
    next_logp: torch.Tensor,
    gamma: float | torch.Tensor,
    alpha: float | torch.Tensor,
) -> torch.Tensor:
    """The soft Bellman target, all inputs (B,), a' ~ pi(. | s'):
    y = r + gamma (1 - terminated) (min(Q1'(s', a'), Q2'(s', a')) - alpha log pi(a' | s')).
    With n-step returns r is the n-step return and gamma the transition's own gamma^k."""
    soft_v = torch.min(next_q1, next_q2) - alpha * next_logp
    return reward + gamma * (1.0 - terminated) * soft_v


@torch.no_grad()
def q_filter(
    q1: torch.nn.Module,
    q2: torch.nn.Module,
    obs: torch.Tensor,
    teacher_action: torch.Tensor,
    action: torch.Tensor,
) -> torch.Tensor:
    """(B,) 1.0 where min(Q1, Q2) rates the teacher's action strictly above `action`, else
    0.0: the samples a Q-filtered BC term imitates."""
    q_t = torch.min(q1(obs, teacher_action), q2(obs, teacher_action))
    q_a = torch.min(q1(obs, action), q2(obs, action))
    return (q_t > q_a).float()


class ReplayBuffer:
    """A ring of transitions (obs, action, reward, next_obs, terminated) on `device`.

    next_obs is info["final_obs"] where an episode ended, so truncated transitions are
    bootstrapped and terminated ones are not. Memory is taken at the first `add` or `load`
    (an agent loaded only to act never allocates it): capacity * (2 obs_dim + act_dim + 2)
    float32 values.
    """

    def __init__(
        self,
        capacity: int,
        obs_dim: int,
        act_dim: int,
        device: torch.device,
        teacher: bool = False,
        discount: bool = False,
    ) -> None:
        self.capacity, self.device = capacity, device
        self.shapes = {"obs": (obs_dim,), "action": (act_dim,), "reward": (),
                       "next_obs": (obs_dim,), "terminated": ()}  # fmt: skip
        if teacher:  # the teacher's action at obs, for the BC term
            self.shapes["teacher_action"] = (act_dim,)
        if discount:  # gamma^k of an n-step transition, k its number of rewards
            self.shapes["discount"] = ()
        self.data: dict[str, torch.Tensor] = {}
        self.pos = 0
        self.size = 0

    def _allocate(self) -> None:
        if not self.data:
            self.data = {
                k: torch.empty(self.capacity, *s, device=self.device)
                for k, s in self.shapes.items()
            }

    def add(self, **batch: torch.Tensor) -> None:
        """Append a batch (n, ...) of each field, overwriting the oldest when full."""
        self._allocate()
        n = len(batch["reward"])
        idx = ((self.pos + torch.arange(n)) % self.capacity).to(self.device)
        for k, v in batch.items():
            self.data[k][idx] = v
        self.pos = (self.pos + n) % self.capacity
        self.size = min(self.size + n, self.capacity)

    def sample(self, n: int) -> dict[str, torch.Tensor]:
        """n transitions drawn uniformly with replacement (torch's global CPU RNG)."""
        idx = torch.randint(0, self.size, (n,)).to(self.device)
        return {k: v[idx] for k, v in self.data.items()}

    def state(self) -> tuple[dict[str, torch.Tensor], dict[str, int]]:
        """(the filled part of every field, the counters) for a checkpoint."""
        counters = {"pos": self.pos, "size": self.size}
        return {k: v[: self.size] for k, v in self.data.items()}, counters

    def load(self, tensors: dict[str, torch.Tensor], counters: dict[str, int]) -> None:
        size = counters["size"]
        if size > self.capacity:
            raise ValueError(f"a buffer of {size} transitions does not fit {self.capacity}")
        if size:
            self._allocate()
        for k, v in tensors.items():
            self.data[k][:size] = v
        self.pos, self.size = counters["pos"], size


class SAC:
    """SAC agent with its replay buffer, for `num_envs` envs."""

    log_keys = (
        "q_loss",
        "policy_loss",
        "entropy",
        "q_mean",
        "q_grad_norm",
        "pi_grad_norm",
        "alpha",
        "buffer_size",
        "bc_loss",
        "bc_weight",
        "bc_kept",
    )
    """What `update` reports (the runner's log columns)."""

    def __init__(
        self,
        obs_dim: int,
        act_dim: int,
        num_envs: int,
        cfg: SACConfig,
        device: str | torch.device = "cpu",
    ) -> None:
        self.cfg = cfg.validate()
        self.device = torch.device(device)
        self.num_envs, self.act_dim = num_envs, act_dim
        h, f, ln, k = cfg.hidden, cfg.activation, cfg.layer_norm, cfg.obs_symlog_scale
        self.actor = SquashedGaussianActor(obs_dim, act_dim, h, f, ln, k).to(self.device)
        self.q1 = QNetwork(obs_dim, act_dim, h, f, ln, k).to(self.device)
        self.q2 = QNetwork(obs_dim, act_dim, h, f, ln, k).to(self.device)
        self.q1_target, self.q2_target = copy.deepcopy(self.q1), copy.deepcopy(self.q2)
        for p in [*self.q1_target.parameters(), *self.q2_target.parameters()]:
            p.requires_grad_(False)
        self.log_alpha = torch.tensor(
            float(np.log(cfg.entropy_coef)), device=self.device, requires_grad=cfg.learn_entropy
        )
        self.target_entropy = -float(act_dim) if cfg.target_entropy is None else cfg.target_entropy
        lr = cfg.learning_rate
        self.actor_opt = torch.optim.Adam(self.actor.parameters(), lr=lr, foreach=True)
        self.q_opt = torch.optim.Adam(
            [*self.q1.parameters(), *self.q2.parameters()], lr=lr, foreach=True
        )
        self.alpha_opt = torch.optim.Adam([self.log_alpha], lr=lr, foreach=True)
        self.buffer = ReplayBuffer(
            cfg.buffer_size, obs_dim, act_dim, self.device, discount=cfg.n_step > 1
        )
        self.nstep = NStepWindow(cfg.n_step, cfg.gamma, num_envs) if cfg.n_step > 1 else None
        self.noise: ColoredNoise | None = None
        if cfg.exploration == "pink":
            # seeded from torch's generator, which the run seeds, so the seed fixes it too
            seed = int(torch.randint(0, 2**31 - 1, ()).item())
            self.noise = ColoredNoise(num_envs, act_dim, cfg.noise_period, 1.0, seed)
        self.teacher: Callable[[np.ndarray], np.ndarray] | None = None
        self._teacher_action: torch.Tensor | None = None
        self.steps_per_iteration = cfg.steps_per_iteration
        self.env_steps = 0  # transitions collected, summed over envs
        self.grad_steps = 0
        self._credit = 0.0  # gradient steps owed (fractional gradient_steps accumulate)
        self._obs: torch.Tensor | None = None
        self._action: torch.Tensor | None = None
        self._online_params = [*self.q1.parameters(), *self.q2.parameters()]
        self._actor_params = list(self.actor.parameters())
        self._target_params = [*self.q1_target.parameters(), *self.q2_target.parameters()]
        self._sums: dict[str, torch.Tensor] = {}
        self._n_sums = 0

    def _t(self, a: np.ndarray) -> torch.Tensor:
        return torch.as_tensor(np.asarray(a, dtype=np.float32), device=self.device)

    def set_teacher(self, teacher: Callable[[np.ndarray], np.ndarray]) -> None:
        """Learn from `teacher` (obs (N, obs_dim) -> actions (N, act_dim) in [-1, 1]): it
        plays the warm-up and labels every stored observation for the BC term. Call before
        the first step (or before loading a checkpoint made with a teacher)."""
        if self.buffer.size:
            raise RuntimeError("set_teacher must be called before any transition is stored")
        self.teacher = teacher
        cfg = self.cfg
        self.buffer = ReplayBuffer(
            cfg.buffer_size,
            self.buffer.shapes["obs"][0],
            self.act_dim,
            self.device,
            True,
            discount=cfg.n_step > 1,
        )

    def bc_weight(self) -> float:
        """The BC term's weight now: bc_weight decayed linearly to 0 over bc_decay_steps
        (0 without a teacher)."""
        cfg = self.cfg
        if self.teacher is None or cfg.bc_weight == 0:
            return 0.0
        if cfg.bc_decay_steps == 0:
            return cfg.bc_weight
        return cfg.bc_weight * max(0.0, 1.0 - self.env_steps / cfg.bc_decay_steps)

    @property
    def alpha(self) -> torch.Tensor:
        return self.log_alpha.detach().exp()

    @torch.no_grad()
    def act(self, obs: np.ndarray) -> np.ndarray:
        """Actions (N, act_dim) in [-1, 1] for obs (N, obs_dim): during warm-up uniform, or
        the teacher's with noise; after it sampled from the policy."""
        o = self._t(obs)
        teach = self._t(self.teacher(obs)) if self.teacher is not None else None
        if self.env_steps >= self.cfg.warmup_steps:
            eps = None if self.noise is None else self._t(self.noise.sample())
            a, _ = self.actor(o, noise=eps)
        elif teach is None:
            a = torch.rand(len(o), self.act_dim, device=self.device) * 2.0 - 1.0
        else:
            noise = self.cfg.teacher_noise * torch.randn_like(teach)
            a = (teach + noise).clamp(-1.0, 1.0)
        self._obs, self._action, self._teacher_action = o, a, teach
        return a.cpu().numpy()

    @torch.no_grad()
    def policy(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """Actions (N, act_dim) for obs (N, obs_dim): tanh(mean) when deterministic."""
        return self.actor(self._t(obs), deterministic)[0].cpu().numpy()

    def process_step(
        self,
        next_obs: np.ndarray,
        reward: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        info: dict[str, Any],
    ) -> None:
        """Store the N transitions of the last `act`, then run the gradient steps owed."""
        done = np.asarray(terminated) | np.asarray(truncated)
        nxt = np.where(done[:, None], info["final_obs"], next_obs)
        assert self._obs is not None and self._action is not None, "call act() first"
        at_obs = {
            "obs": self._obs,
            "action": self._action,
            **({} if self._teacher_action is None else {"teacher_action": self._teacher_action}),
        }
        r, term = self._t(reward) * self.cfg.reward_scale, self._t(terminated)
        if self.nstep is None:
            self.buffer.add(**at_obs, reward=r, next_obs=self._t(nxt), terminated=term)
        else:
            done_t = torch.as_tensor(done, device=self.device)
            batch = self.nstep.push(at_obs, r, self._t(nxt), term, done_t)
            if batch is not None:
                self.buffer.add(**batch)
        self.env_steps += len(reward)
        if self.env_steps < max(self.cfg.warmup_steps, self.cfg.batch_size):
            return
        self._credit += self.cfg.gradient_steps
        while self._credit >= 1.0:
            self._credit -= 1.0
            self._gradient_step()

    def _gradient_step(self) -> None:
        cfg = self.cfg
        b = self.buffer.sample(cfg.batch_size)
        alpha = self.alpha
        with torch.no_grad():
            next_a, next_logp = self.actor(b["next_obs"])
            y = soft_target(
                b["reward"],
                b["terminated"],
                self.q1_target(b["next_obs"], next_a),
                self.q2_target(b["next_obs"], next_a),
                next_logp,
                b.get("discount", cfg.gamma),
                alpha,
            )
        # L_Q = E[(Q1(s, a) - y)^2 + (Q2(s, a) - y)^2]
        q1, q2 = self.q1(b["obs"], b["action"]), self.q2(b["obs"], b["action"])
        q_loss = (q1 - y).pow(2).mean() + (q2 - y).pow(2).mean()
        check_finite("SAC critic", q_loss, q1=q1.mean(), target=y.mean())
        self.q_opt.zero_grad(set_to_none=True)
        q_loss.backward()
        q_norm = self._clip(self._online_params)
        self.q_opt.step()

        # L_pi = E[alpha log pi(a|s) - min(Q1, Q2)(s, a)], a ~ pi(.|s) reparameterised;
        # the critics are frozen meanwhile (no weight gradients to compute for them)
        self._critics_grad(False)
        a, logp = self.actor(b["obs"])
        q = torch.min(self.q1(b["obs"], a), self.q2(b["obs"], a))
        pi_loss = (alpha * logp - q).mean()
        bc_w = self.bc_weight()
        bc_loss = torch.zeros((), device=self.device)
        if bc_w > 0:
            # TD3+BC's scaling: the BC term weighs bc_w relative to the typical |Q|, and it
            # pulls the deterministic action (the one evaluated) towards the teacher's
            mean_action, _ = self.actor(b["obs"], True)
            sq = (mean_action - b["teacher_action"]).pow(2).sum(-1)
            if cfg.bc_filter:
                # Q filter (Nair et al. 2018): imitate only where the critics rate the
                # teacher's action above the policy's, so RL may leave a slower teacher
                keep = q_filter(self.q1, self.q2, b["obs"], b["teacher_action"], mean_action)
                self._sums["bc_kept"] = self._sums.get("bc_kept", 0.0) + keep.mean()
                sq = sq * keep
            bc_loss = sq.mean()
            pi_loss = pi_loss + bc_w * q.abs().mean().detach() * bc_loss
        check_finite("SAC actor", pi_loss, log_pi=logp.mean(), q=q.mean())
        self.actor_opt.zero_grad(set_to_none=True)
        pi_loss.backward()
        pi_norm = self._clip(self._actor_params)
        self.actor_opt.step()
        self._critics_grad(True)

        if cfg.learn_entropy:
            # L_alpha = E[-log alpha (log pi(a|s) + H_target)]
            alpha_loss = -(self.log_alpha * (logp.detach() + self.target_entropy)).mean()
            self.alpha_opt.zero_grad(set_to_none=True)
            alpha_loss.backward()
            self.alpha_opt.step()

        with torch.no_grad():  # theta' <- theta' + tau (theta - theta')
            torch._foreach_lerp_(self._target_params, self._online_params, cfg.tau)
        self.grad_steps += 1
        for k, v in (
            ("q_loss", q_loss),
            ("policy_loss", pi_loss),
            ("entropy", -logp.mean()),
            ("q_mean", q1.mean()),
            ("q_grad_norm", q_norm),
            ("pi_grad_norm", pi_norm),
            ("bc_loss", bc_loss),
        ):
            self._sums[k] = self._sums.get(k, 0.0) + v.detach()  # .item() once per iteration
        self._n_sums += 1

    def _clip(self, params: list[torch.nn.Parameter]) -> torch.Tensor:
        """The gradients' total norm, after scaling them to at most `max_grad_norm`."""
        limit = self.cfg.max_grad_norm
        return torch.nn.utils.clip_grad_norm_(params, math.inf if limit is None else limit)

    def _critics_grad(self, on: bool) -> None:
        for p in self._online_params:
            p.requires_grad_(on)

    def update(self, last_obs: np.ndarray) -> dict[str, float]:
        """Mean losses of the gradient steps since the last call (SAC learns every step)."""
        del last_obs
        out = {k: float(v) / self._n_sums for k, v in self._sums.items()} if self._n_sums else {}
        out["alpha"] = self.alpha.item()
        out["buffer_size"] = float(self.buffer.size)
        out["bc_weight"] = self.bc_weight()
        self._sums, self._n_sums = {}, 0
        return out

    # ---------------------------------------------------------------- checkpoints

    def modules(self) -> dict[str, torch.nn.Module | torch.optim.Optimizer]:
        """What a checkpoint holds (name -> module or optimizer)."""
        return {
            "actor": self.actor,
            "q1": self.q1,
            "q2": self.q2,
            "q1_target": self.q1_target,
            "q2_target": self.q2_target,
            "actor_opt": self.actor_opt,
            "q_opt": self.q_opt,
            "alpha_opt": self.alpha_opt,
        }

    def extra_state(self) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
        """(tensors, JSON-able values) beyond the modules: the temperature, the filled replay
        buffer and the counters."""
        data, counters = self.buffer.state()
        tensors = {
            "log_alpha": self.log_alpha.detach(),
            **{f"buffer/{k}": v for k, v in data.items()},
            **({} if self.nstep is None else
               {f"nstep/{k}": v for k, v in self.nstep.state().items()}),
        }  # fmt: skip
        values = {
            "buffer": counters,
            "env_steps": self.env_steps,
            "grad_steps": self.grad_steps,
            "credit": self._credit,
        }
        if self.noise is not None:
            tensors["noise/buffer"], values["noise"] = self.noise.state()
        return tensors, values

    def load_extra_state(self, tensors: dict[str, torch.Tensor], values: dict[str, Any]) -> None:
        with torch.no_grad():
            self.log_alpha.copy_(tensors["log_alpha"])
        data = {k.removeprefix("buffer/"): v for k, v in tensors.items() if k.startswith("buffer/")}
        self.buffer.load(data, values["buffer"])
        if self.nstep is not None:
            window = {k[6:]: v for k, v in tensors.items() if k.startswith("nstep/")}
            self.nstep.load_state(window)
        self.env_steps, self.grad_steps = values["env_steps"], values["grad_steps"]
        self._credit = values["credit"]
        if self.noise is not None:
            self.noise.load_state(tensors["noise/buffer"], values["noise"])
