"""The cameras: depth where the geometry puts it, pixels where the intrinsics put them, the
image in the observation with its noise, and one-line errors."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sim.assets.task_modules import load_modules
from sim.cameras.config import CameraConfig, parse_camera
from sim.cameras.gl import CameraError
from sim.task.config import TaskConfig
from tests.test_sim_common import sim_dataset

AWAY = (np.array([[0.0, 0.0, 5.0]]), np.array([[1.0, 0.0, 0.0, 0.0]]))
"""A peg pose out of every test camera's view."""


def _renderer(cfg: CameraConfig, count: int = 1):
    from sim.cameras.render import CameraRenderer

    return CameraRenderer(load_modules(sim_dataset())[:count], cfg)


def test_a_plate_seen_straight_down_reads_its_height_where_the_intrinsics_put_its_edge() -> None:
    (asset,) = load_modules(sim_dataset())[:1]
    top = np.concatenate([p.vertices for p in asset.pieces])
    top = top[np.abs(top[:, 2]) < 1e-9]  # the plate's top face is z = 0
    edge, y = top[:, 0].max(), top[:, 1].min() + 0.02  # its +x edge, far from the hole
    height, back = 0.2, 0.005
    # a narrow view (3.5 cm across at 0.2 m) sees the plate's corner only, not its hole
    cfg = CameraConfig(view="fixed", modality="depth", fovy=10.0,
                       fixed_position=(edge - back, y, height),
                       fixed_target=(edge - back, y, 0.0))  # fmt: skip
    r = _renderer(cfg)
    (image,) = r.render(np.array([0]), *AWAY)
    r.close()
    # looking down -z, the image's right is +x: the edge lands back / height * f right of
    # the centre
    u = cfg.intrinsics()[0, 2] + cfg.intrinsics()[0, 0] * back / height
    plate, beyond = image[0][:, : int(np.floor(u))], image[0][:, int(np.ceil(u)) :]
    assert plate.size and beyond.size
    np.testing.assert_allclose(plate, height, atol=1e-5)  # z-depth: the same on every pixel
    np.testing.assert_array_equal(beyond, cfg.far)


def test_a_module_renders_alike_among_others_and_alone() -> None:
    cfg = CameraConfig(view="fixed", modality="rgbd")
    pos = np.array([[0.0, 0.0, 0.05]] * 3)
    quat = np.array([[1.0, 0.0, 0.0, 0.0]] * 3)
    together = _renderer(cfg, 3)
    first, again = (together.render(np.arange(3), pos, quat) for _ in range(2))
    together.close()
    np.testing.assert_array_equal(first, again)
    for k in range(3):
        from sim.cameras.render import CameraRenderer

        alone = CameraRenderer(load_modules(sim_dataset())[: k + 1], cfg)
        np.testing.assert_array_equal(alone.render(np.array([k]), pos[:1], quat[:1])[0], first[k])
        alone.close()
    # and the modules differ, so the comparison can fail
    assert np.abs(first[0] - first[1]).max() > 0.1


def test_the_wrist_camera_rides_with_the_peg() -> None:
    r = _renderer(CameraConfig(view="wrist", modality="rgbd"))
    turn = np.array([[np.cos(0.3), 0.0, 0.0, np.sin(0.3)]])
    high, low, turned = (r.render(np.array([0]), np.array([[0.0, 0.0, z]]), q)
                         for z, q in ((0.3, AWAY[1]), (0.05, AWAY[1]), (0.3, turn)))  # fmt: skip
    r.close()
    peg = np.all(np.abs(high[0, :3] - np.array([0.85, 0.45, 0.2])[:, None, None]) < 0.35, axis=0)
    assert peg.mean() > 0.01  # the peg is in view, wherever it is
    np.testing.assert_array_equal(high[0, 3][peg & (high[0, 3] < 0.2)] > 0, True)
    assert low[0, 3].mean() < high[0, 3].mean()  # the plate comes nearer as the peg goes down
    assert not np.array_equal(turned, high)  # the world turns as the peg turns


