"""The success-gated spawn curriculum: its rule, the env that follows it, resume, bad input."""

from __future__ import annotations

import csv
from dataclasses import replace

import numpy as np
import pytest

from sim.task.config import TaskConfig
from sim.task.curriculum import SuccessCurriculum
from tests.test_cli import run as cli
from tests.test_sim_common import debug_train_args, make_env, quiet, sim_dataset


def _outcomes(c: SuccessCurriculum, successes: list[bool]) -> None:
    """Episodes ending one per step in env 0 of a 1-env batch."""
    for ok in successes:
        c.update(np.array([True]), np.array([ok]))


def test_the_rule_rises_at_the_target_falls_below_half_and_holds_between() -> None:
    c = SuccessCurriculum(target=0.75, increment=0.25, window=4)
    _outcomes(c, [True, True, True, False])  # 3 of 4 = the target: up
    assert c.level == 0.25 and (c.episodes, c.successes) == (0, 0)
    _outcomes(c, [True, True, False, False])  # 2 of 4: between half the target and it
    assert c.level == 0.25
    _outcomes(c, [True, False, False, False])  # 1 of 4 < 0.375: down
    assert c.level == 0.0
    _outcomes(c, [False] * 8)  # never below 0
    assert c.level == 0.0
    _outcomes(c, [True] * 40)  # never above 1
    assert c.level == 1.0
    _outcomes(c, [True, True])  # a window in progress is kept
    assert (c.episodes, c.successes) == (2, 2)


def test_episodes_count_in_env_order_and_only_when_done() -> None:
    c = SuccessCurriculum(target=1.0, increment=0.5, window=2)
    # env 1 is not done: its success flag does not count; envs 0 and 2 fill the window
    c.update(np.array([True, False, True]), np.array([True, True, True]))
    assert c.level == 0.5 and c.episodes == 0
    # three episodes end at once: the first two decide (up), the third starts a window
    c.update(np.array([True, True, True]), np.array([True, True, False]))
    assert c.level == 1.0 and (c.episodes, c.successes) == (1, 0)
    state = c.state()
    d = SuccessCurriculum(target=1.0, increment=0.5, window=2)
    d.load(state)
    assert (d.level, d.episodes, d.successes) == (1.0, 1, 0)


@pytest.mark.parametrize(
    ("kw", "name"),
    [({"target": 0.0}, "target"), ({"target": 1.5}, "target"), ({"increment": 0.0}, "increment"),
     ({"window": 0}, "window")],
)  # fmt: skip
def test_bad_settings_are_named(kw, name) -> None:
    with pytest.raises(ValueError, match=f"curriculum {name} = "):
        SuccessCurriculum(**({"target": 0.8} | kw))
    with pytest.raises(ValueError, match="curriculum"):
        TaskConfig(**{f"curriculum_{'success' if name == 'target' else name}": kw[name]}).validate()


def test_the_env_widens_its_spawns_when_its_episodes_succeed() -> None:
    """A peg put on its seat succeeds at the next step; with a window of one episode the
    curriculum steps up at once, and that env's new episode spawns at the wider scale."""
    cfg = replace(quiet(), curriculum_success=1.0, curriculum_increment=0.5, curriculum_window=1)
    env = make_env(2, cfg)
    obs = env.reset(seed=0)
    assert env.curriculum_scale() == 0.0
    assert np.abs(obs[:, :2]).max() < 1e-9  # at the entrance, as at the start of any curriculum
    env.set_peg_poses(np.array([0]), env.bottom[[0]])
    obs, _, term, trunc, info = env.step(np.zeros((2, 6)))
    assert info["success"][0] and not (term[1] or trunc[1])
    assert env.curriculum_scale() == 0.5
    assert np.abs(obs[0, :2]).max() > 1e-3  # env 0 spawned off the axis, within half range
    assert np.abs(obs[0, :2]).max() <= 0.5 * cfg.spawn_xy + 1e-6
    assert np.abs(obs[1, :2]).max() < 1e-3  # env 1 goes on from the entrance
    # its state travels with the env's (exact resume), and only to an env that has one
    state = env.get_state()
    assert state["curriculum"].tolist() == [0.5, 0.0, 0.0]
    other = make_env(2, cfg)
    other.set_state(state)
    assert other.curriculum_scale() == 0.5
    with pytest.raises(ValueError, match="curriculum"):
        make_env(2, quiet()).set_state(state)


def test_the_env_on_the_device_refuses_it() -> None:
    pytest.importorskip("mujoco_warp")
    from sim.engines.warp.env import WarpTorchVecEnv, make_device_train_env

    cfg = replace(quiet(), curriculum_success=0.8)
    with pytest.raises(ValueError, match="host env"):
        WarpTorchVecEnv(str(sim_dataset()), 2, cfg, device="cpu")
    with pytest.raises(ValueError, match="host env"):
        make_device_train_env(str(sim_dataset()), 2, 0, curriculum_success=0.8)


def test_train_logs_the_level_and_refuses_bad_rates(tmp_path) -> None:
    base = debug_train_args()
    p = cli(*base, "--curriculum-success", "0.5", "--out", str(tmp_path / "run"))
    assert p.returncode == 0, p.stderr
    rows = list(csv.DictReader(open(tmp_path / "run" / "metrics.csv")))
    assert rows and all(0.0 <= float(r["curriculum_scale"]) <= 1.0 for r in rows)
    p = cli(*base, "--curriculum-success", "1.5", "--out", str(tmp_path / "bad"))
    assert p.returncode != 0 and "--curriculum-success 1.5: give a success rate in (0, 1]" in (
        p.stdout + p.stderr
    )
    p = cli(*base, "--curriculum-success", "0.8", "--curriculum-steps", "100",
             "--out", str(tmp_path / "both"))  # fmt: skip
    assert p.returncode != 0 and "exclude each other" in p.stdout + p.stderr
    # a resume must keep the curriculum: the run's env options are checked
    p = cli(*base, "--resume", "--out", str(tmp_path / "run"))
    assert p.returncode != 0 and "curriculum_success" in p.stdout + p.stderr
