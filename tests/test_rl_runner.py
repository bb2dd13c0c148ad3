"""The runner: exact resume, NaN handling, logs; presets; the evaluation protocol; commands."""

from __future__ import annotations

import argparse
import csv
import json
import math
from dataclasses import replace

import numpy as np
import pytest
import torch

from evaluation.command import eval_main
from evaluation.protocol import evaluate
from rl import checkpoint as ckpt
from rl.commands import add_train_parser
from rl.ppo import PPOConfig
from rl.presets import PRESETS, Setup, get_setup
from rl.run_state import CHECKPOINT, load_agent
from rl.runner import train
from rl.sac import SACConfig
from rl.stack import StackObs
from tests.toy_env import StatefulToyEnv, ToyEnv

torch.set_num_threads(1)

# 4 envs; PPO: 8 steps per iteration (32 env steps), checkpoint every 2 iterations
PPO_SETUP = Setup(PPOConfig(hidden=(16,), horizon=8, minibatch_size=16, epochs=2), 4, 256, 64)
SAC_SETUP = Setup(
    SACConfig(hidden=(16,), batch_size=16, buffer_size=100, warmup_steps=24,
              steps_per_iteration=8, learn_entropy=True, gradient_steps=1.0),
    4, 256, 64,
)  # fmt: skip
SAC_N3_SETUP = Setup(replace(SAC_SETUP.config, n_step=3), 4, 256, 64)
SAC_PINK_SETUP = Setup(replace(SAC_SETUP.config, exploration="pink", noise_period=12), 4, 256, 64)


class Interrupt:
    """Wraps an env; raises KeyboardInterrupt (like Ctrl-C or a kill) at step `at`."""

    def __init__(self, env, at: int) -> None:
        self.env, self.at, self.n = env, at, 0
        self.num_envs, self.obs_dim, self.act_dim = env.num_envs, env.obs_dim, env.act_dim
        if hasattr(env, "get_state"):
            self.get_state, self.set_state = env.get_state, env.set_state

    def reset(self, seed=None):
        return self.env.reset(seed)

    def step(self, actions):
        self.n += 1
        if self.n == self.at:
            raise KeyboardInterrupt
        return self.env.step(actions)


class NaNAfter(Interrupt):
    """Rewards become NaN from step `at` on."""

    def step(self, actions):
        self.n += 1
        out = self.env.step(actions)
        return (out[0], out[1] * np.nan if self.n >= self.at else out[1], *out[2:])


def _weights(run_dir) -> dict[str, torch.Tensor]:
    agent, _ = load_agent(run_dir, "cpu")
    return {
        f"{name}.{k}": v
        for name, m in agent.modules().items()
        if isinstance(m, torch.nn.Module)
        for k, v in m.state_dict().items()
    }


def _train(algo, env, setup, out, **kw):
    return train(algo, env, setup, seed=3, out_dir=out, progress=False, tensorboard=False, **kw)


@pytest.mark.parametrize(
    ("algo", "env_cls", "stack"),
    [("ppo", StatefulToyEnv, 1), ("ppo", ToyEnv, 2), ("sac", StatefulToyEnv, 2),
     ("sac", ToyEnv, 1), ("sac-n3", ToyEnv, 1), ("sac-pink", ToyEnv, 1)],
)  # fmt: skip
def test_interrupted_and_resumed_run_matches_uninterrupted(algo, env_cls, stack, tmp_path):
    """... also with n-step returns, whose open steps the checkpoint must carry, and with
    pink exploration noise, whose stream (cut mid-sequence: period 12) it must carry."""
    setup = {"ppo": PPO_SETUP, "sac": SAC_SETUP, "sac-n3": SAC_N3_SETUP,
             "sac-pink": SAC_PINK_SETUP}[algo]  # fmt: skip
    algo = algo.split("-")[0]
    full = _train(algo, env_cls(4), setup, tmp_path / "full", stack=stack, steps=256)
    assert full["status"] == "done" and full["iterations"] == 8
    # killed in iteration 4 (steps 25-32): the checkpoint of iteration 2 is what survives
    part = _train(algo, Interrupt(env_cls(4), 28), setup, tmp_path / "cut", stack=stack,
                  steps=256)  # fmt: skip
    assert part["status"] == "interrupted" and part["iterations"] == 3
    resumed = _train(algo, env_cls(4), setup, tmp_path / "cut", stack=stack, steps=256,
                     resume=True)  # fmt: skip
    assert resumed["status"] == "done" and resumed["env_steps"] == 256
    a, b = _weights(tmp_path / "full"), _weights(tmp_path / "cut")
    assert a.keys() == b.keys()
    for k in a:
        assert torch.equal(a[k], b[k]), k
    rows = list(csv.DictReader(open(tmp_path / "cut" / "metrics.csv")))
    assert [int(r["iteration"]) for r in rows] == list(range(1, 9))  # no duplicated rows
    full_rows = list(csv.DictReader(open(tmp_path / "full" / "metrics.csv")))
    assert rows[-1]["return_mean"] == full_rows[-1]["return_mean"]


