"""The policy that sees: the peg reading (its proprioception), and DAgger's loop end to end on
a tiny budget: it plays, labels, learns, saves what it loads, and is evaluated."""

from __future__ import annotations

import csv
from dataclasses import replace

import numpy as np
import pytest

from sim.cameras.config import CameraConfig
from sim.task import rules as T
from sim.task.config import TaskConfig
from tests.test_sim_common import sim_dataset

TEACHER = "checkpoints/sac-direct-bc"
TINY = dict(collect_steps=6, grad_steps=3, batch_size=4, buffer_size=64, feature_dim=8,
            hidden=(16,))  # fmt: skip
CAMERA = CameraConfig(width=16, height=16)


def test_the_peg_reading_is_its_pose_in_the_module_frame() -> None:
    from sim.env import PegInHoleVecEnv

    quiet = TaskConfig(noise=False, readings=("peg",))
    env = PegInHoleVecEnv(sim_dataset(), 3, quiet)
    obs = env.reset(seed=0)
    ((_, cols, shape),) = [p for p in env.observation_layout() if p[0] == "peg"]
    assert shape == (9,) and obs.shape[1] == 27
    pose = T.pose(env.sim.peg_pos, env.sim.peg_quat)
    np.testing.assert_allclose(obs[:, cols][:, :3], env.sim.peg_pos, atol=1e-7)
    np.testing.assert_allclose(obs[:, cols][:, 3:6], pose[:, :3, 0], atol=1e-7)
    np.testing.assert_allclose(obs[:, cols][:, 6:9], pose[:, :3, 1], atol=1e-7)
    env.close()

    noisy = PegInHoleVecEnv(sim_dataset(), 200, replace(quiet, noise=True))
    obs = noisy.reset(seed=0)
    err = obs[:, 18:21] - noisy.sim.peg_pos
    assert 0.0004 < err.std() < 0.0006  # peg_position_noise, 0.5 mm
    noisy.close()


def test_dagger_plays_labels_learns_and_saves_what_it_loads(tmp_path) -> None:
    from evaluation.student import evaluate_student
    from rl.student.config import StudentConfig
    from rl.student.dagger import FILE_NAME, READINGS, Student, distill
    from sim.env import make_eval_env, make_train_env

    cfg = StudentConfig(**TINY)
    env = make_train_env(str(sim_dataset()), 2, 3, curriculum_steps=0, readings=READINGS,
                         camera=CAMERA)  # fmt: skip
    rows = []
    last = distill(TEACHER, env, tmp_path, minutes=0.0, seed=3, cfg=cfg, progress=rows.append)
    env.close()
    assert len(rows) == 1 and last == rows[0]  # a zero budget still runs one iteration
    assert last["env_steps"] == 12 and last["frames"] == 12 and last["beta"] == 1.0
    assert np.isfinite(last["loss"]) and last["loss"] > 0
    with open(tmp_path / "metrics.csv") as f:
        table = list(csv.DictReader(f))
    assert len(table) == 1 and float(table[0]["loss"]) == pytest.approx(last["loss"])

    student, doc = Student.load(tmp_path)
    assert doc["teacher"] == TEACHER and student.cfg == cfg
    assert CameraConfig(**student.camera) == CAMERA
    res = evaluate_student(tmp_path / FILE_NAME, str(sim_dataset()), 1, modules=2)
    assert res["episodes"] == 2 and res["algo"] == "student"
    assert res["camera"]["width"] == 16 and res["readings"] == ["peg"]

    # the loaded student acts as the one that was saved: same weights, same actions
    env = make_eval_env(str(sim_dataset()), None, 0, modules=2, readings=READINGS, camera=CAMERA)
    obs = env.reset(seed=0)
    again, _ = Student.load(tmp_path)
    a, b = student.bind(env).act(obs), again.bind(env).act(obs)
    env.close()
    np.testing.assert_array_equal(a, b)
    assert a.shape == (2, 6) and np.all(np.abs(a) <= 1.0)


