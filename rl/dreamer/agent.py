"""The DreamerV3 agent the runner drives (rl/agents.py's Agent protocol), for N envs.

Every env step: `act(obs)` updates each env's recurrent state (h, z, previous action) with
the new observation (one batched posterior step for all envs) and draws the actions
(uniform during the warm-up); `process_step(...)` stores the step in the replay, resets
the recurrent state where an episode ended (terminated or truncated) and runs the gradient
steps owed: train_ratio replayed steps per env step, i.e. env_steps * train_ratio /
(batch_size * batch_length) gradient steps, fractions accumulating. A gradient step trains
the world model on a replayed batch, then the actor and the critic on trajectories imagined
from its posterior states. `update(last_obs)` only reports the mean metrics.

`reset(mask)` starts new episodes where mask (N,) is True: the runner calls it after it
resets the env, evaluation/protocol.py after each step, so a recurrent policy never carries one
episode's state into the next.

With a teacher (`set_teacher`, e.g. `assetgen train --algo dreamer --demos scripted-fast`)
the warm-up is played by the teacher instead of uniform actions, so the replay (which keeps
them: uniform sampling over everything stored) starts with successful episodes that the
world model learns the task's rewards from; with `bc_weight` > 0 the actor is also pulled
towards the teacher's actions on replayed states (an addition to the published algorithm).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import torch

from rl.dreamer.actor_critic import ActorCritic
from rl.dreamer.config import DreamerConfig
from rl.dreamer.replay import SequenceReplay
from rl.dreamer.world_model import State, WorldModel
from rl.nets import check_finite


class Dreamer:
    """DreamerV3: world model, actor-critic, sequence replay and per-env recurrent state."""

    log_keys = (
        "model_loss",
        "obs_loss",
        "reward_loss",
        "cont_loss",
        "dyn_loss",
        "rep_loss",
        "kl",
        "post_entropy",
        "actor_loss",
        "bc_loss",
        "critic_loss",
        "actor_entropy",
        "return_scale",
        "imag_return",
        "value_mean",
        "model_grad_norm",
        "actor_grad_norm",
        "critic_grad_norm",
        "grad_steps",
        "replay_steps",
    )
    """What `update` reports (the runner's log columns)."""

    def __init__(
        self,
        obs_dim: int,
        act_dim: int,
        num_envs: int,
        cfg: DreamerConfig,
        device: str | torch.device = "cpu",
        seed: int = 0,
    ) -> None:
        self.cfg = cfg.validate()
        self.device = torch.device(device)
        self.num_envs, self.act_dim = num_envs, act_dim
        self.wm = WorldModel(cfg, obs_dim, act_dim).to(self.device)
        self.ac = ActorCritic(cfg, self.wm.feat_dim, act_dim).to(self.device)
        self.model_opt = torch.optim.Adam(self.wm.parameters(), cfg.model_lr, eps=cfg.model_eps)
        self.actor_opt = torch.optim.Adam(self.ac.actor.parameters(), cfg.actor_lr, eps=cfg.ac_eps)
        self.critic_opt = torch.optim.Adam(
            self.ac.critic.parameters(), cfg.critic_lr, eps=cfg.ac_eps
        )
        self.replay = SequenceReplay(cfg.replay_capacity, num_envs, obs_dim, act_dim)
        self.rng = np.random.default_rng(seed)  # replay sampling
        self.steps_per_iteration = cfg.steps_per_iteration
        self.env_steps = 0  # summed over envs
        self.grad_steps = 0
        self._credit = 0.0  # gradient steps owed
        self.teacher: Callable[[np.ndarray], np.ndarray] | None = None
        self._sums: dict[str, torch.Tensor] = {}
        self._n_sums = 0
        self._init_state(num_envs)

    def acting_state(self) -> dict[str, np.ndarray]:
        """A copy of the per-env acting state as arrays: the recurrent state (deter, stoch),
        the previous action and the first-step flags; for `load_acting_state` after another
        use of the policy (evaluation/probe.py) or in a resumed evaluation
        (evaluation/snapshots.py)."""
        st = self.state
        return {
            "deter": st.deter.cpu().numpy().copy(),
            "stoch": st.stoch.cpu().numpy().copy(),
            "prev_action": self.prev_action.cpu().numpy().copy(),
            "first": self.first.copy(),
        }

    def load_acting_state(self, saved: dict[str, np.ndarray]) -> None:
        """Restore what `acting_state` returned (any number of envs)."""
        # copies: the state is written in place (reset) and `saved` may be restored again
        own = {k: self._t(np.array(saved[k], dtype=np.float32)) for k in ("deter", "stoch")}
        self.state = State(own["deter"], own["stoch"])
        self.prev_action = self._t(np.array(saved["prev_action"], dtype=np.float32))
        self.first = np.asarray(saved["first"], dtype=bool).copy()

    def set_teacher(self, teacher: Callable[[np.ndarray], np.ndarray]) -> None:
        """Let `teacher` (obs (N, obs_dim) -> actions (N, act_dim) in [-1, 1]) play the
        warm-up, with Gaussian noise of std `teacher_noise`. Call before the first step."""
        if self.env_steps:
            raise RuntimeError("set_teacher must be called before the first step")
        self.teacher = teacher

    def _t(self, a: np.ndarray) -> torch.Tensor:
        return torch.as_tensor(np.asarray(a, dtype=np.float32), device=self.device)

    # ---------------------------------------------------------------- recurrent state

    @torch.no_grad()
    def _init_state(self, n: int) -> None:
        """Every env at the initial state, about to see an episode's first observation."""
        self.state = self.wm.rssm.initial(n)
        self.state = State(self.state.deter.clone(), self.state.stoch.clone())
        self.prev_action = torch.zeros(n, self.act_dim, device=self.device)
        self.first = np.ones(n, dtype=bool)

    @torch.no_grad()
    def reset(self, mask: np.ndarray) -> None:
        """New episodes start where mask (N,) is True: their recurrent state becomes the
        initial state and their previous action zero; other envs keep theirs. A mask of
        another length than the current state restarts every env (e.g. an evaluation with
        another number of envs)."""
        mask = np.asarray(mask, dtype=bool)
        if len(mask) != len(self.first):
            self._init_state(len(mask))
            return
        if not mask.any():
            return
        m = torch.as_tensor(mask, device=self.device)
        init = self.wm.rssm.initial(int(m.sum()))
        self.state.deter[m] = init.deter
        self.state.stoch[m] = init.stoch
        self.prev_action[m] = 0.0
        self.first |= mask

    @torch.no_grad()
    def _observe(self, obs: np.ndarray) -> torch.Tensor:
        """Fold observations (N, obs_dim) into the recurrent state (one posterior step for
        every env); returns the features [h, z] (N, F) the actor reads."""
        if len(obs) != len(self.first):
            self._init_state(len(obs))
        first = torch.as_tensor(self.first, device=self.device)
        post, _ = self.wm.rssm.obs_step(
            self.state, self.prev_action, self.wm.embed(self._t(obs)), first, with_prior=False
        )
        self.state = State(post.deter, post.stoch)
        self.first[:] = False
        return post.feat()

    # ---------------------------------------------------------------- acting

    @torch.no_grad()
    def act(self, obs: np.ndarray) -> np.ndarray:
        """Actions (N, act_dim) in [-1, 1]: uniform during the warm-up, else sampled from
        the policy. The first observation of each new episode is stored here."""
        first = np.flatnonzero(self.first)
        if len(first):
            k = len(first)
            self.replay.add(first, obs=np.asarray(obs)[first],
                            prev_action=np.zeros((k, self.act_dim), np.float32),
                            reward=np.zeros(k, np.float32), is_first=np.ones(k, bool),
                            is_terminal=np.zeros(k, bool))  # fmt: skip
        feat = self._observe(obs)
        if self.env_steps < self.cfg.warmup_steps and self.teacher is not None:
            a = self._t(self.teacher(np.asarray(obs)))
            a = (a + self.cfg.teacher_noise * torch.randn_like(a)).clamp(-1.0, 1.0)
        elif self.env_steps < self.cfg.warmup_steps:
            a = torch.rand(len(obs), self.act_dim, device=self.device) * 2.0 - 1.0
        else:
            a = self.ac.actor(feat).rsample().clamp(-1.0, 1.0)
        self.prev_action = a
        return a.cpu().numpy()

    @torch.no_grad()
    def policy(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """Actions (N, act_dim) for obs (N, obs_dim), carrying the recurrent state from call
        to call (call `reset(mask)` where episodes end): the mean tanh(m) when
        deterministic, else a sample. The latent z is sampled either way, as the official
        policy does."""
        dist = self.ac.actor(self._observe(obs))
        a = dist.mode() if deterministic else dist.rsample().clamp(-1.0, 1.0)
        self.prev_action = a
        return a.cpu().numpy()

    def process_step(
        self,
        next_obs: np.ndarray,
        reward: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        info: dict[str, Any],
    ) -> None:
        """Store the step (the finished episode's last observation where one ended), reset
        the recurrent state there, then run the gradient steps owed."""
        terminated, truncated = np.asarray(terminated), np.asarray(truncated)
        done = terminated | truncated
        n = len(done)
        obs = np.where(done[:, None], info["final_obs"], next_obs) if done.any() else next_obs
        self.replay.add(np.arange(n), obs=obs, prev_action=self.prev_action.cpu().numpy(),
                        reward=np.asarray(reward, np.float32) * np.float32(self.cfg.reward_scale),
                        is_first=np.zeros(n, bool),
                        is_terminal=terminated)  # fmt: skip
        self.env_steps += n
        self.reset(done)
        cfg = self.cfg
        if self.env_steps < cfg.warmup_steps or not self.replay.can_sample(cfg.batch_length):
            return
        self._credit += n * cfg.train_ratio / (cfg.batch_size * cfg.batch_length)
        while self._credit >= 1.0:
            self._credit -= 1.0
            self._train_step()

    # ---------------------------------------------------------------- learning

    def _autocast(self) -> torch.autocast:
        """The gradient steps' compute dtype (DreamerConfig.compute_dtype)."""
        bf16 = self.cfg.compute_dtype == "bfloat16"
        return torch.autocast(self.device.type, dtype=torch.bfloat16, enabled=bf16)

    def _batch(self) -> dict[str, torch.Tensor]:
        b = self.replay.sample(self.cfg.batch_size, self.cfg.batch_length, self.rng)
        return {k: torch.as_tensor(v, device=self.device) for k, v in b.items()}

    def _train_step(self) -> None:
        cfg = self.cfg
        batch = self._batch()
        with self._autocast():
            model_loss, post, metrics = self.wm.loss(batch)
        check_finite("Dreamer world model", model_loss, **metrics)
        self.model_opt.zero_grad(set_to_none=True)
        model_loss.backward()
        metrics["model_grad_norm"] = torch.nn.utils.clip_grad_norm_(
            self.wm.parameters(), cfg.model_clip
        )
        self.model_opt.step()

        # imagination starts from every replayed posterior state, detached
        d, s, c = cfg.deter, cfg.stoch, cfg.classes
        start = State(post.deter.detach().reshape(-1, d), post.stoch.detach().reshape(-1, s, c),
                      post.logits.detach().reshape(-1, s, c))  # fmt: skip
        terminal = batch["is_terminal"].reshape(-1)
        with self._autocast():
            actor_loss, critic_loss, ac_metrics = self.ac.losses(self.wm, start, terminal)
        if self.teacher is not None and cfg.bc_weight > 0:
            # labelled at sampling time: the teachers are functions of the observation, so
            # this equals labelling at storage time and keeps the replay's layout
            target = self._t(self.teacher(batch["obs"].reshape(-1, batch["obs"].shape[-1])
                                          .cpu().numpy()))  # fmt: skip
            # the teacher's action's negative log-likelihood: it trains the spread too, so
            # the policy's samples (what it trains on) narrow where the teacher is sure
            bc_loss = -self.ac.actor(start.feat()).log_prob(target).mean()
            actor_loss = actor_loss + cfg.bc_weight * bc_loss
            ac_metrics["bc_loss"] = bc_loss.detach()
        self.actor_opt.zero_grad(set_to_none=True)
        actor_loss.backward()
        metrics["actor_grad_norm"] = torch.nn.utils.clip_grad_norm_(
            self.ac.actor.parameters(), cfg.ac_clip
        )
        self.actor_opt.step()
        self.critic_opt.zero_grad(set_to_none=True)
        critic_loss.backward()
        metrics["critic_grad_norm"] = torch.nn.utils.clip_grad_norm_(
            self.ac.critic.parameters(), cfg.ac_clip
        )
        self.critic_opt.step()
        self.ac.update_slow()
        self.grad_steps += 1
        metrics |= ac_metrics
        metrics |= {"model_loss": model_loss, "actor_loss": actor_loss, "critic_loss": critic_loss}
        for k, v in metrics.items():
            self._sums[k] = self._sums.get(k, 0.0) + v.detach()  # .item() once per iteration
        self._n_sums += 1

    def update(self, last_obs: np.ndarray) -> dict[str, float]:
        """Mean metrics of the gradient steps since the last call (Dreamer learns in
        process_step)."""
        del last_obs
        out = {k: float(v) / self._n_sums for k, v in self._sums.items()} if self._n_sums else {}
        out["grad_steps"] = float(self.grad_steps)
        out["replay_steps"] = float(self.replay.size)
        self._sums, self._n_sums = {}, 0
        return out

    # ---------------------------------------------------------------- checkpoints

    def modules(self) -> dict[str, torch.nn.Module | torch.optim.Optimizer]:
        """What a checkpoint holds (name -> module or optimizer)."""
        return {
            "world_model": self.wm,
            "actor_critic": self.ac,
            "model_opt": self.model_opt,
            "actor_opt": self.actor_opt,
            "critic_opt": self.critic_opt,
        }

    def extra_state(self) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
        """(tensors, JSON-able values) beyond the modules: the recurrent state of every env,
        the replay (when its filled part is under checkpoint_replay_mb), the replay
        sampler's RNG and the counters."""
        tensors = {
            "state/deter": self.state.deter,
            "state/stoch": self.state.stoch,
            "state/prev_action": self.prev_action,
        }
        saved = self.replay.filled_bytes() <= self.cfg.checkpoint_replay_mb * 2**20
        if saved:
            arrays, _ = self.replay.state()
            tensors |= {f"replay/{k}": torch.from_numpy(np.ascontiguousarray(v))
                        for k, v in arrays.items()}  # fmt: skip
        _, counters = self.replay.state()
        return tensors, {
            "first": self.first.tolist(),
            "replay": counters,
            "replay_saved": saved,
            "rng": self.rng.bit_generator.state,
            "env_steps": self.env_steps,
            "grad_steps": self.grad_steps,
            "credit": self._credit,
        }

    def load_extra_state(self, tensors: dict[str, torch.Tensor], values: dict[str, Any]) -> None:
        dev = self.device
        self.state = State(tensors["state/deter"].to(dev), tensors["state/stoch"].to(dev))
        self.prev_action = tensors["state/prev_action"].to(dev)
        self.first = np.array(values["first"], dtype=bool)
        if values["replay_saved"]:
            arrays = {k.removeprefix("replay/"): v.numpy() for k, v in tensors.items()
                      if k.startswith("replay/")}  # fmt: skip
            self.replay.load(arrays, values["replay"])
        self.rng.bit_generator.state = values["rng"]
        self.env_steps, self.grad_steps = values["env_steps"], values["grad_steps"]
        self._credit = values["credit"]