def test_stateful_env_resumes_exactly_from_any_iteration(tmp_path) -> None:
    full = _train("ppo", StatefulToyEnv(4), PPO_SETUP, tmp_path / "full", steps=160)
    _train("ppo", StatefulToyEnv(4), PPO_SETUP, tmp_path / "cut", steps=96)  # stops at 3
    _train("ppo", StatefulToyEnv(4), PPO_SETUP, tmp_path / "cut", steps=160, resume=True)
    assert full["iterations"] == 5
    a, b = _weights(tmp_path / "full"), _weights(tmp_path / "cut")
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_a_checkpoint_every_few_minutes_on_a_stateful_env(tmp_path) -> None:
    """A run killed between its periodic checkpoints loses only what followed the last
    clock checkpoint (here: every iteration), and still resumes to the uncut weights."""
    full = _train("ppo", StatefulToyEnv(4), PPO_SETUP, tmp_path / "full", steps=256)
    assert full["status"] == "done" and full["iterations"] == 8
    cut = _train("ppo", Interrupt(StatefulToyEnv(4), 28), PPO_SETUP, tmp_path / "cut",
                 steps=256, checkpoint_minutes=1e-9)  # fmt: skip
    assert cut["status"] == "interrupted" and cut["iterations"] == 3
    assert ckpt.load(tmp_path / "cut" / CHECKPOINT)[1]["counters"]["iteration"] == 3
    _train("ppo", StatefulToyEnv(4), PPO_SETUP, tmp_path / "cut", steps=256, resume=True)
    a, b = _weights(tmp_path / "full"), _weights(tmp_path / "cut")
    assert all(torch.equal(a[k], b[k]) for k in a)
    # an env without get_state keeps its checkpoints on checkpoint_steps (iteration 2)
    _train("ppo", Interrupt(ToyEnv(4), 28), PPO_SETUP, tmp_path / "plain", steps=256,
           checkpoint_minutes=1e-9)  # fmt: skip
    assert ckpt.load(tmp_path / "plain" / CHECKPOINT)[1]["counters"]["iteration"] == 2
    with pytest.raises(ValueError, match="checkpoint_minutes = 0"):
        _train("ppo", ToyEnv(4), PPO_SETUP, tmp_path / "bad", steps=64, checkpoint_minutes=0)


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_nan_loss_stops_and_keeps_last_good_checkpoint(algo, tmp_path, capsys) -> None:
    setup = PPO_SETUP if algo == "ppo" else SAC_SETUP
    before = _train(algo, ToyEnv(4), setup, tmp_path / "ref", steps=64)  # 2 iterations
    r = _train(algo, NaNAfter(ToyEnv(4), 20), setup, tmp_path / "run", steps=256)
    assert r["status"] == "nan" and r["iterations"] == 2
    err = " ".join(capsys.readouterr().err.split())  # rich may wrap lines
    assert "training stopped at iteration 3" in err and "iteration 2 is kept" in err
    w, ref = _weights(tmp_path / "run"), _weights(tmp_path / "ref")
    assert before["iterations"] == 2
    for k in w:  # the kept checkpoint is the good one of iteration 2
        assert torch.isfinite(w[k]).all() and torch.equal(w[k], ref[k]), k


def test_minutes_is_the_whole_runs_budget_across_resumes(tmp_path) -> None:
    """--minutes counts from the run's start, as --steps does: resumed with the budget its
    checkpoint already spent, a run stops at once; with more, it goes on."""
    _train("ppo", ToyEnv(4), PPO_SETUP, tmp_path, steps=64)
    spent = ckpt.load(tmp_path / CHECKPOINT)[1]["counters"]["wall_s"]
    assert spent > 0
    r = _train("ppo", ToyEnv(4), PPO_SETUP, tmp_path, minutes=spent / 60, resume=True)
    assert r["iterations"] == 2 and r["env_steps"] == 64  # nothing left to spend
    r = _train("ppo", ToyEnv(4), PPO_SETUP, tmp_path, minutes=spent / 60 + 1e-4, resume=True)
    assert r["iterations"] > 2


