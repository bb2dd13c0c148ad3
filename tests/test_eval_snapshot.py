"""A cut evaluation resumed from its snapshot ends as an uncut one, episode for episode."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from evaluation.protocol import evaluate
from evaluation.snapshots import EvalSnapshots, snapshot_progress
from rl.agents import acting_state_hooks, reset_hook
from rl.dreamer.agent import Dreamer
from sim.task.expert import direct_expert_action
from tests.test_dreamer import TINY
from tests.test_sim_common import make_env, quiet


class _Cut(Exception):
    """The machine stopping mid-evaluation."""


class _CutAfter(EvalSnapshots):
    def __init__(self, path: Path, key: dict, saves: int) -> None:
        super().__init__(path, key, every_s=0.0)
        self.left = saves

    def save(self, state: dict) -> None:
        super().save(state)
        self.left -= 1
        if self.left == 0:
            raise _Cut


def _policy(obs: np.ndarray) -> np.ndarray:
    """The expert with torch-drawn noise: sampled actions, as --stochastic gives."""
    noise = torch.randn(len(obs), 6, dtype=torch.float64).numpy()
    return direct_expert_action(obs) + 0.5 * noise


def _env():
    # 3 envs in shards of 2, short episodes: some succeed, some are cut, and envs finish
    # their attempts at different steps (the parked tail is part of the state)
    return make_env(3, replace(quiet(), noise=True, max_steps=90), shard_size=2)


def _run(snapshots: EvalSnapshots | None, torch_seed: int) -> dict:
    torch.manual_seed(torch_seed)
    env = _env()
    return evaluate(_policy, env, 4, seed=1, live=env.set_live, snapshots=snapshots)


def test_a_cut_evaluation_resumes_to_the_uncut_result(tmp_path: Path) -> None:
    key = {"run": "r", "seed": 1}
    path = tmp_path / "eval.json.partial.safetensors"
    whole = _run(None, torch_seed=0)
    assert 0 < whole["successes"] < whole["episodes"] and whole["truncation_rate"] > 0
    with pytest.raises(_Cut):
        _run(_CutAfter(path, key, saves=340), torch_seed=0)
    saved = EvalSnapshots(path, key).load()
    assert saved is not None and 0 < len(saved["returns"]) < whole["episodes"]
    progress = snapshot_progress(path)  # from the file's header (table3 --plan)
    assert progress == {"episodes": len(saved["returns"]), "seconds": saved["seconds"]}
    assert snapshot_progress(tmp_path / "none") is None
    assert 0 < saved["steps"] and "live" in saved["env"]  # cut in the parked tail
    # another torch seed: the snapshot's RNG state must replace it
    resumed = _run(EvalSnapshots(path, key, every_s=0.0), torch_seed=7)
    for k in whole:
        if k != "seconds":
            assert resumed[k] == whole[k], k


def test_a_snapshot_of_another_evaluation_is_set_aside(tmp_path: Path, capsys) -> None:
    path = tmp_path / "e.partial.safetensors"
    with pytest.raises(_Cut):
        _run(_CutAfter(path, {"seed": 1}, saves=3), torch_seed=0)
    assert EvalSnapshots(path, {"seed": 2}).load() is None
    assert "another evaluation" in capsys.readouterr().err
    assert EvalSnapshots(path, {"seed": 1}).load() is not None
    assert "resuming after" in capsys.readouterr().err
    path.write_bytes(path.read_bytes()[:-100])  # cut off mid-write by an older version
    assert EvalSnapshots(path, {"seed": 1}).load() is None
    assert "starting from the first episode" in capsys.readouterr().err
    EvalSnapshots(path, {}).clear()
    assert not path.exists()


def _run_recurrent(snapshots: EvalSnapshots | None, torch_seed: int, restore: bool = True):
    """An untrained DreamerV3 steering the expert: its actions depend on its recurrent state
    and on latents drawn from torch's RNG."""
    torch.manual_seed(0)
    env = _env()
    agent = Dreamer(env.obs_dim, env.act_dim, env.num_envs, TINY, seed=0)
    torch.manual_seed(torch_seed)
    hooks = acting_state_hooks(agent)
    assert hooks is not None
    if not restore:  # a resume that forgets the policy's state
        hooks = (hooks[0], lambda state: None)

    def policy(obs: np.ndarray) -> np.ndarray:
        return direct_expert_action(obs) + 0.5 * agent.policy(obs, deterministic=False)

    return evaluate(policy, env, 3, seed=1, live=env.set_live, reset=reset_hook(agent),
                    snapshots=snapshots, policy_state=hooks)  # fmt: skip


def test_a_recurrent_policys_evaluation_resumes_with_its_acting_state(tmp_path: Path) -> None:
    key = {"run": "dreamer"}
    path = tmp_path / "eval.json.partial.safetensors"
    whole = _run_recurrent(None, torch_seed=0)
    for restore in (True, False):
        path.unlink(missing_ok=True)  # the resumed run saved itself to its last steps
        with pytest.raises(_Cut):
            _run_recurrent(_CutAfter(path, key, saves=60), torch_seed=0)
        saved = EvalSnapshots(path, key).load()
        assert saved is not None and set(saved["policy"]) >= {"deter", "stoch", "first"}
        resumed = _run_recurrent(EvalSnapshots(path, key, every_s=0.0), 7, restore)
        same = [resumed[k] == whole[k] for k in whole if k != "seconds"]
        # restored, every field agrees; forgotten, the episodes after the cut differ
        assert all(same) if restore else not all(same)


def test_snapshots_refuse_a_policy_with_episode_state(tmp_path: Path) -> None:
    env = _env()
    with pytest.raises(ValueError, match="a reset hook comes with policy_state"):
        evaluate(_policy, env, 1, reset=lambda done: None,
                 snapshots=EvalSnapshots(tmp_path / "s.npz", {}))  # fmt: skip
    with pytest.raises(ValueError, match="every_s = -1"):
        EvalSnapshots(tmp_path / "s.npz", {}, every_s=-1)
