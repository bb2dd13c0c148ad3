"""The training-only axis term of the reward (TaskConfig.dist_axis_weight, train
--axis-shaping): it pays for sliding onto the hole's axis where the paper's distance barely
changes, a success's rewards still sum to 1, and without it the rewards are the paper's."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sim.task import rules as T
from sim.task.config import TaskConfig
from tests.test_cli import run as cli
from tests.test_sim_common import debug_train_args, make_env, quiet, sim_dataset


def _slide_reward(weight: float) -> float:
    """The reward of sliding a peg on the plate from 4 mm off the hole's axis onto it."""
    env = make_env(1, replace(quiet(), dist_axis_weight=weight), num_envs=1)
    env.reset(seed=0)
    start = env.entrance.copy()
    start[0, 0, 3] += 0.004  # on the plate's surface, beside the hole
    start[0, 2, 3] += 0.0005
    env.set_peg_poses(np.array([0]), start)
    # 4 mm in one 20 ms step: 0.2 m/s along -x (action -0.8 of 0.25 m/s)
    reward = env.step(np.array([[-0.8, 0.0, 0.0, 0.0, 0.0, 0.0]]))[1]
    return float(reward[0])


def test_the_axis_term_pays_for_finding_the_hole() -> None:
    paper, shaped = _slide_reward(0.0), _slide_reward(2.0)
    assert shaped > 5 * max(paper, 1e-4), (paper, shaped)


def test_the_distance_gains_the_weighted_distance_from_the_axis() -> None:
    pos = np.array([[0.003, 0.004, 0.01]])
    quat = np.array([[1.0, 0.0, 0.0, 0.0]])
    bottom = np.zeros((1, 3))
    conj = np.array([[1.0, 0.0, 0.0, 0.0]])
    axis = np.array([[0.0, 0.0, 1.0]])
    plain = T.seat_distance(pos, quat, bottom, conj, 0.8, 0.2)
    shaped = T.seat_distance(pos, quat, bottom, conj, 0.8, 0.2, 2.0, axis)
    np.testing.assert_allclose(shaped - plain, 2.0 * 0.005)


def test_a_success_still_sums_to_one_and_without_it_nothing_changes() -> None:
    from sim.task.expert import direct_expert_action

    returns = {}
    for w in (0.0, 2.0):
        env = make_env(4, replace(quiet(), dist_axis_weight=w), num_envs=4)
        obs, total, done = env.reset(seed=1), np.zeros(4), np.zeros(4, bool)
        for _ in range(300):
            obs, r, term, trunc, _ = env.step(direct_expert_action(obs))
            total += np.where(done, 0.0, r)
            done |= term | trunc
            if done.all():
                break
        assert done.all() and env.cfg.dist_axis_weight == w
        returns[w] = total
    np.testing.assert_allclose(returns[2.0], 1.0, atol=1e-9)
    np.testing.assert_allclose(returns[0.0], 1.0, atol=1e-9)
    assert TaskConfig().dist_axis_weight == 0.0


@pytest.mark.parametrize("w", [-1.0, float("nan"), float("inf")])
def test_bad_weights_are_named(w) -> None:
    with pytest.raises(ValueError, match="dist_axis_weight"):
        TaskConfig(dist_axis_weight=w).validate()


def test_the_env_on_the_device_refuses_it() -> None:
    pytest.importorskip("mujoco_warp")
    from sim.engines.warp.env import make_device_train_env

    with pytest.raises(ValueError, match="host env only"):
        make_device_train_env(str(sim_dataset()), 2, 0, axis_shaping=2.0)


def test_train_takes_it_and_refuses_bad_weights(tmp_path) -> None:
    base = debug_train_args()
    p = cli(*base, "--axis-shaping", "2", "--out", str(tmp_path / "run"))
    assert p.returncode == 0, p.stderr
    assert '"axis_shaping": 2.0' in (tmp_path / "run" / "config.json").read_text()
    p = cli(*base, "--axis-shaping", "-1", "--out", str(tmp_path / "bad"))
    assert p.returncode != 0 and "--axis-shaping -1" in p.stdout + p.stderr
