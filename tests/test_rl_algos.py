"""PPO and SAC against hand-computed values; networks; short smoke runs of every agent."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import torch

from rl.nets import ActorCritic, QNetwork, RunningNorm, SquashedGaussianActor, SymlogObs
from rl.nstep import NStepWindow
from rl.ppo import PPO, PPOConfig, bounds_loss, gae
from rl.random_agent import RandomAgent
from rl.runner import train
from rl.sac import SAC, SACConfig, q_filter, soft_target
from tests.toy_env import ToyEnv

torch.set_num_threads(1)

# Three steps, two envs, gamma 0.9, lambda 0.8.
#   env 0: rewards 1, 2, 3; V(s_0..s_2) = 0.5, 1.0, 1.5; terminated at t = 1; V(s_3) = 2.0
#     t=2: delta = 3 + 0.9 * 2.0 - 1.5 = 3.3                A = 3.3
#     t=1: delta = 2 + 0 - 1.0 = 1.0 (terminal)            A = 1.0 (the recursion stops)
#     t=0: delta = 1 + 0.9 * 1.0 - 0.5 = 1.4               A = 1.4 + 0.9 * 0.8 * 1.0 = 2.12
#   env 1: rewards 1, 1, 1; V = 1, 2, 3; truncated at t = 0 with V(final_obs) = 4; V(s_3) = 5
#     t=2: delta = 1 + 0.9 * 5 - 3 = 2.5                   A = 2.5
#     t=1: delta = 1 + 0.9 * 3 - 2 = 1.7                   A = 1.7 + 0.72 * 2.5 = 3.5
#     t=0: delta = 1 + 0.9 * 4 - 1 = 3.6 (bootstrapped)    A = 3.6 (the recursion stops)
GAMMA, LAM = 0.9, 0.8
ADV = [[2.12, 3.6], [1.0, 3.5], [3.3, 2.5]]
VALUES = [[0.5, 1.0], [1.0, 2.0], [1.5, 3.0]]


def test_gae_hand_computed() -> None:
    t = lambda x: torch.tensor(x, dtype=torch.float64)  # noqa: E731
    rewards, values = t([[1, 1], [2, 1], [3, 1]]), t(VALUES)
    next_values = t([[1.0, 4.0], [1.5, 3.0], [2.0, 5.0]])  # env 1, t=0: V(final_obs)
    terminated = t([[0, 0], [1, 0], [0, 0]])
    done = t([[0, 1], [1, 0], [0, 0]])
    adv, ret = gae(rewards, values, next_values, terminated, done, GAMMA, LAM)
    np.testing.assert_allclose(adv, ADV, rtol=1e-12)
    np.testing.assert_allclose(ret, np.add(ADV, VALUES), rtol=1e-12)


def test_ppo_rollout_bootstraps_truncation_from_final_obs() -> None:
    """The same example through PPO's storage: V(s) is read from obs[0] (a stub critic)."""
    cfg = PPOConfig(hidden=(4,), horizon=3, gamma=GAMMA, gae_lambda=LAM, normalize_obs=False)
    agent = PPO(1, 1, 2, cfg)
    agent.net.value = lambda o: o[:, 0]  # type: ignore[method-assign]
    o = lambda *v: np.array(v, np.float32)[:, None]  # noqa: E731
    steps = [  # obs, reward, terminated, truncated, final_obs
        (o(0.5, 1.0), [1, 1], [False, False], [False, True], o(9.0, 4.0)),
        (o(1.0, 2.0), [2, 1], [True, False], [False, False], o(9.0, 9.0)),
        (o(1.5, 3.0), [3, 1], [False, False], [False, False], o(9.0, 9.0)),
    ]
    for obs, r, term, trunc, final in steps:
        agent.act(obs)
        agent.process_step(obs, np.array(r), np.array(term), np.array(trunc), {"final_obs": final})
    adv, ret = agent.compute_returns(o(2.0, 5.0))
    np.testing.assert_allclose(adv.numpy(), ADV, rtol=1e-6)
    np.testing.assert_allclose(ret.numpy(), np.add(ADV, VALUES), rtol=1e-6)


