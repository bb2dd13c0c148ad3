"""The DreamerV3 world model: an RSSM with a LayerNorm GRU and discrete latents, an MLP
encoder and decoder of the vector observation (symlog inputs and targets), a two-hot
reward head and a Bernoulli continue head. Shapes: B batch, T time, F = deter + stoch *
classes the latent feature [h, z]."""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn
from torch.nn import functional as F

from rl.dreamer.config import DreamerConfig
from rl.dreamer.distributions import (
    TwoHot,
    kl_losses,
    mode_onehot,
    sample_straight_through,
    unimix_logits,
)
from rl.nets import SymlogObs


def dense(in_dim: int, out_dim: int) -> nn.Sequential:
    """Linear (no bias: LayerNorm has one) -> LayerNorm -> SiLU, the official block."""
    return nn.Sequential(nn.Linear(in_dim, out_dim, bias=False), nn.LayerNorm(out_dim), nn.SiLU())


def mlp(
    in_dim: int, units: int, layers: int, out_dim: int, zero_out: bool = False
) -> nn.Sequential:
    """`layers` dense blocks of `units`, then a Linear to out_dim; `zero_out` initialises
    the output layer to zero (the official `outscale: 0.0` of the reward head and the
    critic: their first predictions are exactly 0, so early returns are not noise)."""
    blocks = [dense(in_dim if i == 0 else units, units) for i in range(layers)]
    out = nn.Linear(units if layers else in_dim, out_dim)
    if zero_out:
        nn.init.zeros_(out.weight)
        nn.init.zeros_(out.bias)
    return nn.Sequential(*blocks, out)


class LayerNormGRU(nn.Module):
    """The official GRU cell: one Linear over [x, h] to the three gates, LayerNorm, then

        r = sigmoid(.), c = tanh(r * .), u = sigmoid(. - 1),   h' = u c + (1 - u) h

    (the -1 bias makes the cell keep its state at first)."""

    def __init__(self, in_dim: int, deter: int) -> None:
        super().__init__()
        self.linear = nn.Linear(in_dim + deter, 3 * deter, bias=False)
        self.norm = nn.LayerNorm(3 * deter)

    def forward(self, x: torch.Tensor, h: torch.Tensor) -> torch.Tensor:
        reset, cand, update = self.norm(self.linear(torch.cat([x, h], -1))).chunk(3, -1)
        reset = torch.sigmoid(reset)
        cand = torch.tanh(reset * cand)
        update = torch.sigmoid(update - 1.0)
        return update * cand + (1.0 - update) * h


@dataclass
class State:
    """An RSSM state: deter h (..., deter), stoch z (..., stoch, classes) one-hot (with
    straight-through gradients), and the log-probabilities (..., stoch, classes) of the
    distribution z was drawn from (None for the initial state)."""

    deter: torch.Tensor
    stoch: torch.Tensor
    logits: torch.Tensor | None = None

    def feat(self) -> torch.Tensor:
        """[h, flatten(z)] (..., F): what every head, the actor and the critic read."""
        return torch.cat([self.deter, self.stoch.flatten(-2)], -1)


def stack_states(states: list[State], dim: int = 1) -> State:
    """The states of successive steps stacked along `dim`."""
    return State(
        torch.stack([s.deter for s in states], dim),
        torch.stack([s.stoch for s in states], dim),
        torch.stack([s.logits for s in states], dim),  # type: ignore[misc]
    )


