"""n-step returns for an off-policy agent's replay buffer, over a batch of envs.

A transition stored with n-step returns is (s_t, a_t, R, s_{t+k}, terminated, gamma^k) with
R = r_t + gamma r_{t+1} + ... + gamma^(k-1) r_{t+k-1}: k = n, or fewer where the episode
ended first (then s_{t+k} is its final observation, and `terminated` says whether the target
bootstraps from it). The critic's target becomes R + gamma^k (1 - terminated) V(s_{t+k}), so a
reward reaches the value n steps back in one update instead of n (as in Rainbow, D4PG and
DrQ-v2). The price is a bias: the rewards after a_t come from the actions the policy took
then, not from the present policy; small while the policy acts near-deterministically.

Written by hand: the accumulator is a few lines of tensor bookkeeping, and none of the
libraries this project uses keeps n-step windows for a batch of envs with auto-reset.
"""

from __future__ import annotations

import torch


class NStepWindow:
    """The last n-1 steps of every env, waiting for their n-step return.

    `push` takes one vector-env step and returns the transitions completed by it, each with
    its discount gamma^k; `state`/`load_state` carry the window through a checkpoint.
    """

    def __init__(self, n: int, gamma: float, num_envs: int) -> None:
        if n < 1:
            raise ValueError(f"n-step returns need n >= 1, got {n}")
        self.n, self.gamma, self.num_envs = n, gamma, num_envs
        # oldest first; each: the fields at s_t (obs, action, ...), "ret", "disc", "valid"
        self.entries: list[dict[str, torch.Tensor]] = []

    def push(
        self,
        fields: dict[str, torch.Tensor],
        reward: torch.Tensor,
        next_obs: torch.Tensor,
        terminated: torch.Tensor,
        done: torch.Tensor,
    ) -> dict[str, torch.Tensor] | None:
        """Add the step (fields at s_t, e.g. obs and action, each (N, ...); reward (N,);
        next_obs (N, obs_dim), the final observation where the episode ended; terminated
        (N,) float; done (N,) bool: terminated or truncated). Returns the completed
        transitions as one batch: the fields, "reward" (the n-step return), "next_obs",
        "terminated" and "discount" (gamma^k), or None when none completed."""
        g = self.gamma
        for e in self.entries:  # the steps still open gain this reward
            v = e["valid"]
            e["ret"] = torch.where(v, e["ret"] + e["disc"] * reward, e["ret"])
            e["disc"] = torch.where(v, e["disc"] * g, e["disc"])
        new = {k: v.clone() for k, v in fields.items()}
        new["ret"] = reward.clone()
        new["disc"] = torch.full_like(reward, g)
        new["valid"] = torch.ones(len(reward), dtype=torch.bool, device=reward.device)
        self.entries.append(new)
        full = len(self.entries) == self.n
        out: list[dict[str, torch.Tensor]] = []
        for i, e in enumerate(self.entries):
            # the oldest has its n rewards; where an episode ended, every open step closes
            emit = e["valid"] & (done | (i == 0 and full))
            if emit.any():
                out.append(
                    {
                        **{k: e[k][emit] for k in fields},
                        "reward": e["ret"][emit],
                        "next_obs": next_obs[emit],
                        "terminated": terminated[emit],
                        "discount": e["disc"][emit],
                    }
                )
                e["valid"] = e["valid"] & ~emit
        if full:
            self.entries.pop(0)
        if not out:
            return None
        return {k: torch.cat([o[k] for o in out]) for k in out[0]}

    def state(self) -> dict[str, torch.Tensor]:
        """The open steps as tensors (each field stacked oldest first) for a checkpoint."""
        if not self.entries:
            return {}
        return {k: torch.stack([e[k] for e in self.entries]) for k in self.entries[0]}

    def load_state(self, tensors: dict[str, torch.Tensor]) -> None:
        if not tensors:
            self.entries = []
            return
        depth = len(next(iter(tensors.values())))
        if depth >= self.n:
            raise ValueError(f"an n-step window of {depth} open steps does not fit n = {self.n}")
        self.entries = [{k: v[i].clone() for k, v in tensors.items()} for i in range(depth)]
