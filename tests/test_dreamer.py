"""DreamerV3: its maths against hand-computed values, the replay, the recurrent state,
and short runs through the runner (counters, checkpoints, exact resume, evaluation)."""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest
import torch

from evaluation.command import eval_main
from evaluation.protocol import evaluate
from rl import checkpoint as ckpt
from rl.agents import reset_hook
from rl.dreamer.actor_critic import imagine
from rl.dreamer.agent import Dreamer
from rl.dreamer.config import DreamerConfig
from rl.dreamer.distributions import (
    ReturnNormalizer,
    TwoHot,
    kl_losses,
    lambda_returns,
    sample_straight_through,
    symexp,
    symlog,
    unimix_logits,
)
from rl.dreamer.replay import ReplayMemoryError, SequenceReplay
from rl.dreamer.world_model import State
from rl.presets import Setup, get_setup
from rl.run_state import load_agent
from rl.runner import train
from tests.test_rl_runner import Interrupt, NaNAfter, _weights
from tests.toy_env import StatefulToyEnv, ToyEnv

torch.set_num_threads(1)

TINY = DreamerConfig(units=16, layers=1, deter=16, stoch=4, classes=4, batch_size=4,
                     batch_length=8, horizon=4, replay_capacity=2_000, warmup_steps=32,
                     train_ratio=16.0, steps_per_iteration=8)  # fmt: skip
# 4 envs, 8 vector steps (32 env steps) per iteration, a checkpoint every 2 iterations;
# 4 * 16 / (4 * 8) = 2 gradient steps per vector step once the 32 warm-up steps are done
SETUP = Setup(TINY, num_envs=4, total_steps=96, checkpoint_steps=64)


def _train(env, out, setup=SETUP, **kw):
    return train("dreamer", env, setup, seed=1, out_dir=out, progress=False, tensorboard=False,
                 **kw)  # fmt: skip


def _play(agent: Dreamer, env: ToyEnv, steps: int) -> np.ndarray:
    """`steps` vector steps of `agent` acting and learning in `env`; the last observation."""
    obs = env.reset(seed=0)
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(agent.act(obs))
        agent.process_step(obs, r, term, trunc, info)
    return obs


# ----------------------------------------------------------------------------- maths


def test_symlog_symexp() -> None:
    x = torch.tensor([-1e6, -(math.e - 1), -0.5, 0.0, 0.5, math.e - 1, 1e6], dtype=torch.float64)
    np.testing.assert_allclose(symlog(x)[1:6], [-1.0, -math.log(1.5), 0, math.log(1.5), 1.0])
    assert symlog(x)[-1] == pytest.approx(math.log(1e6 + 1))
    np.testing.assert_allclose(symexp(symlog(x)), x, rtol=1e-12)


