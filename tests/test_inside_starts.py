"""Starts inside the hole for a share of the training episodes (TaskConfig.inside_starts, a
reverse curriculum's first stage): those pegs sit on the hole's axis, turned as on the seat,
between the entrance and the seat, free of contact, and a push down seats them; their
episodes are marked `assisted` and counted neither in the training statistics nor by the
success-gated curriculum; an env without it draws exactly as before."""

from __future__ import annotations

import numpy as np
import pytest

from rl.metrics import EpisodeStats
from sim.task.config import TaskConfig
from tests.test_cli import run as cli
from tests.test_sim_common import debug_train_args, make_env, quiet, sim_dataset


def _down(env) -> np.ndarray:
    """Actions that push every peg down its hole's axis at full speed (module frame)."""
    a = np.zeros((env.num_envs, 6))
    a[:, :3] = -env.bottom[:, :3, 2]
    return a


def test_inside_starts_sit_in_the_hole_and_a_push_down_seats_them() -> None:
    env = make_env(4, quiet(inside_starts=0.5), num_envs=16)
    env.reset(seed=1)
    inside = env._assisted.copy()
    assert 0 < inside.sum() < 16
    rel = env.bottom_inv @ env.peg_poses()  # the peg in its seat's frame
    depth = np.linalg.norm(env.entrance[:, :3, 3] - env.bottom[:, :3, 3], axis=1)
    np.testing.assert_allclose(rel[inside, :2, 3], 0.0, atol=1e-9)  # on the axis
    np.testing.assert_allclose(rel[inside, :3, :3], np.eye(3)[None].repeat(inside.sum(), 0),
                               atol=1e-9)  # fmt: skip
    height = rel[inside, 2, 3]
    assert (height >= 2 * env.cfg.success_radius - 1e-9).all()
    assert (height <= depth[inside] + 1e-9).all()
    # the rest spawn 15-25 cm above the entrance, as without it
    above = (np.linalg.inv(env.entrance) @ env.peg_poses())[~inside, 2, 3]
    assert (above > env.cfg.spawn_z[0] - 0.005).all()
    ended, success, assisted = np.zeros(16, bool), np.zeros(16, bool), np.zeros(16, bool)
    for _ in range(40):
        _, _, term, trunc, info = env.step(_down(env))
        first = (term | trunc) & ~ended
        success[first], assisted[first] = info["success"][first], info["assisted"][first]
        ended |= first
    assert success[inside].all(), "a push down must seat every peg started inside"
    np.testing.assert_array_equal(assisted[ended], inside[ended])


def test_assisted_episodes_are_left_out_of_the_training_statistics() -> None:
    stats = EpisodeStats(10)
    info = {
        "episode_return": np.array([1.0, -1.0, 1.0]),
        "episode_length": np.array([5, 9, 3]),
        "success": np.array([True, False, True]),
        "time_to_success": np.array([0.1, np.nan, 0.06]),
        "assisted": np.array([True, False, False]),
    }
    stats.add(np.array([True, True, True]), info)
    assert stats.total == 2
    assert stats.summary()["success_rate"] == 0.5
    del info["assisted"]  # an env that marks nothing: every episode counts
    stats.add(np.array([True, False, False]), info)
    assert stats.total == 3


def test_the_gated_curriculum_does_not_count_them() -> None:
    cfg = quiet(inside_starts=0.5, curriculum_success=0.5, curriculum_window=1000)
    env = make_env(4, cfg, num_envs=16)
    env.reset(seed=2)
    counted = assisted = 0
    for _ in range(40):
        _, _, term, trunc, info = env.step(_down(env))
        done = term | trunc
        counted += int((done & ~info["assisted"]).sum())
        assisted += int((done & info["assisted"]).sum())
    assert assisted > 0 and counted > 0
    assert env.curriculum.episodes == counted  # no decision yet: every counted episode


def test_its_state_is_saved_and_restored() -> None:
    a = make_env(4, quiet(inside_starts=0.5), num_envs=8)
    b = make_env(4, quiet(inside_starts=0.5), num_envs=8)
    a.reset(seed=4)
    b.reset(seed=5)
    b.set_state(a.get_state())
    np.testing.assert_array_equal(a._assisted, b._assisted)
    act = _down(a)
    for _ in range(30):
        ra, rb = a.step(act), b.step(act)
        np.testing.assert_array_equal(ra[4]["assisted"], rb[4]["assisted"])
        np.testing.assert_array_equal(ra[0], rb[0])


def test_without_it_no_episode_is_assisted() -> None:
    assert TaskConfig().inside_starts is None
    env = make_env(4, quiet(), num_envs=8)
    env.reset(seed=3)
    for _ in range(30):
        info = env.step(_down(env))[4]
        assert not info["assisted"].any()


@pytest.mark.parametrize("share", [0.0, 1.0, -0.5])
def test_bad_shares_are_named(share) -> None:
    with pytest.raises(ValueError, match="inside_starts"):
        TaskConfig(inside_starts=share).validate()


def test_the_env_on_the_device_refuses_it() -> None:
    pytest.importorskip("mujoco_warp")
    from sim.engines.warp.env import make_device_train_env

    with pytest.raises(ValueError, match="host env only"):
        make_device_train_env(str(sim_dataset()), 2, 0, inside_starts=0.5)


def test_train_takes_it_and_refuses_a_share_of_one(tmp_path) -> None:
    base = debug_train_args()
    p = cli(*base, "--inside-starts", "0.25", "--out", str(tmp_path / "run"))
    assert p.returncode == 0, p.stderr
    assert '"inside_starts": 0.25' in (tmp_path / "run" / "config.json").read_text()
    p = cli(*base, "--inside-starts", "1", "--out", str(tmp_path / "bad"))
    out = p.stdout + p.stderr
    assert p.returncode != 0 and "--inside-starts 1" in out and "(0, 1)" in out
