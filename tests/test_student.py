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
TINY = dict(envs=2, collect_steps=6, grad_steps=3, batch_size=4, buffer_size=64, feature_dim=8,
            hidden=(16,), camera=CameraConfig(width=16, height=16))  # fmt: skip


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
    from rl.student.config import StudentConfig
    from rl.student.dagger import FILE_NAME, Student, distill, evaluate_student

    cfg = StudentConfig(**TINY)
    rows = []
    last = distill(TEACHER, str(sim_dataset()), tmp_path, minutes=0.0, seed=3, cfg=cfg,
                   progress=rows.append)  # fmt: skip
    assert len(rows) == 1 and last == rows[0]  # a zero budget still runs one iteration
    assert last["env_steps"] == 12 and last["frames"] == 12 and last["beta"] == 1.0
    assert np.isfinite(last["loss"]) and last["loss"] > 0
    with open(tmp_path / "metrics.csv") as f:
        table = list(csv.DictReader(f))
    assert len(table) == 1 and float(table[0]["loss"]) == pytest.approx(last["loss"])

    student, doc = Student.load(tmp_path)
    assert doc["teacher"] == TEACHER and student.cfg == cfg
    res = evaluate_student(tmp_path / FILE_NAME, str(sim_dataset()), 1, modules=2)
    assert res["episodes"] == 2 and res["algo"] == "student"
    assert res["camera"]["width"] == 16 and res["readings"] == ["peg"]

    # the loaded student acts as the one that was saved: same weights, same actions
    from sim.env import make_eval_env

    env = make_eval_env(str(sim_dataset()), None, 0, modules=2, readings=("peg",),
                        camera=cfg.camera)  # fmt: skip
    obs = env.reset(seed=0)
    again, _ = Student.load(tmp_path)
    a, b = student.bind(env).act(obs), again.bind(env).act(obs)
    env.close()
    np.testing.assert_array_equal(a, b)
    assert a.shape == (2, 6) and np.all(np.abs(a) <= 1.0)


def test_the_student_refuses_what_it_cannot_read() -> None:
    from rl.student.config import StudentConfig
    from rl.student.dagger import Student
    from sim.env import PegInHoleVecEnv

    with pytest.raises(ValueError, match="the student reads depth; give depth or rgbd"):
        StudentConfig(camera=CameraConfig(modality="rgb")).validate()
    with pytest.raises(ValueError, match="beta_decay"):
        StudentConfig(beta_decay=1.0).validate()
    env = PegInHoleVecEnv(sim_dataset(), 2, TaskConfig(camera=CameraConfig(width=16, height=16)))
    with pytest.raises(ValueError, match="the student needs 'peg'"):
        Student(StudentConfig(**TINY)).bind(env)
    env.close()