def test_bounds_loss_hand_computed_and_pulls_the_mean_in() -> None:
    # row 0: |1.5| - 1.1 = 0.4 -> 0.16, -2.1 -> 1.0, 0.3 inside -> 0: 1.16; row 1: all inside
    mean = torch.tensor([[1.5, -2.1, 0.3], [1.0, -1.1, 0.0]])
    assert bounds_loss(mean).item() == pytest.approx(1.16 / 2)
    with pytest.raises(ValueError, match="bounds_loss_coef"):
        PPOConfig(bounds_loss_coef=-1.0).validate()
    # in PPO's update: a mean started at 3 is pulled back towards the soft bound only with it
    obs = np.zeros((2, 1), np.float32)
    no = np.zeros(2, bool)
    means = {}
    for coef in (0.0, 1.0):
        torch.manual_seed(0)
        cfg = PPOConfig(hidden=(4,), horizon=2, minibatch_size=4, epochs=1, learning_rate=1e-2,
                        bounds_loss_coef=coef)  # fmt: skip
        agent = PPO(1, 1, 2, cfg)
        with torch.no_grad():
            agent.net.actor[-1].bias.fill_(3.0)
        for _ in range(50):
            for _ in range(2):
                agent.act(obs)
                agent.process_step(obs, np.zeros(2), no, no, {})
            agent.update(obs)
        means[coef] = agent.net.dist(torch.zeros(1, 1))[0].item()
    assert means[0.0] > 2.9 and means[1.0] < 2.5


def test_ppo_std_cap_falls_log_linearly_and_binds_the_parameter() -> None:
    # init std e^-1 = 0.3679 at 100 env steps, 0.05 at 300: halfway (200) the geometric mean
    cfg = PPOConfig(hidden=(4,), horizon=2, minibatch_size=4, epochs=1, init_log_std=-1.0,
                    final_std=0.05, std_decay_start=100, std_decay_end=300)  # fmt: skip
    assert cfg.std_cap(0) == pytest.approx(math.exp(-1.0))
    assert cfg.std_cap(200) == pytest.approx(math.sqrt(math.exp(-1.0) * 0.05))
    assert cfg.std_cap(300) == pytest.approx(0.05) and cfg.std_cap(10**9) == pytest.approx(0.05)
    assert PPOConfig().std_cap(10**6) is None
    with pytest.raises(ValueError, match="std_decay_start <= std_decay_end"):
        PPOConfig(final_std=0.1, std_decay_start=5, std_decay_end=1).validate()
    with pytest.raises(ValueError, match="final_std"):
        PPOConfig(final_std=0.0).validate()
    obs = np.zeros((2, 1), np.float32)
    no = np.zeros(2, bool)
    stds = {}
    for c in (cfg, replace(cfg, final_std=None)):
        torch.manual_seed(0)
        agent = PPO(1, 1, 2, c)  # 4 env steps a rollout
        for k in range(1, 101):
            for _ in range(2):
                agent.act(obs)
                agent.process_step(obs, np.ones(2), no, no, {})
            agent.update(obs)
            cap = c.std_cap(4 * k)
            assert cap is None or agent.net.log_std.exp().item() <= cap * (1 + 1e-6)
        stds[c.final_std] = agent.net.log_std.exp().item()
    assert stds[0.05] <= 0.05 * (1 + 1e-6) and stds[None] > 0.3  # uncapped, it stays wide
    # the cap's clock survives a checkpoint
    fresh = PPO(1, 1, 2, cfg)
    fresh.load_extra_state({}, agent.extra_state()[1])
    assert fresh.updates == 100


def test_sac_target_hand_computed() -> None:
    # y = r + gamma (1 - term) (min(Q1', Q2') - alpha log pi), gamma 0.99, alpha 0.2
    #   sample 0: 1 + 0.99 * (min(2.0, 1.5) - 0.2 * -1.0) = 1 + 0.99 * 1.7 = 2.683
    #   sample 1: terminal: 0.5
    y = soft_target(
        torch.tensor([1.0, 0.5]), torch.tensor([0.0, 1.0]), torch.tensor([2.0, 3.0]),
        torch.tensor([1.5, 4.0]), torch.tensor([-1.0, 0.5]), 0.99, 0.2,
    )  # fmt: skip
    np.testing.assert_allclose(y.numpy(), [2.683, 0.5], rtol=1e-6)


def test_sac_stores_final_obs_and_terminal_flags() -> None:
    agent = SAC(2, 1, 3, SACConfig(hidden=(4,), batch_size=2, buffer_size=5, warmup_steps=100))
    obs = np.zeros((3, 2), np.float32)
    nxt = np.ones((3, 2), np.float32)
    final = np.full((3, 2), 7.0, np.float32)
    agent.act(obs)
    term, trunc = np.array([True, False, False]), np.array([False, True, False])
    agent.process_step(nxt, np.array([1.0, 2.0, 3.0]), term, trunc, {"final_obs": final})
    d = agent.buffer.data
    np.testing.assert_array_equal(d["next_obs"][:3, 0], [7.0, 7.0, 1.0])
    np.testing.assert_array_equal(d["terminated"][:3], [1.0, 0.0, 0.0])
    agent.act(obs)
    no = np.zeros(3, bool)
    agent.process_step(nxt, np.zeros(3), no, no, {"final_obs": final})
    assert agent.buffer.size == 5 and agent.buffer.pos == 1  # the ring wrapped


