"""A trained policy run live in the viewer (`assetgen view DATASET --policy RUN`): steps in
real time, step by step, new spawns, the true and the observed peg drawn, episodes recorded
in the replay format, NaN actions stopped with a message while the server keeps serving,
and checkpoints that do not fit refused before any server starts. The policy is a debug
PPO trained for a few seconds: the mechanics are tested, not its skill."""

from __future__ import annotations

import argparse
import atexit
import functools
import io
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("viser", reason="the `view` extra (viser) is not installed")
pytest.importorskip("torch", reason="the `rl` extra (torch) is not installed")

from rich.console import Console

from assetgen.core.rotations import matrix_to_quat
from assetgen.dataset.reader import Dataset
from preview import command
from preview.episode import load_episode
from preview.live import LivePolicy
from preview.scene import PreviewError
from preview.server import serve
from sim.task import rules as T
from tests.test_sim_common import sim_dataset

ROOT = Path(__file__).resolve().parents[1]
RECORDER_KEYS = {"module_id", "poses", "spawn_pose", "reward", "success"}
"""What evaluation/recording.py's EpisodeRecorder writes (live recordings add dt)."""


@functools.cache
def debug_policy() -> Path:
    """A PPO run of 64 env steps on the simulator test dataset (seconds), trained once."""
    from cli import main

    tmp = Path(tempfile.mkdtemp(prefix="live-policy-"))
    atexit.register(shutil.rmtree, tmp, ignore_errors=True)
    run = tmp / "run"
    argv = ["train", "--algo", "ppo", "--preset", "debug", "--dataset", str(sim_dataset()),
            "--envs", "2", "--steps", "64", "--out", str(run), "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    return run


def _rewrite(run: Path, out: Path, tensors_fn=None, run_meta: dict | None = None) -> Path:
    """A copy of run's checkpoint in `out` with tensors changed and run metadata replaced."""
    from rl import checkpoint as ckpt

    tensors, doc = ckpt.load(run / "checkpoint.safetensors")
    if tensors_fn is not None:
        tensors = {k: tensors_fn(k, t) for k, t in tensors.items()}
    doc["run"].update(run_meta or {})
    ckpt.save(out / "checkpoint.safetensors", tensors, doc)
    return out


def _quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


@pytest.fixture
def viewer(tmp_path):
    h = serve(str(sim_dataset()), console=_quiet(), policy=debug_policy(), record=tmp_path)
    yield h
    h.stop()


def _wait(cond, timeout: float, what: str) -> None:
    deadline = time.time() + timeout
    while not cond():
        if time.time() > deadline:
            raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(0.02)


def test_step_by_step_draws_the_true_and_the_observed_peg(viewer):
    app = viewer.app
    app.g_module.value = "002049"
    for _ in range(3):
        app.live_step()
    live = app.live
    frame = live.frame
    assert frame.module_id == "002049" and frame.step == 3 and not live.running
    assert "t = **0.06 s** (step 3 / 500)" in app.g_live_now.content
    assert "success: **no**" in app.g_live_now.content
    peg, seen = app.nodes["/module/peg"], app.nodes["/module/observed"]
    np.testing.assert_allclose(peg.position, frame.true_pose[:3], atol=1e-7)
    np.testing.assert_allclose(seen.position, frame.observed_pose[:3], atol=1e-7)
    np.testing.assert_allclose(seen.wxyz, frame.observed_pose[3:], atol=1e-7)
    assert seen.visible and peg.visible and app.g_lift.disabled
    # The task's estimation noise (0.5 mm, 1°): near the true pose, not on it.
    d_m, d_deg = frame.observation_error()
    assert 0 < d_m < 0.005 and 0 < d_deg < 10
    app.g_show_observed.value = False
    assert not seen.visible
    # The observed pose is read in the module frame: a noise-free observation of the true
    # pose gives the true pose back.
    env = live.base_env
    exact = T.observe_matrices(env.peg_poses(), env.entrance_inv, env.bottom_inv)[0]
    back = live.observed_pose(exact)
    np.testing.assert_allclose(back[:3], env.sim.state[0, 1:4], atol=1e-6)
    q = env.sim.state[0, 4:8]
    assert min(np.abs(back[3:] - q).max(), np.abs(back[3:] + q).max()) < 1e-5
    np.testing.assert_allclose(back[3:], matrix_to_quat(env.peg_poses()[0, :3, :3]), atol=1e-5)


def test_run_is_real_time_and_new_spawn_records_the_cut_episode(viewer, tmp_path):
    app = viewer.app
    app.live_run()
    live = app.live
    _wait(lambda: live.frame is not None and live.frame.step >= 3, 10, "the run to step")
    t0, k0 = time.perf_counter(), live.frame.step
    time.sleep(0.6)
    app.live_pause()
    steps, wall = live.frame.step - k0, time.perf_counter() - t0
    assert not live.running and steps >= 3
    assert steps <= wall / live.frame.dt + 2, f"{steps} steps in {wall:.2f} s: too fast"
    k = live.frame.step
    time.sleep(0.1)
    assert live.frame.step == k, "pause stops the run"
    assert f"step {k} / 500" in app.g_live_now.content
    app.live_spawn()
    spawn = live.frame.true_pose
    assert live.frame.step == 0
    np.testing.assert_allclose(app.nodes["/module/peg"].position, spawn[:3], atol=1e-7)
    # The episode cut short by the new spawn is recorded, and replays in the viewer.
    (path,) = live.written
    assert path.parent == tmp_path
    ep = load_episode(path, Dataset(sim_dataset()))
    assert ep.module_id == "002048" and ep.steps == k + 1 and not ep.success
    assert ep.dt == 0.02 and ep.notes == ()
    assert np.abs(ep.poses[0, :3] - spawn[:3]).max() > 1e-3, "a new start pose"
    assert app.load_episode(path) and app.episode is not None
    assert not app.nodes["/module/observed"].visible, "the episode takes the scene over"
    np.testing.assert_allclose(app.nodes["/module/peg"].position, ep.poses[0, :3], atol=1e-6)


def test_an_ended_episode_is_recorded_in_the_replay_format(viewer):
    app = viewer.app
    app.g_module.value = "002050"
    app.live_step()
    live = app.live
    while live.frame.ended is None:  # as fast as it goes (500 steps at most)
        live.step()
    frame = live.frame
    assert frame.ended in ("success", "failure", "step limit", "unstable physics")
    assert f"ended: **{frame.ended}**" in app.g_live_now.content
    assert frame.recording is not None and app.g_ep_path.value == str(frame.recording)
    assert any("recorded" in text for level, text in app.messages if level == "info")
    with np.load(frame.recording) as z:
        assert RECORDER_KEYS <= set(z.files) and z["poses"].shape == (frame.step, 7)
        assert bool(z["success"]) == frame.success
        assert float(z["reward"].sum()) == pytest.approx(frame.episode_return, abs=1e-4)
    ep = load_episode(frame.recording, Dataset(sim_dataset()))
    np.testing.assert_allclose(ep.poses[-1], frame.true_pose, atol=1e-6)
    # The next step shows the next episode's spawn (the env has already reset).
    app.live_step()
    assert live.frame.step == 0 and live.frame.ended is None


def test_nan_policy_is_stopped_with_a_message_and_the_viewer_keeps_working(tmp_path):
    nan = _rewrite(
        debug_policy(),
        tmp_path / "nan",
        lambda k, t: t.clone().fill_(float("nan")) if k.startswith("agent/net/actor.") else t,
    )
    h = serve(str(sim_dataset()), console=_quiet(), policy=nan, record=tmp_path / "rec")
    try:
        app = h.app
        app.live_run()
        _wait(lambda: any(lvl == "error" for lvl, _ in app.messages), 10, "the error")
        _wait(lambda: not app.live.running, 5, "the run to stop")
        level, text = app.messages[-1]
        assert level == "error" and "non-finite" in text and "step 0" in text
        assert "NaN" in text and "non\\-finite" in app.g_status.content  # in the page
        assert app.live.frame.step == 0 and not app.live.written
        with urllib.request.urlopen(h.url, timeout=10) as r:  # still serving
            assert r.status == 200
        app.live_step()  # again: the message again, nothing raised
        assert sum(lvl == "error" for lvl, _ in app.messages) == 2
        assert app.show_module("002050") and app.view.id == "002050"
    finally:
        h.stop()


def test_checkpoint_that_does_not_fit_the_task_is_named(tmp_path):
    from rl.runner import train
    from tests.toy_env import ToyEnv

    toy = tmp_path / "toy"  # 4 observation values, 2 actions
    train("ppo", ToyEnv(2), "debug", steps=64, out_dir=toy, progress=False, tensorboard=False)
    with pytest.raises(PreviewError, match=r"observations of 4 values at stack depth 1.*18 per"):
        LivePolicy(toy, tmp_path / "rec")
    stacked = _rewrite(debug_policy(), tmp_path / "stack3", run_meta={"stack": 3})
    with pytest.raises(PreviewError, match=r"18 values at stack depth 3.*54 at stack 3"):
        LivePolicy(stacked, tmp_path / "rec")


def test_stacking_policy_plays_on_stacked_observations(tmp_path):
    from cli import main
    from rl.stack import StackObs

    run = tmp_path / "stack2"
    argv = ["train", "--algo", "ppo", "--preset", "debug", "--dataset", str(sim_dataset()),
            "--envs", "2", "--steps", "64", "--stack", "2", "--out", str(run),
            "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    live = LivePolicy(run, tmp_path / "rec")
    try:
        live.set_module(Dataset(sim_dataset()).module_dir("002051"))
        for _ in range(3):
            live.step()
        assert isinstance(live.env, StackObs) and live.env.obs_dim == 36
        assert live.frame.step == 3 and live.frame.observation_error()[0] < 0.005
    finally:
        live.close()
    assert len(live.written) == 1  # the episode under way, recorded on close


def _view_args(*argv: str) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    command.add_arguments(p)
    return p.parse_args([str(sim_dataset()), *argv])


def test_bad_policy_paths_exit_2_before_any_server(tmp_path, capsys, monkeypatch):
    import preview.server

    def no_server(*a, **k):
        raise AssertionError("a server was started")

    monkeypatch.setattr(preview.server, "start_server", no_server)
    cases = [
        ((str(tmp_path),), "holds no checkpoint.safetensors"),
        ((str(tmp_path / "missing"),), "does not exist"),
        ((str(tmp_path), "--html", str(tmp_path / "x.html")), "drop --html"),
    ]
    for argv, text in cases:
        assert command.view_main(_view_args("--policy", *argv)) == 2
        err = capsys.readouterr().err.strip()
        assert text in err and len(err.splitlines()) == 1, err
    assert command.view_main(_view_args("--record", str(tmp_path))) == 2
    assert "give --policy" in capsys.readouterr().err
    toy = _rewrite(debug_policy(), tmp_path / "toy", run_meta={"stack": 2})
    assert command.view_main(_view_args("--policy", str(toy))) == 2
    assert "stack depth 2" in capsys.readouterr().err


def test_viewer_without_policy_imports_no_torch():
    code = (
        "import io, sys; from rich.console import Console; from preview.server import serve; "
        f"h = serve({str(sim_dataset())!r}, console=Console(file=io.StringIO())); h.stop(); "
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('torch', 'rl')); "
        "assert not bad, bad"
    )
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