def test_two_hot_encode_decode() -> None:
    th = TwoHot(bins=5, bin_range=2.0)  # bins -2, -1, 0, 1, 2 in symlog space
    d = torch.float64
    y = torch.tensor([0.0, math.exp(0.25) - 1, -(math.e - 1), 1e9, -1e9], dtype=d)
    w = th.encode(y)
    np.testing.assert_allclose(w[0], [0, 0, 1, 0, 0])  # on a bin
    np.testing.assert_allclose(w[1], [0, 0, 0.75, 0.25, 0], atol=1e-12)  # between bins
    np.testing.assert_allclose(w[2], [0, 1, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(w[3], [0, 0, 0, 0, 1])  # beyond the range: the end bin
    np.testing.assert_allclose(w[4], [1, 0, 0, 0, 0])
    back = th.decode(w)
    np.testing.assert_allclose(back[:3], y[:3], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(back[3:], [math.exp(2) - 1, 1 - math.exp(2)])
    full = TwoHot()  # 255 bins over [-20, 20]: the round trip of any value inside
    y = torch.tensor([-12345.6, -3.3, 0.01, 7.0, 1e5], dtype=torch.float64)
    np.testing.assert_allclose(full.decode(full.encode(y)), y, rtol=1e-9)
    # the log-probability of the target's own two-hot softmax is the largest
    logits = torch.log(full.encode(y) + 1e-9)
    assert (full.log_prob(logits, y) > full.log_prob(logits, y + 1.0)).all()


def test_lambda_returns_hand_computed() -> None:
    # gamma 0.9, lambda 0.8, three steps, two trajectories (columns):
    #   a: r = 1, 2, 3; c = 1, 1, 0; v(s_0..s_3) = 0.5, 1, 1.5, 2
    #      R_3 = 2;  R_2 = 3 + 0 = 3
    #      R_1 = 2 + 0.9 (0.2 * 1.5 + 0.8 * 3) = 4.43
    #      R_0 = 1 + 0.9 (0.2 * 1.0 + 0.8 * 4.43) = 4.3696
    #   b: r = 0, 0, 1; c = 1, 1, 1; v = 0, 0, 0, 10
    #      R_2 = 1 + 0.9 (0.2 * 10 + 0.8 * 10) = 10
    #      R_1 = 0 + 0.9 (0 + 0.8 * 10) = 7.2;  R_0 = 0.9 (0.8 * 7.2) = 5.184
    t = lambda x: torch.tensor(x, dtype=torch.float64)  # noqa: E731
    ret = lambda_returns(t([[1, 0], [2, 0], [3, 1]]), t([[1, 1], [1, 1], [0, 1]]),
                         t([[0.5, 0], [1, 0], [1.5, 0], [2, 10]]), 0.9, 0.8)  # fmt: skip
    np.testing.assert_allclose(ret, [[4.3696, 5.184], [4.43, 7.2], [3.0, 10.0]], rtol=1e-12)


def test_kl_balancing_and_free_bits() -> None:
    # two latent variables of two classes:
    #   post [0.5, 0.5], prior [0.9, 0.1]: KL = 0.5 ln(0.5/0.9) + 0.5 ln(0.5/0.1) = 0.510826
    #   post [0.2, 0.8], prior [0.5, 0.5]: KL = 0.2 ln 0.4 + 0.8 ln 1.6           = 0.192745
    #   summed over the latents: 0.703571
    post = torch.tensor([[[0.5, 0.5], [0.2, 0.8]]], dtype=torch.float64).log().requires_grad_()
    prior = torch.tensor([[[0.9, 0.1], [0.5, 0.5]]], dtype=torch.float64).log().requires_grad_()
    dyn, rep, kl = kl_losses(post, prior, free_nats=0.5)
    assert kl.item() == pytest.approx(0.703571, abs=1e-6)
    assert dyn.item() == rep.item() == pytest.approx(0.703571, abs=1e-6)
    # dyn trains the prior only, rep the posterior only
    grad = lambda y, x: torch.autograd.grad(y.sum(), x, retain_graph=True, allow_unused=True)[0]  # noqa: E731
    assert grad(dyn, post) is None and grad(rep, prior) is None
    assert torch.autograd.grad(dyn.sum(), prior)[0].abs().sum() > 0
    # below the free bits (1 nat) both terms are clipped to 1 and pull nothing
    dyn, rep, kl = kl_losses(post, prior, free_nats=1.0)
    assert dyn.item() == rep.item() == 1.0 and kl.item() < 1.0
    g = torch.autograd.grad((0.5 * dyn + 0.1 * rep).sum(), [post, prior], allow_unused=True)
    assert all(x is None or torch.all(x == 0) for x in g)


def test_return_normalizer_percentiles_and_ema() -> None:
    rng = np.random.default_rng(0)
    a, b = rng.normal(0, 20, 1000), rng.normal(10, 5, 500)  # P95 - P5 of a: 66
    norm = ReturnNormalizer(decay=0.99)
    norm.update(torch.tensor(a))
    lo, hi = 0.01 * np.percentile(a, 5), 0.01 * np.percentile(a, 95)
    assert norm.low.item() == pytest.approx(lo, rel=1e-5)
    assert norm.high.item() == pytest.approx(hi, rel=1e-5)
    assert norm.scale().item() == 1.0  # max(1, S): small ranges are not scaled up
    norm.update(torch.tensor(b))
    lo, hi = 0.99 * lo + 0.01 * np.percentile(b, 5), 0.99 * hi + 0.01 * np.percentile(b, 95)
    assert norm.low.item() == pytest.approx(lo, rel=1e-5)
    assert norm.high.item() == pytest.approx(hi, rel=1e-5)
    for _ in range(2000):
        norm.update(torch.tensor(a))
    width = np.percentile(a, 95) - np.percentile(a, 5)
    assert norm.scale().item() == pytest.approx(width, rel=1e-3)


def test_straight_through_samples_follow_the_probabilities() -> None:
    """One-hot samples whose class frequencies are the probabilities (inverse-CDF sampling,
    every class reachable, unimix included) and whose gradient is the probabilities'."""
    torch.manual_seed(0)
    probs = torch.tensor([[0.7, 0.2, 0.1, 0.0], [0.25, 0.25, 0.25, 0.25]], dtype=torch.float64)
    log_p = unimix_logits(torch.log(probs.clamp(min=1e-30)), 0.01).to(torch.float64)
    expect = log_p.exp()
    n = 200_000
    logits = log_p.expand(n, 2, 4).clone().requires_grad_(True)
    sample = sample_straight_through(logits)
    assert torch.allclose(sample.detach().sum(-1), torch.ones(n, 2, dtype=torch.float64))
    assert set(sample.detach().unique().round(decimals=9).tolist()) == {0.0, 1.0}
    freq = sample.detach().mean(0)
    assert torch.all((freq - expect).abs() < 4 * torch.sqrt(expect * (1 - expect) / n))
    assert freq[0, 3] > 0  # the class of probability 0 is drawn through the uniform mix
    # straight-through: d sample / d logits is d probs / d logits
    w = torch.arange(4, dtype=torch.float64)
    (sample * w).sum().backward()
    ref = logits.detach().clone().requires_grad_(True)
    (ref.exp() * w).sum().backward()
    assert torch.allclose(logits.grad, ref.grad)


# ----------------------------------------------------------------------------- parts


def test_obs_scale_sets_the_unit_of_the_encoder_and_the_decoder_target() -> None:
    from dataclasses import replace

    torch.manual_seed(0)
    obs = torch.tensor([[0.001, -0.25, 0.1, 1.0]])
    one = Dreamer(4, 2, 3, TINY).wm
    torch.manual_seed(0)
    mm = Dreamer(4, 2, 3, replace(TINY, obs_scale=1000.0)).wm
    assert torch.allclose(mm.embed(obs), one.embed(1000.0 * obs))
    batch = {"obs": obs.expand(1, 3, 4), "prev_action": torch.zeros(1, 3, 2),
             "reward": torch.zeros(1, 3), "is_first": torch.tensor([[True, False, False]]),
             "is_terminal": torch.zeros(1, 3, dtype=torch.bool)}  # fmt: skip
    torch.manual_seed(1)
    _, _, m_mm = mm.loss(batch)
    torch.manual_seed(1)
    _, _, m_one = one.loss(batch | {"obs": 1000.0 * batch["obs"]})
    assert torch.allclose(m_mm["obs_loss"], m_one["obs_loss"])
    with pytest.raises(ValueError, match="obs_scale"):
        replace(TINY, obs_scale=0.0).validate()


def test_bfloat16_gradient_steps_keep_float32_distributions() -> None:
    from dataclasses import replace

    torch.manual_seed(0)
    agent = Dreamer(4, 2, 3, replace(TINY, compute_dtype="bfloat16", warmup_steps=0))
    obs = _play(agent, ToyEnv(3), 12)
    assert agent.grad_steps > 0
    metrics = agent.update(obs)
    assert all(math.isfinite(v) for v in metrics.values())
    assert all(p.dtype == torch.float32 for p in agent.wm.parameters())
    with pytest.raises(ValueError, match="compute_dtype"):
        replace(TINY, compute_dtype="float16").validate()


def test_imagination_shapes_and_losses() -> None:
    torch.manual_seed(0)
    agent = Dreamer(4, 2, 3, TINY)
    start = agent.wm.rssm.initial(6)
    for backprop in (True, False):
        traj, actions, policy = imagine(agent.wm, agent.ac.actor, start, TINY.horizon, backprop)
        h = TINY.horizon + 1
        assert traj.deter.shape == (h, 6, TINY.deter)
        assert traj.stoch.shape == traj.logits.shape == (h, 6, TINY.stoch, TINY.classes)
        assert traj.feat().shape == (h, 6, agent.wm.feat_dim) and actions.shape == (h, 6, 2)
        assert torch.allclose(traj.stoch[1:].sum(-1), torch.ones(()))  # one-hot latents
        assert policy.mean.shape == policy.std.shape == (h, 6, 2)
        # the returned policy is the one the actions were drawn from (no second actor pass)
        assert torch.equal(policy.mean, agent.ac.actor(traj.feat()).mean)
    terminal = torch.tensor([False, True, False, False, False, True])
    actor_loss, critic_loss, metrics = agent.ac.losses(agent.wm, start, terminal)
    assert actor_loss.shape == critic_loss.shape == ()
    assert torch.isfinite(actor_loss) and torch.isfinite(critic_loss)
    assert abs(metrics["value_mean"].item()) < 1e-6  # the critic's zero-initialised output layer


def test_acting_step_without_prior_gives_the_same_posterior() -> None:
    """The acting step skips the prior's head; its posterior is the training step's."""
    torch.manual_seed(0)
    agent = Dreamer(4, 2, 3, TINY)
    rssm = agent.wm.rssm
    prev = rssm.initial(5)
    prev = State(prev.deter + 0.1 * torch.randn_like(prev.deter), prev.stoch)
    action, embed = torch.randn(5, 2), agent.wm.embed(torch.randn(5, 4))
    first = torch.tensor([True, False, False, True, False])
    with torch.no_grad():
        post, prior = rssm.obs_step(prev, action, embed, first, sample=False)
        fast, none = rssm.obs_step(prev, action, embed, first, sample=False, with_prior=False)
    assert none is None and prior is not None
    assert torch.equal(fast.deter, post.deter) and torch.equal(fast.stoch, post.stoch)
    assert torch.equal(fast.logits, post.logits)
    # the initial state is one row broadcast; the agent's per-env state must still be rows of
    # its own, or a write for one env (reset, acting) would reach every env
    init = rssm.initial(3)
    assert init.deter.shape == (3, TINY.deter) and init.stoch.shape[0] == 3
    agent.reset(np.ones(3, bool))
    agent.state.deter[0] += 1.0
    agent.state.stoch[0] *= 0.0
    assert torch.equal(agent.state.deter[1], init.deter[1])
    assert torch.equal(agent.state.stoch[2], init.stoch[2])


def test_recurrent_state_resets_where_episodes_end() -> None:
    torch.manual_seed(0)
    agent = Dreamer(4, 2, 3, TINY)
    env = ToyEnv(3)
    obs = env.reset(seed=0)
    for _ in range(3):
        agent.act(obs)
        obs, r, _, _, info = env.step(np.zeros((3, 2)))
    before = State(agent.state.deter.clone(), agent.state.stoch.clone())
    init = agent.wm.rssm.initial(1)
    assert not torch.equal(before.deter[1], init.deter[0])
    done = np.array([False, True, False])
    agent.process_step(obs, r, done, np.zeros(3, bool), info | {"final_obs": obs * 0 + 7})
    assert torch.equal(agent.state.deter[1], init.deter[0])
    assert torch.equal(agent.state.stoch[1], init.stoch[0])
    assert torch.all(agent.prev_action[1] == 0) and agent.first.tolist() == [False, True, False]
    for i in (0, 2):  # the others are untouched
        assert torch.equal(agent.state.deter[i], before.deter[i])
        assert torch.equal(agent.state.stoch[i], before.stoch[i])
    # the replay got the finished episode's last observation, then the next one's first
    rep = agent.replay
    last = rep.data["obs"][1, rep.pos[1] - 1]
    assert np.all(last == 7) and rep.data["is_terminal"][1, rep.pos[1] - 1]
    agent.act(obs)
    assert rep.data["is_first"][1, rep.pos[1] - 1] and not agent.first.any()
    assert rep.count.tolist() == [2, 3, 2]  # first obs, the step; env 1: its new first obs
    # a batch of another size (an evaluation with other envs) starts afresh
    agent.policy(np.zeros((5, 4), np.float32))
    assert agent.state.deter.shape == (5, TINY.deter)


def test_reward_scale_multiplies_the_stored_rewards() -> None:
    from dataclasses import replace

    stored = []
    for scale in (1.0, 100.0):
        torch.manual_seed(0)
        agent = Dreamer(4, 2, 3, replace(TINY, reward_scale=scale))
        env = ToyEnv(3)
        obs = env.reset(seed=0)
        agent.act(obs)
        obs, r, term, trunc, info = env.step(np.full((3, 2), 0.5))
        agent.process_step(obs, r, term, trunc, info)
        rep = agent.replay
        stored.append(np.array([rep.data["reward"][i, rep.pos[i] - 1] for i in range(3)]))
        assert np.allclose(stored[-1], np.asarray(r) * scale)
    assert np.abs(stored[0]).sum() > 0
    with pytest.raises(ValueError, match="reward_scale"):
        replace(TINY, reward_scale=0.0).validate()


def test_bc_term_pulls_the_policy_to_the_teacher() -> None:
    """With bc_weight > 0 the policy's mode on replayed states moves to the teacher's
    action (a constant here, which the toy env's reward does not favour); without it, or
    without a teacher, it does not."""
    from dataclasses import replace

    target = np.array([0.6, -0.4], np.float32)

    def run(bc_weight: float) -> np.ndarray:
        torch.manual_seed(0)
        agent = Dreamer(4, 2, 3, replace(TINY, bc_weight=bc_weight, actor_lr=1e-2))
        agent.set_teacher(lambda o: np.tile(target, (len(o), 1)))
        obs = _play(agent, ToyEnv(3), 120)
        assert agent.grad_steps > 100
        metrics = agent.update(obs)
        assert ("bc_loss" in metrics) == (bc_weight > 0)
        agent.reset(np.ones(3, bool))
        return agent.policy(obs)

    assert np.abs(run(50.0) - target).max() < 0.1
    assert np.abs(run(0.0) - target).max() > 0.3
    with pytest.raises(ValueError, match="bc_weight"):
        replace(TINY, bc_weight=-1.0).validate()


def test_replay_sequences_and_memory_check() -> None:
    rep = SequenceReplay(capacity=20, num_envs=2, obs_dim=1, act_dim=1)
    for t in range(13):  # env 0 wraps its ring of 10
        rep.add(np.array([0, 1]), obs=np.array([[t], [100 + t]]), prev_action=np.zeros((2, 1)),
                reward=np.zeros(2), is_first=np.array([t == 0, t == 0]),
                is_terminal=np.zeros(2, bool))  # fmt: skip
    assert rep.count.tolist() == [10, 10] and rep.size == 20
    b = rep.sample(64, 4, np.random.default_rng(0))
    o = b["obs"][..., 0]
    assert o.shape == (64, 4) and np.all(np.diff(o, axis=1) == 1)  # consecutive steps
    assert o.min() == 3 and b["is_first"][:, 0].all() and not b["is_first"][:, 1:].any()
    with pytest.raises(ReplayMemoryError, match=r"needs \d+.* GiB"):
        SequenceReplay(10**13, 1, 18, 4).add(np.array([0]), obs=np.zeros((1, 18)))


# ----------------------------------------------------------------------------- runs


def test_runner_counters_checkpoint_and_nan(tmp_path, capsys) -> None:
    r = _train(ToyEnv(4), tmp_path / "run")
    assert r["status"] == "done" and r["env_steps"] == 96 and r["iterations"] == 3
    m = r["metrics"]
    # vector steps 8..24 are past the warm-up (32 env steps): 2 gradient steps each
    assert m["grad_steps"] == 2 * (24 - 8 + 1)
    for k in ("model_loss", "obs_loss", "reward_loss", "cont_loss", "dyn_loss", "rep_loss",
              "return_scale", "actor_entropy", "critic_loss"):  # fmt: skip
        assert math.isfinite(m[k]), k
    agent, meta = load_agent(tmp_path / "run", "cpu")
    agent2, _ = load_agent(tmp_path / "run", "cpu")
    assert meta["algo"] == "dreamer" and isinstance(agent, Dreamer)
    w1, w2 = _weights(tmp_path / "run"), _weights(tmp_path / "run")
    assert all(torch.equal(w1[k], w2[k]) for k in w1)
    obs = np.random.default_rng(0).normal(size=(4, 4)).astype(np.float32)
    torch.manual_seed(0)
    a1 = agent.policy(obs)
    torch.manual_seed(0)
    np.testing.assert_array_equal(a1, agent2.policy(obs))
    # another configuration is refused, naming the difference
    other = Setup(DreamerConfig(**{**TINY.__dict__, "units": 8}), 4, 96, 64)
    with pytest.raises(ckpt.CheckpointError, match=r"config.units: checkpoint 16, now 8"):
        _train(ToyEnv(4), tmp_path / "run", other, resume=True)
    # a NaN reward makes the world-model loss NaN: stopped, the good checkpoint is kept
    r = _train(NaNAfter(ToyEnv(4), 20), tmp_path / "nan", steps=512)
    assert r["status"] == "nan" and r["iterations"] >= 2
    err = " ".join(capsys.readouterr().err.split())
    assert "Dreamer world model loss is nan" in err and "is kept" in err
    assert all(torch.isfinite(w).all() for w in _weights(tmp_path / "nan").values())


def test_exact_resume(tmp_path) -> None:
    # a stateful env, stopped at 64 steps and resumed to 128 = 128 straight
    full = _train(StatefulToyEnv(4), tmp_path / "full", steps=128)
    _train(StatefulToyEnv(4), tmp_path / "cut", steps=64)
    _train(StatefulToyEnv(4), tmp_path / "cut", steps=128, resume=True)
    assert full["iterations"] == 4
    a, b = _weights(tmp_path / "full"), _weights(tmp_path / "cut")
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    # a re-seeded env killed mid-iteration 4 resumes from the checkpoint of iteration 2
    full = _train(ToyEnv(4), tmp_path / "full2", steps=128)
    part = _train(Interrupt(ToyEnv(4), 28), tmp_path / "cut2", steps=128)
    assert part["status"] == "interrupted" and part["iterations"] == 3
    _train(ToyEnv(4), tmp_path / "cut2", steps=128, resume=True)
    a, b = _weights(tmp_path / "full2"), _weights(tmp_path / "cut2")
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_evaluation_carries_and_resets_the_recurrent_state(tmp_path, monkeypatch) -> None:
    _train(ToyEnv(4), tmp_path, steps=32)
    agent, _ = load_agent(tmp_path, "cpu")
    masks = []
    hook = reset_hook(agent)
    assert hook is not None

    def spy(mask: np.ndarray) -> None:
        masks.append(mask.copy())
        hook(mask)
        for i in np.flatnonzero(mask):  # restarted right away
            assert torch.equal(agent.state.deter[i], agent.wm.rssm.initial(1).deter[0])

    res = evaluate(agent.policy, ToyEnv(3, max_steps=6), 2, seed=0, reset=spy)
    assert res["episodes"] == 6 and masks[0].all() and len(masks[0]) == 3
    assert sum(m.sum() for m in masks[1:]) >= 6  # every episode end restarted its env
    # `assetgen eval --checkpoint` passes the hook too (here with more envs than trained)
    calls = []
    real = Dreamer.reset
    monkeypatch.setattr(Dreamer, "reset", lambda self, m: (calls.append(len(m)), real(self, m)))
    args = argparse.Namespace(run=tmp_path, dataset="toy", episodes=1, envs=6, seed=0,
                              device="cpu", stochastic=False, json=True, out=None)  # fmt: skip
    assert eval_main(args, lambda dataset, n, seed, **kw: ToyEnv(n)) == 0
    assert calls and set(calls) == {6}
    assert get_setup("debug", "dreamer").config.validate()


def test_paper_preset_is_table_ii() -> None:
    paper = get_setup("paper", "dreamer")
    c = paper.config
    assert (c.model_lr, c.actor_lr, c.critic_lr) == (1e-4, 3e-5, 3e-5)
    assert (c.units, c.layers, c.deter, c.stoch, c.classes) == (512, 2, 512, 32, 32)
    assert (c.replay_capacity, c.warmup_steps) == (20_000_000, 500_000)
    assert (c.batch_size, c.batch_length, c.train_ratio) == (16, 64, 512.0)
    assert (c.horizon, c.lam, c.gamma, c.entropy_coef) == (15, 0.95, 1 - 1 / 333, 3e-4)
    assert (c.dyn_scale, c.rep_scale, c.free_nats, c.unimix) == (0.5, 0.1, 1.0, 0.01)
    assert paper.num_envs == 1024 and paper.total_steps == 100_000_000