def test_nstep_window_hand_computed() -> None:
    """n = 3, gamma 0.5, two envs; env 1 terminates at step 1, env 0 is truncated at step 3.
    A transition's return sums gamma^j r_{t+j} until n rewards or its episode's end."""
    w = NStepWindow(3, 0.5, 2)
    no = torch.zeros(2, dtype=torch.bool)

    def push(t, r, term=(0.0, 0.0), done=no):
        fields = {"obs": torch.full((2, 1), float(t)), "action": torch.tensor([[0.0], [1.0]])}
        nxt = torch.full((2, 1), 100.0 + t)
        return w.push(fields, torch.tensor(r), nxt, torch.tensor(term), done)

    assert push(0, [1.0, 10.0]) is None
    out = push(1, [2.0, 20.0], (0.0, 1.0), torch.tensor([False, True]))
    # env 1, steps 0 and 1: 10 + 0.5 * 20 = 20 (gamma^2), 20 (gamma), terminal
    np.testing.assert_allclose(out["reward"], [20.0, 20.0])
    np.testing.assert_allclose(out["discount"], [0.25, 0.5])
    np.testing.assert_allclose(out["obs"][:, 0], [0.0, 1.0])
    np.testing.assert_allclose(out["terminated"], [1.0, 1.0])
    np.testing.assert_allclose(out["next_obs"][:, 0], [101.0, 101.0])
    out = push(2, [4.0, 40.0])  # env 0, step 0 has its three rewards: 1 + 1 + 1
    np.testing.assert_allclose(out["reward"], [3.0])
    np.testing.assert_allclose(out["discount"], [0.125])
    np.testing.assert_allclose(out["action"][:, 0], [0.0])
    saved = w.state()
    out = push(3, [8.0, 80.0], (0.0, 0.0), torch.tensor([True, False]))
    # env 0 truncated: steps 1 (2 + 2 + 2), 2 (4 + 4) and 3 (8) close, bootstrapped
    np.testing.assert_allclose(out["reward"], [6.0, 8.0, 8.0])
    np.testing.assert_allclose(out["discount"], [0.125, 0.25, 0.5])
    np.testing.assert_allclose(out["obs"][:, 0], [1.0, 2.0, 3.0])
    np.testing.assert_allclose(out["terminated"], [0.0, 0.0, 0.0])
    # env 1's new episode (steps 2 and 3) waits; a window restored from before step 3
    # gives the same step 3
    restored = NStepWindow(3, 0.5, 2)
    restored.load_state(saved)
    w = restored
    again = push(3, [8.0, 80.0], (0.0, 0.0), torch.tensor([True, False]))
    for k in out:
        assert torch.equal(out[k], again[k]), k
    out = push(4, [16.0, 160.0])  # env 1's step 2 completes: 40 + 40 + 40
    np.testing.assert_allclose(out["reward"], [120.0])
    np.testing.assert_allclose(out["obs"][:, 0], [2.0])
    with pytest.raises(ValueError, match="n >= 1"):
        NStepWindow(0, 0.5, 2)


