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


# --------------------------------------------------------------- until take-off (the gate)


def test_the_gate_closes_at_the_first_window_at_its_rate_and_stays_closed() -> None:
    from sim.task.takeoff_gate import TakeoffGate

    gate = TakeoffGate(0.5, window=4)
    done = np.array([True, True, False, True, True])
    gate.update(done, np.array([True, False, True, False, False]), step=10)
    assert gate.open and (gate.episodes, gate.successes) == (0, 0)  # 1 of 4: below, reset
    gate.update(done, np.array([True, False, False, True, False]), step=20)
    assert not gate.open and gate.closed_at == 20  # 2 of 4 = 0.5: closed
    gate.update(done, np.zeros(5, bool), step=30)  # a closed gate counts nothing more
    assert not gate.open and gate.closed_at == 20
    fresh = TakeoffGate(0.5, window=4)
    fresh.load(gate.state())
    assert (fresh.open, fresh.closed_at) == (False, 20)


def test_the_gate_ends_the_inside_starts_once_the_task_takes_off() -> None:
    """The scripted expert seats pegs from the task's own starts: after the first window of
    them, the gate closes and no episode started after it is assisted."""
    from sim.task.expert import direct_expert_action

    cfg = quiet(inside_starts=0.5, inside_starts_until=0.5, curriculum_window=4)
    env = make_env(4, cfg, num_envs=8)
    obs = env.reset(seed=6)
    assert env.inside_share() == 0.5 and env._assisted.any()
    closed_at = None
    for _ in range(600):
        obs, _, term, trunc, _ = env.step(direct_expert_action(obs))
        if closed_at is None and not env.inside_gate.open:
            closed_at, started = env.global_step, env._assisted.copy()
        elif closed_at is not None:  # only episodes begun before the gate closed are assisted
            assert not (env._assisted & ~started).any()
            started &= ~(term | trunc)
    assert closed_at is not None and env.inside_gate.closed_at == closed_at
    assert env.inside_share() == 0.0 and not env._assisted.any()


def test_the_gates_state_is_saved_and_restored() -> None:
    cfg = quiet(inside_starts=0.5, inside_starts_until=0.5)
    a, b = make_env(4, cfg, num_envs=8), make_env(4, cfg, num_envs=8)
    a.reset(seed=4)
    b.reset(seed=5)
    a.inside_gate.open, a.inside_gate.episodes, a.inside_gate.closed_at = False, 3, 77
    b.set_state(a.get_state())
    assert (b.inside_gate.open, b.inside_gate.episodes, b.inside_gate.closed_at) == (False, 3, 77)
    assert b.inside_share() == 0.0


def test_a_gate_without_inside_starts_is_refused() -> None:
    with pytest.raises(ValueError, match="inside_starts_until"):
        TaskConfig(inside_starts_until=0.1).validate()
    with pytest.raises(ValueError, match="inside_starts_until"):
        TaskConfig(inside_starts=0.25, inside_starts_until=0.0).validate()


def test_train_logs_the_inside_share_and_refuses_a_gate_alone(tmp_path) -> None:
    base = debug_train_args()
    flags = ("--inside-starts", "0.25", "--inside-starts-until", "0.1")
    p = cli(*base, *flags, "--out", str(tmp_path / "run"))
    assert p.returncode == 0, p.stderr
    assert '"inside_starts_until": 0.1' in (tmp_path / "run" / "config.json").read_text()
    header, *rows = (tmp_path / "run" / "metrics.csv").read_text().splitlines()
    share = header.split(",").index("inside_share")
    assert rows and all(float(r.split(",")[share]) == 0.25 for r in rows)  # not taken off
    p = cli(*base, "--inside-starts-until", "0.1", "--out", str(tmp_path / "alone"))
    out = p.stdout + p.stderr
    assert p.returncode != 0 and "inside_starts_until" in out and len(out.strip().splitlines()) == 1
