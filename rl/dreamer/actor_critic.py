"""The DreamerV3 actor-critic, trained on trajectories imagined by the world model from
every replayed posterior state (time-major: H horizon, N = B * T starts)."""

from __future__ import annotations

import copy

import torch
from torch import nn

from rl.dreamer.config import DreamerConfig
from rl.dreamer.distributions import BoundedNormal, ReturnNormalizer, TwoHot, lambda_returns
from rl.dreamer.world_model import State, WorldModel, mlp, stack_states
from rl.nets import check_finite


class Actor(nn.Module):
    """pi(a | h, z): an MLP to the bounded normal's (mean, std) parameters."""

    def __init__(self, cfg: DreamerConfig, feat_dim: int, act_dim: int) -> None:
        super().__init__()
        self.cfg = cfg
        self.net = mlp(feat_dim, cfg.units, cfg.layers, 2 * act_dim)

    def forward(self, feat: torch.Tensor) -> BoundedNormal:
        return BoundedNormal(self.net(feat), self.cfg.min_std, self.cfg.max_std)


def imagine(
    wm: WorldModel, actor: Actor, start: State, horizon: int, reparameterise: bool
) -> tuple[State, torch.Tensor, BoundedNormal]:
    """Roll the prior forward `horizon` steps from `start` (N, ...) with actions drawn from
    the actor: states s_0..s_H (H + 1, N, ...), actions a_0..a_H (H + 1, N, A), a_t taken
    at s_t (a_H is only used for the entropy), and the policy pi(. | s_t) at every state
    (H + 1, N, A), which the losses reuse instead of running the actor again. The actor
    reads sg(s_t), as in the official code: with `reparameterise` the gradient reaches it
    through the actions; without, the actions are detached and the gradient reaches the
    actor only through the returned policy (its log-probabilities and entropy)."""
    states, actions, outs = [start], [], []
    state = start
    for t in range(horizon + 1):
        out = actor.net(state.feat().detach())
        dist = BoundedNormal(out, actor.cfg.min_std, actor.cfg.max_std)
        action = dist.rsample() if reparameterise else dist.rsample().detach()
        actions.append(action)
        outs.append(out)
        if t < horizon:
            state = wm.rssm.img_step(state, action)
            states.append(state)
    start_logits = torch.zeros_like(start.stoch) if start.logits is None else start.logits
    states[0] = State(start.deter, start.stoch, start_logits)
    policy = BoundedNormal(torch.stack(outs), actor.cfg.min_std, actor.cfg.max_std)
    return stack_states(states, 0), torch.stack(actions), policy


class ActorCritic(nn.Module):
    """Actor, two-hot critic, its slow EMA copy and the return normaliser."""

    def __init__(self, cfg: DreamerConfig, feat_dim: int, act_dim: int) -> None:
        super().__init__()
        self.cfg = cfg
        self.actor = Actor(cfg, feat_dim, act_dim)
        self.critic = mlp(feat_dim, cfg.units, cfg.layers, cfg.bins, zero_out=True)
        self.slow_critic = copy.deepcopy(self.critic).requires_grad_(False)
        self.retnorm = ReturnNormalizer(cfg.return_decay, cfg.return_low, cfg.return_high)
        self.twohot = TwoHot(cfg.bins, cfg.bin_range)

    def value(self, feat: torch.Tensor) -> torch.Tensor:
        """The critic's prediction v(s) = symexp(E[bins]) (...)."""
        return self.twohot.mean(self.critic(feat))

    def losses(
        self, wm: WorldModel, start: State, terminal: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, dict[str, torch.Tensor]]:
        """(actor loss, critic loss, metrics) of trajectories imagined from `start` (N, ...,
        detached posterior states) whose replayed is_terminal is `terminal` (N,).

        The world model is frozen here (no parameter gradients); with "backprop" the
        gradient still flows through its activations into the actor's actions.

            R_t    lambda-returns of the imagined rewards and the critic's values
            w_t    = gamma^t prod_(i<=t) c_i (c_0 = 1 - terminal): trajectories that end in
                   imagination stop counting
            A_t    = (R_t - sg(v(s_t))) / max(1, S), S the percentile return scale
            L_pi   = -E[w_t (A_t + eta H[pi(. | s_t)])]                        (backprop)
                   = -E[w_t (log pi(a_t | s_t) sg(A_t) + eta H[pi(. | s_t)])] (reinforce)
            L_v    = -E[w_t (log p_v(sg(R_t) | s_t) + slowreg log p_v(sg(v_slow(s_t)) | s_t))]
        The baseline v(s_t) is detached in the backprop loss too: its gradient through s_t
        would push the policy towards states the critic values low."""
        cfg = self.cfg
        backprop = cfg.actor_grad == "backprop"
        wm.requires_grad_(False)
        self.critic.requires_grad_(False)
        try:
            # the graph holds the actor always; the world model's activations only with
            # backprop (without, the actions are detached and no input of the world model
            # asks for a gradient, so imagining costs a forward pass)
            traj, actions, dist = imagine(wm, self.actor, start, cfg.horizon, backprop)
            with torch.set_grad_enabled(backprop):
                feat = traj.feat()  # (H + 1, N, F)
                reward = wm.twohot.mean(wm.reward(feat[1:]))
                # the official code uses the continue head's mode in imagination
                cont = (wm.cont(feat[1:]).squeeze(-1) > 0).float()
                cont = torch.cat([(1.0 - terminal.float())[None], cont])
                if backprop:  # the bootstrap values carry the actor's gradient too
                    value = self.value(feat)
        finally:
            wm.requires_grad_(True)
            self.critic.requires_grad_(True)
        sg_feat = feat.detach()
        logits = self.critic(sg_feat)  # the critic's own pass, trained below
        if not backprop:  # one critic pass serves the returns and the loss
            value = self.twohot.mean(logits.detach())
        ret = lambda_returns(reward, cont[1:], value, cfg.gamma, cfg.lam)
        weight = (torch.cumprod(cfg.gamma * cont, 0) / cfg.gamma).detach()
        self.retnorm.update(ret)
        scale = self.retnorm.scale()
        adv = (ret - value[:-1].detach()) / scale
        entropy = dist.entropy()[:-1]
        if backprop:
            pg = -adv
        else:
            pg = -dist.log_prob(actions.detach())[:-1] * adv.detach()
        actor_loss = (weight[:-1] * (pg - cfg.entropy_coef * entropy)).mean()

        target = ret.detach()
        with torch.no_grad():
            slow = self.twohot.mean(self.slow_critic(sg_feat[:-1]))
        critic_nll = -self.twohot.log_prob(logits[:-1], target)
        slow_nll = -self.twohot.log_prob(logits[:-1], slow)
        critic_loss = (weight[:-1] * (critic_nll + cfg.slowreg * slow_nll)).mean()
        check_finite("Dreamer actor", actor_loss, advantage=adv.mean(), entropy=entropy.mean())
        check_finite("Dreamer critic", critic_loss, returns=ret.mean(), value=value.mean())
        metrics = {
            "actor_entropy": entropy.mean(),
            "imag_return": ret.mean(),
            "imag_reward": reward.mean(),
            "return_scale": scale,
            "value_mean": value.mean(),
        }
        return actor_loss, critic_loss, metrics

    @torch.no_grad()
    def update_slow(self) -> None:
        """theta_slow <- decay theta_slow + (1 - decay) theta (every critic step)."""
        for s, p in zip(self.slow_critic.parameters(), self.critic.parameters(), strict=True):
            s.lerp_(p, 1.0 - self.cfg.slow_critic_decay)