def test_sac_nstep_stores_discounts_and_the_target_uses_them() -> None:
    cfg = SACConfig(hidden=(4,), batch_size=2, buffer_size=10, warmup_steps=100, n_step=2,
                    gamma=0.9)  # fmt: skip
    agent = SAC(2, 1, 2, cfg)
    obs, nxt, final = (np.full((2, 2), v, np.float32) for v in (0.0, 1.0, 7.0))
    no = np.zeros(2, bool)
    agent.act(obs)
    agent.process_step(nxt, np.array([1.0, 2.0]), no, no, {"final_obs": final})
    assert agent.buffer.size == 0  # both wait for their second reward
    agent.act(obs)
    term = np.array([True, False])
    agent.process_step(nxt, np.array([3.0, 4.0]), term, no, {"final_obs": final})
    d, n = agent.buffer.data, agent.buffer.size
    # env 0 ended: both its steps close (1 + 0.9 * 3, then 3); env 1's first has two rewards
    np.testing.assert_allclose(d["reward"][:n], [1.0 + 0.9 * 3.0, 2.0 + 0.9 * 4.0, 3.0],
                               rtol=1e-6)  # fmt: skip
    np.testing.assert_allclose(d["discount"][:n], [0.81, 0.81, 0.9], rtol=1e-6)
    np.testing.assert_allclose(d["terminated"][:n], [1.0, 0.0, 1.0])
    # the target reads each transition's own discount
    y = soft_target(torch.tensor([1.0, 1.0]), torch.zeros(2), torch.ones(2), torch.ones(2),
                    torch.zeros(2), torch.tensor([0.81, 0.9]), 0.2)  # fmt: skip
    np.testing.assert_allclose(y.numpy(), [1.81, 1.9], rtol=1e-6)
    assert "discount" not in SAC(2, 1, 2, replace(cfg, n_step=1)).buffer.shapes
    with pytest.raises(ValueError, match="n_step >= 1"):
        replace(cfg, n_step=0).validate()


def test_running_norm_matches_numpy() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(3.0, 2.0, (1000, 3))
    norm = RunningNorm(3)
    for chunk in np.array_split(x, 7):
        norm.update(torch.as_tensor(chunk))
    np.testing.assert_allclose(norm.mean.numpy(), x.mean(0), rtol=1e-10)
    np.testing.assert_allclose(norm.var.numpy(), x.var(0), rtol=1e-10)


def test_log_probs() -> None:
    mean, std, a = torch.tensor([[0.0, 1.0]]), torch.tensor([1.0, 2.0]), torch.tensor([[1.0, 1.0]])
    want = -0.5 - 0.5 * math.log(2 * math.pi) + (-math.log(2.0) - 0.5 * math.log(2 * math.pi))
    assert ActorCritic.log_prob(mean, std, a).item() == pytest.approx(want)
    actor = SquashedGaussianActor(3, 2, (8,))
    a, logp = actor(torch.zeros(4, 3))
    assert a.shape == (4, 2) and logp.shape == (4,) and (a.abs() < 1).all()


def test_symlog_obs_reads_millimetres_and_reaches_every_network() -> None:
    """symlog(1000 x): a millimetre is ln 2 near the hole, where the raw input moves by 1e-3;
    far away ten centimetres move it about as much. Every network applies it to the
    observation only (the Q-function's action stays raw), and PPO normalises what it saw."""
    enc = SymlogObs(1000.0)
    x = torch.tensor([0.0, 0.001, -0.001, 0.1, 0.2])
    y = enc(x)
    assert y[1].item() == pytest.approx(math.log(2.0)) and y[2].item() == -y[1].item()
    assert (y[4] - y[3]).item() == pytest.approx(math.log(201 / 101))  # 10 cm, far out
    assert torch.equal(SymlogObs(None)(x), x)
    torch.manual_seed(0)
    obs = torch.randn(16, 18) * 0.01
    act = torch.rand(16, 6) * 2 - 1
    q = QNetwork(18, 6, (8,), obs_symlog_scale=1000.0)
    with torch.no_grad():
        want = q.net(torch.cat([symlog_ref(1000.0 * obs), act], -1)).squeeze(-1)
        assert torch.allclose(q(obs, act), want)
        actor = SquashedGaussianActor(18, 6, (8,), obs_symlog_scale=1000.0)
        mean = actor.net(symlog_ref(1000.0 * obs)).chunk(2, -1)[0]
        assert torch.allclose(actor(obs, deterministic=True)[0], torch.tanh(mean))
    ppo = PPO(18, 6, 4, PPOConfig(hidden=(8,), horizon=4, minibatch_size=16, epochs=1,
                                 obs_symlog_scale=1000.0))  # fmt: skip
    for _ in range(4):
        ppo.act(obs[:4].numpy())
        ppo.process_step(obs[4:8].numpy(), np.zeros(4), np.zeros(4, bool), np.zeros(4, bool),
                         {"final_obs": obs[4:8].numpy()})  # fmt: skip
    ppo.update(obs[8:12].numpy())
    seen = symlog_ref(1000.0 * obs[:4]).double()
    assert torch.allclose(ppo.net.obs_norm.mean, seen.mean(0), atol=1e-6)
    with pytest.raises(ValueError, match="obs_symlog_scale"):
        PPOConfig(obs_symlog_scale=0.0).validate()
    with pytest.raises(ValueError, match="obs_symlog_scale"):
        SACConfig(obs_symlog_scale=-1.0).validate()