class RSSM(nn.Module):
    """Recurrent state-space model: h_t = GRU(h_(t-1), [z_(t-1), a_(t-1)]);
    prior p(z_t | h_t); posterior q(z_t | h_t, e_t) with e_t the observation's embedding."""

    def __init__(self, cfg: DreamerConfig, act_dim: int, embed_dim: int) -> None:
        super().__init__()
        self.cfg = cfg
        s = cfg.stoch * cfg.classes
        # the official `initial: learned`: h_0 = tanh(w), z_0 the prior's mode at h_0
        self.init_deter = nn.Parameter(torch.zeros(cfg.deter))
        self.img_in = dense(s + act_dim, cfg.units)
        self.gru = LayerNormGRU(cfg.units, cfg.deter)
        self.prior_net = nn.Sequential(dense(cfg.deter, cfg.units), nn.Linear(cfg.units, s))
        self.post_net = nn.Sequential(
            dense(cfg.deter + embed_dim, cfg.units), nn.Linear(cfg.units, s)
        )

    def _dist(self, x: torch.Tensor) -> torch.Tensor:
        """Log-probabilities (..., stoch, classes) with the uniform mix."""
        x = x.reshape(*x.shape[:-1], self.cfg.stoch, self.cfg.classes)
        return unimix_logits(x, self.cfg.unimix)

    def initial(self, batch: int) -> State:
        """The learned initial state, repeated `batch` times."""
        # computed once and broadcast: every row is the same (the acting step calls this
        # for every vector step)
        deter = torch.tanh(self.init_deter)[None]
        stoch = mode_onehot(self._dist(self.prior_net(deter)))
        return State(deter.expand(batch, -1), stoch.expand(batch, -1, -1))

    def deter_step(self, prev: State, action: torch.Tensor) -> torch.Tensor:
        """The deterministic part of a step: (h_(t-1), z_(t-1)), a_(t-1) -> h_t."""
        # the official `action_clip: 1.0`: a / max(1, |a|)
        action = action / torch.clamp(action.abs(), min=1.0).detach()
        x = self.img_in(torch.cat([prev.stoch.flatten(-2), action], -1))
        return self.gru(x, prev.deter)

    def img_step(self, prev: State, action: torch.Tensor, sample: bool = True) -> State:
        """One step of the prior: (h_(t-1), z_(t-1)), a_(t-1) -> (h_t, z_t ~ p(. | h_t))."""
        deter = self.deter_step(prev, action)
        logits = self._dist(self.prior_net(deter))
        stoch = sample_straight_through(logits) if sample else mode_onehot(logits)
        return State(deter, stoch, logits)

    def obs_step(
        self,
        prev: State,
        prev_action: torch.Tensor,
        embed: torch.Tensor,
        is_first: torch.Tensor,
        sample: bool = True,
        init: State | None = None,
        with_prior: bool = True,
    ) -> tuple[State, State | None]:
        """(posterior, prior) at t. Where is_first (B,) the previous state becomes the initial
        state (`init`, computed when not given) and the previous action zero: episodes never
        see each other. with_prior=False skips the prior's head and returns None for it
        (acting needs only the posterior; its latent is then the step's only draw)."""
        keep = (~is_first).to(embed.dtype)[:, None]
        init = init if init is not None else self.initial(len(is_first))
        prev = State(
            keep * prev.deter + (1 - keep) * init.deter,
            keep[..., None] * prev.stoch + (1 - keep[..., None]) * init.stoch,
        )
        prior = self.img_step(prev, keep * prev_action, sample) if with_prior else None
        deter = prior.deter if prior is not None else self.deter_step(prev, keep * prev_action)
        logits = self._dist(self.post_net(torch.cat([deter, embed], -1)))
        stoch = sample_straight_through(logits) if sample else mode_onehot(logits)
        return State(deter, stoch, logits), prior

    def observe(
        self, embed: torch.Tensor, prev_action: torch.Tensor, is_first: torch.Tensor
    ) -> tuple[State, State]:
        """Posteriors and priors (B, T, ...) of sequences: embed (B, T, E), prev_action
        (B, T, A) (a_(t-1)), is_first (B, T). Each sequence starts from the initial state
        (is_first[:, 0] must be True)."""
        init = state = self.initial(embed.shape[0])
        posts, priors = [], []
        for t in range(embed.shape[1]):
            state, prior = self.obs_step(
                state, prev_action[:, t], embed[:, t], is_first[:, t], init=init
            )
            posts.append(state)
            priors.append(prior)

        return stack_states(posts), stack_states(priors)


class WorldModel(nn.Module):
    """Encoder, RSSM, decoder, reward and continue heads, and their loss."""

    def __init__(self, cfg: DreamerConfig, obs_dim: int, act_dim: int) -> None:
        super().__init__()
        self.cfg = cfg
        u, n = cfg.units, cfg.layers
        feat = cfg.deter + cfg.stoch * cfg.classes
        self.obs_symlog = SymlogObs(cfg.obs_scale)  # the encoder's input, the decoder's target
        self.encoder = nn.Sequential(*[dense(obs_dim if i == 0 else u, u) for i in range(n)])
        self.rssm = RSSM(cfg, act_dim, u)
        self.decoder = mlp(feat, u, n, obs_dim)
        self.reward = mlp(feat, u, n, cfg.bins, zero_out=True)
        self.cont = mlp(feat, u, n, 1)
        self.twohot = TwoHot(cfg.bins, cfg.bin_range)

    @property
    def feat_dim(self) -> int:
        return self.cfg.deter + self.cfg.stoch * self.cfg.classes

    def embed(self, obs: torch.Tensor) -> torch.Tensor:
        """e = encoder(symlog(k obs)), k = obs_scale: the symlog bounds the inputs whatever
        their scale."""
        return self.encoder(self.obs_symlog(obs))

    def loss(self, batch: dict[str, torch.Tensor]) -> tuple[torch.Tensor, State, dict]:
        """The world-model loss of a batch of sequences (B, T, ...): obs, prev_action,
        reward, is_first, is_terminal. Returns (loss, posterior states, metrics):

            L = pred (L_obs + L_reward + L_cont) + dyn L_dyn + rep L_rep   (mean over B, T)
            L_obs = ||decoder(h, z) - symlog(k o)||^2 (summed over dims), k = obs_scale
            L_reward = -log p_twohot(r | h, z),  L_cont = -log Bernoulli(1 - terminal | h, z)
        """
        cfg = self.cfg
        post, prior = self.rssm.observe(
            self.embed(batch["obs"]), batch["prev_action"], batch["is_first"]
        )
        feat = post.feat()
        target = self.obs_symlog(batch["obs"])
        obs_loss = (self.decoder(feat).float() - target).pow(2).sum(-1)
        reward_loss = -self.twohot.log_prob(self.reward(feat), batch["reward"])
        cont_target = 1.0 - batch["is_terminal"].to(feat.dtype)
        cont_loss = F.binary_cross_entropy_with_logits(
            self.cont(feat).float().squeeze(-1), cont_target, reduction="none"
        )
        dyn, rep, kl = kl_losses(post.logits, prior.logits, cfg.free_nats)
        pred = obs_loss + reward_loss + cont_loss
        loss = (cfg.pred_scale * pred + cfg.dyn_scale * dyn + cfg.rep_scale * rep).mean()
        ent = -(post.logits.exp() * post.logits).sum((-2, -1))
        metrics = {
            "obs_loss": obs_loss.mean(),
            "reward_loss": reward_loss.mean(),
            "cont_loss": cont_loss.mean(),
            "dyn_loss": dyn.mean(),
            "rep_loss": rep.mean(),
            "kl": kl.mean(),
            "post_entropy": ent.mean(),
        }
        return loss, post, metrics
