"""Modules replayed by their failures: the rule, the rotating env that follows it, resume,
bad input."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sim.task.config import TaskConfig
from sim.task.module_replay import ModuleReplay
from tests.test_cli import run as cli
from tests.test_sim_common import debug_train_args, make_env, quiet, sim_dataset


def test_scores_follow_the_episodes_and_picks_follow_the_scores() -> None:
    r = ModuleReplay(4, share=1.0, rate=0.5)
    assert r.failure.tolist() == [1.0] * 4  # unplayed modules count as failing
    # envs 0-2 on modules 2, 2, 3; env 2 still running: only done episodes count, in order
    r.update(np.array([2, 2, 3]), np.array([True, True, False]), np.array([True, False, True]))
    assert r.failure[2] == pytest.approx(0.75) and r.episodes.tolist() == [0, 0, 2, 0]
    assert r.failure[3] == 1.0
    r.failure[:] = [0.0, 0.0, 0.0, 1.0]
    picks = [r.pick(np.random.default_rng(s), [0, 1, 3]) for s in range(400)]
    # weights 0.02, 0.02, 1.02: module 3, at position 2, nearly always
    assert picks.count(2) / 400 == pytest.approx(1.02 / 1.06, abs=0.05)
    half = ModuleReplay(4, share=0.5)
    half.failure[:] = [0.0, 0.0, 0.0, 1.0]
    fronts = [half.pick(np.random.default_rng(s), [3, 0, 1]) for s in range(400)]
    # the plain turns (half the picks) take the front, here the failing module too
    assert fronts.count(0) / 400 > 0.9
    fronts = [half.pick(np.random.default_rng(s), [0, 1, 3]) for s in range(400)]
    assert fronts.count(0) / 400 == pytest.approx(0.5 + 0.5 * 0.02 / 1.06, abs=0.07)


@pytest.mark.parametrize("kw", [{"share": 0.0}, {"share": 1.5}, {"rate": 0.0}, {"floor": 0.0}])
def test_bad_settings_are_named(kw) -> None:
    with pytest.raises(ValueError, match=f"module replay {next(iter(kw))} = "):
        ModuleReplay(4, **({"share": 0.5} | kw))
    if "share" in kw:
        with pytest.raises(ValueError, match="module_replay"):
            TaskConfig(module_replay=kw["share"]).validate()


def test_the_rotating_env_takes_the_failing_module_next_and_resumes_its_scores() -> None:
    cfg = replace(quiet(), module_replay=1.0)
    env = make_env(4, cfg, num_envs=1, rotate_modules=True)
    env.reset(seed=0)
    first = int(env.env_module[0])
    replay = env.module_replay
    replay.floor = 1e-12
    replay.failure[:] = 0.0
    target = env.module_queue[-1]  # the last in line: in turn it would come after two others
    assert env.module_queue[0] != target
    replay.failure[target] = 1.0
    env.set_peg_poses(np.array([0]), env.bottom[[0]])  # on its seat: succeeds at once
    _, _, term, _, info = env.step(np.zeros((1, 6)))
    assert term[0] and info["success"][0] and info["module"][0] == first
    assert replay.episodes[first] == 1 and replay.failure[first] == 0.0
    assert int(env.env_module[0]) == target  # not the queue's front: the failing module
    # the scores travel with the env's state, and only to an env that replays
    state = env.get_state()
    other = make_env(4, cfg, num_envs=1, rotate_modules=True)
    other.set_state(state)
    assert other.module_replay.failure.tolist() == replay.failure.tolist()
    assert other.module_replay.episodes.tolist() == replay.episodes.tolist()
    with pytest.raises(ValueError, match="module replay"):
        make_env(4, quiet(), num_envs=1, rotate_modules=True).set_state(state)


def test_an_env_that_does_not_rotate_refuses_it() -> None:
    with pytest.raises(ValueError, match=r"module_replay = 0\.5: .* in turns"):
        make_env(2, replace(quiet(), module_replay=0.5))


def test_the_env_on_the_device_refuses_it() -> None:
    pytest.importorskip("mujoco_warp")
    from sim.engines.warp.env import make_device_train_env

    with pytest.raises(ValueError, match="host env only"):
        make_device_train_env(str(sim_dataset()), 2, 0, module_replay=0.5)


def test_train_takes_it_refuses_bad_shares_and_keeps_it_on_resume(tmp_path) -> None:
    base = debug_train_args()
    p = cli(*base, "--module-replay", "0.5", "--out", str(tmp_path / "run"))
    assert p.returncode == 0, p.stderr
    p = cli(*base, "--module-replay", "1.5", "--out", str(tmp_path / "bad"))
    assert p.returncode != 0 and "--module-replay 1.5: give the share" in p.stdout + p.stderr
    p = cli(*base, "--resume", "--out", str(tmp_path / "run"))
    assert p.returncode != 0 and "module_replay" in p.stdout + p.stderr