def test_the_student_refuses_what_it_cannot_read() -> None:
    from dataclasses import asdict

    from rl.student.config import StudentConfig
    from rl.student.dagger import Student
    from sim.env import PegInHoleVecEnv

    with pytest.raises(ValueError, match="beta_decay"):
        StudentConfig(beta_decay=1.0).validate()
    env = PegInHoleVecEnv(sim_dataset(), 2, TaskConfig(camera=CAMERA))
    with pytest.raises(ValueError, match="the student needs 'peg' and a depth camera's image"):
        Student(StudentConfig(**TINY), asdict(CAMERA)).bind(env)
    with pytest.raises(ValueError, match="is not the student's"):
        Student(StudentConfig(**TINY), asdict(replace(CAMERA, far=0.4))).bind(env)
    env.close()
    rgb = replace(CAMERA, modality="rgb")
    env = PegInHoleVecEnv(sim_dataset(), 2, TaskConfig(readings=("peg",), camera=rgb))
    with pytest.raises(ValueError, match="a camera with depth or rgbd"):
        Student(StudentConfig(**TINY), asdict(rgb)).bind(env)
    env.close()


def test_the_teacher_is_shown_the_nearest_seat_that_looks_the_same() -> None:
    from assetgen.core.mesh import Mesh
    from rl.student.symmetry import HALF_TURN, half_turn_symmetric, nearest_seat

    def prism(section: np.ndarray) -> Mesh:
        v = np.concatenate([np.c_[section, np.zeros(len(section))],
                            np.c_[section, np.full(len(section), 0.05)]])  # fmt: skip
        return Mesh(v, np.zeros((0, 3), dtype=np.int64))

    def polygon(n: int, squash: float) -> np.ndarray:
        a = 2 * np.pi * np.arange(n) / n + 0.3
        return np.c_[0.01 * np.cos(a), 0.01 * squash * np.sin(a)]

    assert half_turn_symmetric(prism(polygon(6, 0.4)))  # a squashed hexagon
    assert half_turn_symmetric(prism(polygon(32, 0.7)))  # a squashed circle
    assert not half_turn_symmetric(prism(polygon(5, 0.4)))
    assert not half_turn_symmetric(prism(polygon(6, 0.4) + np.array([0.001, 0.0])))  # off axis

    # a peg turned 170 degrees from its seat's frame about the axis: 10 from the other seat
    a = np.radians(170.0)
    obs = np.zeros((2, 18), dtype=np.float32)
    obs[:, 9:12] = [0.002, -0.001, 0.03]
    obs[:, 12:15] = [np.cos(a), np.sin(a), 0.0]
    obs[:, 15:18] = [-np.sin(a), np.cos(a), 0.0]
    out = nearest_seat(obs, np.array([True, False]))
    np.testing.assert_array_equal(out[0], obs[0] * HALF_TURN)
    np.testing.assert_allclose(out[0, 9:12], [-0.002, 0.001, 0.03])
    assert out[0, 12] + out[0, 16] > obs[0, 12] + obs[0, 16]  # nearer: a larger trace
    np.testing.assert_array_equal(out[1], obs[1])  # not symmetric: its own seat
    np.testing.assert_array_equal(nearest_seat(out[:1], np.array([True])), out[:1])  # nearer


def test_the_direct_expert_inserts_into_the_half_turned_seat() -> None:
    from rl.student.symmetry import HALF_TURN, half_turn_symmetric
    from sim.env import PegInHoleVecEnv
    from sim.task.expert import direct_expert_action

    env = PegInHoleVecEnv(sim_dataset(), 4, TaskConfig())
    symmetric = np.array([half_turn_symmetric(m.peg) for m in env.modules])[env.env_module]
    assert symmetric.any(), "no module of the test set fits its hole turned by half a turn"
    obs = env.reset(seed=1)
    won, ended = np.zeros(4, bool), np.zeros(4, bool)
    for _ in range(env.cfg.max_steps):
        seen = np.where(symmetric[:, None], obs[:, :18] * HALF_TURN, obs[:, :18])
        obs, _, terminated, truncated, info = env.step(direct_expert_action(seen))
        won |= info["success"] & ~ended
        ended |= terminated | truncated
        if ended.all():
            break
    env.close()
    # the turned seat is the same hole: the expert turns the other way round and inserts
    assert won[symmetric].all()