def test_minutes_budget_and_csv(tmp_path) -> None:
    r = _train("ppo", ToyEnv(4), PPO_SETUP, tmp_path, minutes=1e-9)
    assert r["status"] == "done" and r["iterations"] == 0 and r["checkpoint"] is not None
    r = _train("ppo", ToyEnv(4), PPO_SETUP, tmp_path, steps=64, resume=True)
    assert r["iterations"] == 2
    rows = list(csv.DictReader(open(tmp_path / "metrics.csv")))
    assert len(rows) == 2 and float(rows[-1]["env_steps"]) == 64
    assert math.isfinite(float(rows[-1]["policy_loss"]))
    cfg = json.loads((tmp_path / "config.json").read_text())
    assert cfg["algo"] == "ppo" and cfg["device"] == "cpu"


def test_presets() -> None:
    ppo, sac = get_setup("paper", "ppo"), get_setup("paper", "sac")
    # paper Table II
    assert ppo.config.hidden == sac.config.hidden == (512, 512)
    assert (ppo.config.learning_rate, sac.config.learning_rate) == (3e-4, 8e-5)
    assert ppo.config.gamma == sac.config.gamma == 0.997
    assert (ppo.config.minibatch_size, sac.config.batch_size) == (8192, 4096)
    assert (ppo.config.horizon, ppo.config.epochs, sac.config.gradient_steps) == (128, 8, 8)
    assert ppo.config.entropy_coef == sac.config.entropy_coef == 3e-4
    assert not sac.config.learn_entropy
    assert (sac.config.buffer_size, sac.config.warmup_steps) == (20_000_000, 500_000)
    assert (ppo.config.gae_lambda, ppo.config.clip, sac.config.tau) == (0.95, 0.2, 0.005)
    assert ppo.num_envs == sac.num_envs == 1024 and ppo.total_steps == 100_000_000
    for name, algos in PRESETS.items():
        for algo, setup in algos.items():
            if algo != "random":
                setup.config.validate()
            assert setup.num_envs >= 1, (name, algo)
    with pytest.raises(ValueError, match=r"unknown preset 'gpu'; valid presets: \['cpu', "):
        get_setup("gpu", "ppo")
    with pytest.raises(ValueError, match="unknown algorithm 'dqn'"):
        get_setup("cpu", "dqn")


def test_every_preset_sets_up_every_registered_algorithm() -> None:
    """The algorithm registry's names are the presets' keys, each with its own config."""
    from rl.algorithms import ALGOS, config_class

    for name, algos in PRESETS.items():
        assert set(algos) == set(ALGOS), name
        for algo, setup in algos.items():
            assert isinstance(setup.config, config_class(algo)), (name, algo)


def test_evaluate_counts_exact_episodes_per_env() -> None:
    env = ToyEnv(3, max_steps=40)
    res = evaluate(lambda o: np.clip(o[:, 2:] * 10, -1, 1), env, 4, seed=0)  # go to the goal
    assert res["episodes"] == 12 and len(res["per_env_success_rate"]) == 3
    assert res["success_rate"] > 0.5 and len(res["time_to_success_s"]) == res["successes"]
    assert res["median_time_to_success_s"] > 0
    idle = evaluate(lambda o: np.zeros((len(o), 2)), StackObs(ToyEnv(2, max_steps=5), 3), 2)
    assert idle["truncation_rate"] + idle["success_rate"] == pytest.approx(1.0)
    assert idle["mean_length"] <= 5
    with pytest.raises(RuntimeError, match="max_steps"):
        evaluate(lambda o: np.zeros((len(o), 2)), ToyEnv(2, max_steps=50), 1, max_steps=3)


def test_evaluate_tells_the_env_which_envs_still_count() -> None:
    """Before each step `live` gets the envs short of their episodes (env 0's episodes end
    at once, env 1's take 5 steps), and None when the evaluation ends."""
    env = ToyEnv(2, max_steps=5)
    seen: list = []

    def policy(o: np.ndarray) -> np.ndarray:
        env.pos[0] = env.goal[0]  # env 0 sits on its goal: every episode a one-step success
        return np.zeros((len(o), 2))

    res = evaluate(
        policy, env, 3, seed=0, live=lambda m: seen.append(None if m is None else m.copy())
    )
    assert res["per_env_success_rate"][0] == 1.0 and res["env_steps"] == 2 * 15
    assert seen[-1] is None and len(seen) == 16
    assert [m.tolist() for m in seen[:4]] == [[True, True]] * 3 + [[False, True]]
    assert all(m.tolist() == [False, True] for m in seen[3:15])