def symlog_ref(x: torch.Tensor) -> torch.Tensor:
    return torch.sign(x) * torch.log1p(x.abs())


def test_layer_norm_bounds_q_on_far_out_observations() -> None:
    # With LayerNorm the last hidden features have norm <= sqrt(H) (unit variance, ReLU only
    # shrinks), so |Q| <= ||w_last|| sqrt(H) + |b_last| for any input; without it Q grows
    # linearly with the input's scale (a peg metres from its hole).
    torch.manual_seed(0)
    obs = torch.randn(64, 18) * 1e4
    act = torch.rand(64, 6) * 2 - 1
    q_ln = QNetwork(18, 6, (32, 32), layer_norm=True)
    last = q_ln.net[-1]
    bound = last.weight.norm() * math.sqrt(32) + last.bias.abs().sum()
    with torch.no_grad():
        assert q_ln(obs, act).abs().max() <= bound
        assert QNetwork(18, 6, (32, 32))(obs, act).abs().max() > 10 * bound


@pytest.mark.parametrize("algo", ["ppo", "sac", "random"])
@pytest.mark.parametrize("stack", [1, 3])
def test_smoke_train(algo: str, stack: int, tmp_path) -> None:
    from rl.presets import Setup
    from rl.random_agent import RandomConfig

    cfg = {
        "ppo": PPOConfig(hidden=(16, 16), horizon=8, minibatch_size=32, epochs=2),
        "sac": SACConfig(hidden=(16, 16), batch_size=16, buffer_size=500, warmup_steps=32,
                         gradient_steps=0.5, steps_per_iteration=8, layer_norm=stack > 1,
                         max_grad_norm=1.0),
        "random": RandomConfig(steps_per_iteration=8),
    }[algo]  # fmt: skip
    env = ToyEnv(4, max_steps=10)
    r = train(algo, env, Setup(cfg, 4, 256, 128), seed=1, out_dir=tmp_path, stack=stack,
              progress=False, tensorboard=False)  # fmt: skip
    assert r["status"] == "done" and r["env_steps"] == 256 and r["iterations"] == 8
    assert r["episodes"] > 0 and math.isfinite(r["metrics"]["return_mean"])
    lines = (tmp_path / "metrics.csv").read_text().splitlines()
    assert len(lines) == 1 + 8
    if algo == "sac":
        assert r["metrics"]["q_loss"] > 0
        assert r["metrics"]["q_grad_norm"] > 0 and r["metrics"]["pi_grad_norm"] > 0


def test_random_agent_is_seeded() -> None:
    obs = np.zeros((5, 3))
    a, b = RandomAgent(2, seed=4)(obs), RandomAgent(2, seed=4)(obs)
    np.testing.assert_array_equal(a, b)
    assert a.shape == (5, 2) and np.abs(a).max() <= 1


def test_q_filter_keeps_samples_where_the_teacher_is_rated_higher() -> None:
    """Critics Q(s, a) = -|a - s| (the best action is the observation): the filter keeps a
    sample only where the teacher's action is nearer the best than the policy's; with two
    critics the lower one decides."""

    class Critic(torch.nn.Module):
        def __init__(self, shift: float) -> None:
            super().__init__()
            self.shift = shift

        def forward(self, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
            return -(action - obs).abs().sum(-1) + self.shift * action.sum(-1)

    obs = torch.tensor([[0.0], [0.0], [0.5], [0.5]])
    teacher = torch.tensor([[0.1], [0.9], [0.5], [0.0]])
    policy = torch.tensor([[0.5], [0.2], [0.0], [0.5]])
    keep = q_filter(Critic(0.0), Critic(0.0), obs, teacher, policy)
    assert keep.tolist() == [1.0, 0.0, 1.0, 0.0]
    # equal ratings are not kept: nothing to learn from the teacher there
    assert q_filter(Critic(0.0), Critic(0.0), obs, policy, policy).sum() == 0
    # the lower critic decides: Q2 = Q1 + a is above Q1 for these actions (all >= 0), so
    # min(Q1, Q2) = Q1 and nothing changes; Q2 = Q1 - 2 a is below, and favours small
    # actions: sample 2 (teacher 0.5 against 0.0) leaves, sample 3 (0.0 against 0.5) joins
    assert q_filter(Critic(0.0), Critic(1.0), obs, teacher, policy).tolist() == keep.tolist()
    assert q_filter(Critic(0.0), Critic(-2.0), obs, teacher, policy).tolist() == [1, 0, 0, 1]