def test_the_env_appends_the_image_and_names_its_parts() -> None:
    from sim.env import PegInHoleVecEnv

    cam = CameraConfig(view="fixed", modality="depth", width=32, height=24)
    quiet = TaskConfig(noise=False, camera=cam)
    env = PegInHoleVecEnv(sim_dataset(), 2, quiet)
    obs = env.reset(seed=0)
    assert env.obs_dim == obs.shape[1] == 18 + 32 * 24
    names = [(n, s.start, s.stop, shape) for n, s, shape in env.observation_layout()]
    assert names == [("pose", 0, 18, (18,)), ("camera_fixed_depth", 18, 786, (1, 24, 32))]
    pos, quat = env.sim.peg_pos.copy(), env.sim.peg_quat.copy()
    clean = env.camera.render(env.env_module, pos, quat)
    np.testing.assert_array_equal(obs[:, 18:], clean.reshape(2, -1))
    up = np.zeros((2, 6))
    up[:, 2] = 1.0
    obs, *_ = env.step(up)
    assert not np.array_equal(obs[:, 18:], clean.reshape(2, -1))  # the image follows the peg
    env.close()

    noisy = replace(quiet, noise=True, camera=replace(cam, depth_noise=0.002, depth_dropout=0.1))
    env = PegInHoleVecEnv(sim_dataset(), 2, noisy)
    obs = env.reset(seed=0)
    clean = env.camera.render(env.env_module, env.sim.peg_pos, env.sim.peg_quat).reshape(2, -1)
    dropped = obs[:, 18:] == 0.0
    assert 0.07 < dropped.mean() < 0.13
    err = (obs[:, 18:] - clean)[~dropped & (clean < cam.far - 0.01)]
    assert 0.0017 < err.std() < 0.0023
    env.close()

    bare = PegInHoleVecEnv(sim_dataset(), 2, replace(quiet, camera=None))
    assert bare.obs_dim == 18 and bare.camera is None
    assert [n for n, *_ in bare.observation_layout()] == ["pose"]
    bare.close()


def test_bad_camera_values_are_refused_naming_them() -> None:
    with pytest.raises(ValueError, match=r"width = 4: give a whole number of pixels in \[8"):
        CameraConfig(width=4).validate()
    with pytest.raises(ValueError, match="view = 'eye': give one of wrist, fixed"):
        TaskConfig(camera=CameraConfig(view="eye")).validate()
    with pytest.raises(ValueError, match=r"depth_dropout = 1\.0"):
        CameraConfig(depth_dropout=1.0).validate()
    with pytest.raises(ValueError, match="the size '64y64' is not WIDTHxHEIGHT"):
        parse_camera("wrist:depth:64y64")
    assert parse_camera("fixed:rgbd:96x48").shape == (4, 48, 96)


def test_a_missing_gl_backend_is_one_line(monkeypatch) -> None:
    from sim.cameras import gl

    monkeypatch.setenv("MUJOCO_GL", "glfw")
    with pytest.raises(CameraError, match=r"MUJOCO_GL='glfw' cannot render .* set MUJOCO_GL=egl"):
        gl.offscreen_context(8, 8)

    import mujoco.egl

    def broken(*_args, **_kwargs):
        raise RuntimeError("eglInitialize failed\nand more")

    monkeypatch.setenv("MUJOCO_GL", "egl")
    monkeypatch.setattr(mujoco.egl, "GLContext", broken)
    with pytest.raises(CameraError) as e:
        gl.offscreen_context(8, 8)
    assert "\n" not in str(e.value)
    assert "MUJOCO_GL=egl: no GL context (eglInitialize failed)" in str(e.value)
    assert "apt install libegl1" in str(e.value) and "MUJOCO_GL=osmesa" in str(e.value)