def test_commands(tmp_path, capsys) -> None:
    made = []

    def make_env(dataset: str, num_envs: int, seed: int, **task):
        made.append((dataset, num_envs, seed, task))
        return ToyEnv(num_envs or 2)  # evaluation: None = the env decides

    parser = argparse.ArgumentParser(prog="assetgen")
    sub = parser.add_subparsers(dest="command", required=True)
    add_train_parser(sub, make_env)
    out = tmp_path / "run"
    argv = ["train", "--algo", "ppo", "--stack", "2", "--dataset", "toy", "--preset", "cpu",
            "--steps", "100", "--envs", "2", "--seed", "5", "--out", str(out),
            "--no-progress", "--json"]  # fmt: skip
    args = parser.parse_args(argv)
    assert args.func(args) == 0
    res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert res["status"] == "done" and res["env_steps"] == 128
    curriculum = get_setup("cpu", "ppo").curriculum_steps
    assert made[-1] == ("toy", 2, 5, {"curriculum_steps": curriculum, "keep_physics": False})
    meta = json.loads((out / "config.json").read_text())
    assert meta["env_options"] == {"curriculum_steps": curriculum}
    args = argparse.Namespace(run=out, dataset="toy", episodes=1, envs=None, seed=0, device=None,
                              stochastic=False, json=True, out=None)  # fmt: skip
    assert eval_main(args, make_env) == 0
    ev = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert ev["algo"] == "ppo" and ev["stack"] == 2 and ev["episodes"] == 2
    assert ev["policy"] == "deterministic" and ev["attempts"] == 1
    args = parser.parse_args(argv)  # the folder holds a run: refused, with a clear message
    assert args.func(args) == 2
    assert "already holds a run" in " ".join(capsys.readouterr().err.split())
    with pytest.raises(SystemExit):
        parser.parse_args([*argv, "--minutes", "1"])  # --steps and --minutes exclude each other
    # resuming with another curriculum is refused, naming it
    args = parser.parse_args([*argv, "--resume", "--curriculum-steps", "7"])
    assert args.func(args) == 2
    assert "env_options.curriculum_steps" in " ".join(capsys.readouterr().err.split())
    args = parser.parse_args(
        [*argv[:-2], "--out", str(tmp_path / "r2"), "--curriculum-steps", "-1"]
    )
    assert args.func(args) == 2
    assert "--curriculum-steps -1" in " ".join(capsys.readouterr().err.split())
    args = parser.parse_args(
        [*argv[:-2], "--out", str(tmp_path / "r3"), "--checkpoint-minutes", "0"]
    )
    assert args.func(args) == 2
    assert "--checkpoint-minutes 0.0: give a positive" in " ".join(capsys.readouterr().err.split())


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_exported_policy_acts_like_the_run_and_is_small(algo, tmp_path) -> None:
    from rl.checkpoint import CheckpointError
    from rl.export import export_policy

    setup = PPO_SETUP if algo == "ppo" else SAC_SETUP
    run = tmp_path / "run"
    _train(algo, ToyEnv(4), setup, run, stack=2, steps=256)
    (run / "eval_test.json").write_text("{}")
    res = export_policy(run, tmp_path / "policy")
    assert set(res["files"]) == {"checkpoint.safetensors", "config.json", "metrics.csv",
                                 "eval_test.json"}  # fmt: skip
    full = (run / "checkpoint.safetensors").stat().st_size
    assert res["files"]["checkpoint.safetensors"] < full / 2  # no optimiser, no replay
    a, meta_a = load_agent(run, "cpu")
    b, meta_b = load_agent(tmp_path / "policy", "cpu")
    assert meta_a == meta_b
    obs = np.random.default_rng(0).normal(size=(5, meta_a["obs_dim"])).astype(np.float32)
    np.testing.assert_array_equal(a.policy(obs), b.policy(obs))
    with pytest.raises(CheckpointError, match="exists"):
        export_policy(run, tmp_path / "policy")
    with pytest.raises(CheckpointError, match="already an exported policy"):
        export_policy(tmp_path / "policy", tmp_path / "again")
    with pytest.raises(CheckpointError, match="cannot resume"):
        _train(algo, ToyEnv(4), setup, tmp_path / "policy", stack=2, steps=512, resume=True)
