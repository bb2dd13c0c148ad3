"""The simulator on MuJoCo Warp (sim/engines/warp/batch.py), run on Warp's CPU device so that CI
needs no GPU: the same trajectory as the CPU simulator in free flight, the same insertions
in contact, module rotation, and the errors."""

from __future__ import annotations

import functools
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("warp", reason="the warp extra: pip install -e '.[warp]'")

from assetgen.core.mujoco_config import physics_for
from assetgen.core.rotations import quat_conj, quat_mul
from sim.assets.loading import load_dataset
from sim.engines.warp.batch import load_warp
from sim.env import PegInHoleVecEnv
from sim.task.config import TaskConfig
from sim.task.expert import DIRECT, expert_action

pytest.importorskip("mujoco_warp", reason="the warp extra: pip install -e '.[warp]'")
load_warp()  # quiet, as the engine keeps Warp: no line per kernel module in the test log


@functools.cache
def _dataset() -> Path:
    """Three test-split modules (seeds 2048-2050), generated once."""
    import atexit

    from assetgen.dataset.generate import generate
    from assetgen.dataset.spec import DatasetSpec
    from assetgen.params.sampler import SamplerConfig

    tmp = Path(tempfile.mkdtemp(prefix="warp-tests-"))
    atexit.register(shutil.rmtree, tmp, ignore_errors=True)
    spec = DatasetSpec("t", 2048, 3, SamplerConfig(), ("collision", "mjcf"))
    assert not generate(tmp / "ds", spec, workers=1, progress=False).failures
    return tmp / "ds"


def _quiet() -> TaskConfig:
    return TaskConfig(noise=False, curriculum_steps=0, physics=physics_for(0.001))


def _env(mods, num_envs: int, cfg: TaskConfig, engine: str, **kw) -> PegInHoleVecEnv:
    extra = {"nthread": 1} if engine == "mujoco" else {}
    return PegInHoleVecEnv(mods, num_envs, cfg, engine=engine, **extra, **kw)


def test_free_flight_matches_the_cpu_simulator_to_float32() -> None:
    """No contact: the same modules, poses and actions give the CPU simulator's trajectory
    over 200 control steps (8000 physics steps) within 10 µm and 1e-5 rad. MuJoCo Warp
    computes in float32 (a relative 6e-8 a step: micrometres accumulate over thousands of
    steps), the CPU in float64."""
    mods = load_dataset(_dataset())[:2]
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.5, 0.5, (200, len(mods), 6))
    actions[:, :, 2] = 0.2  # rising: nothing to touch
    traj = {}
    for engine in ("mujoco", "mujoco-warp"):
        env = _env(mods, len(mods), _quiet(), engine)
        env.reset(seed=0)
        poses = np.tile(np.eye(4), (len(mods), 1, 1))
        poses[:, 2, 3] = 0.1
        env.set_peg_poses(np.arange(len(mods)), poses)
        states = []
        for a in actions:
            env.step(a)
            states.append(env.sim.state[:, 1:8].copy())
        traj[engine] = np.array(states)
        env.close()
    cpu, gpu = traj["mujoco"], traj["mujoco-warp"]
    travel = np.linalg.norm(cpu[-1, :, :3] - cpu[0, :, :3], axis=1)
    assert travel.min() > 0.05, "the pegs must move for the comparison to mean anything"
    np.testing.assert_allclose(gpu[..., :3], cpu[..., :3], rtol=0, atol=1e-5)
    # the angle between the orientations, from the relative quaternion's vector part
    # (linear in the error, unlike the dot product at float32's resolution)
    rel = quat_mul(quat_conj(cpu[..., 3:].reshape(-1, 4)), gpu[..., 3:].reshape(-1, 4))
    angle = 2 * np.linalg.norm(rel[:, 1:], axis=1)
    assert angle.max() < 1e-5, angle.max()


def test_the_direct_expert_inserts_as_on_the_cpu_with_modules_in_turns() -> None:
    """In contact trajectories part at float precision, so the figures are compared: one
    env takes two modules in turns (MuJoCo Warp's per-world meshes swapped at each
    reset), noise on, and the direct expert inserts every peg within 5 % of the CPU
    simulator's time on the same episodes."""
    mods = load_dataset(_dataset())[:2]
    cfg = replace(_quiet(), noise=True)
    times = {}
    for engine in ("mujoco", "mujoco-warp"):
        env = _env(mods, 1, cfg, engine, rotate_modules=True)
        obs = env.reset(seed=0)
        got, played = [], []
        for _ in range(2 * 200):
            module = env.env_module[0]
            obs, _r, term, trunc, info = env.step(expert_action(obs, DIRECT))
            if term[0] or trunc[0]:
                assert info["success"][0], (engine, module)
                got.append(float(info["episode_length"][0]) * env.control_dt)
                played.append(int(module))
                if len(got) == 2:
                    break
        assert sorted(played) == [0, 1], played  # every module had its turn
        times[engine] = np.array(got)
        env.close()
    np.testing.assert_allclose(times["mujoco-warp"], times["mujoco"], rtol=0.05)


def test_what_the_warp_engine_refuses(tmp_path: Path) -> None:
    mods = load_dataset(_dataset())
    with pytest.raises(ValueError, match="engine 'bullet' is not registered"):
        PegInHoleVecEnv(mods, 3, _quiet(), engine="bullet")
    env = _env(mods, 2, _quiet(), "mujoco-warp")
    with pytest.raises(ValueError, match="saving the env's state is MuJoCo's only"):
        env.get_state()
    with pytest.raises(ValueError, match="module 'nope' was not given"):
        env.sim.set_module(0, "nope")
    env.close()


def test_what_changes_between_steps_reaches_the_device() -> None:
    """Between steps only what changed goes up: a world put on another module gets that
    module's rows (meshes, frames, the fixed pieces' poses), a new contact draw reaches its
    world's peg alone."""
    from sim.engines.warp.batch import WarpBatchSim

    mods = load_dataset(_dataset())
    sim = WarpBatchSim(mods[:2], _quiet(), spare_assets=mods[2:])
    sim.step(np.zeros((2, 6)))
    before = sim.model.geom_friction.numpy().copy()
    sim.set_contact(np.array([1]), np.array([0.37]), np.array([4.5]))
    sim.set_module(0, mods[2].id)
    sim.step(np.zeros((2, 6)))
    g = sim.peg_geom
    friction = sim.model.geom_friction.numpy()
    assert friction[1, g, 0] == pytest.approx(0.37)
    np.testing.assert_array_equal(np.delete(friction[1], g, 0), np.delete(before[1], g, 0))
    want = sim.per_module[mods[2].id]
    np.testing.assert_array_equal(sim.model.geom_dataid.numpy()[0], want["geom_dataid"])
    np.testing.assert_allclose(sim.model.geom_pos.numpy()[0], want["geom_pos"], atol=1e-7)
    np.testing.assert_allclose(
        sim.data.geom_xpos.numpy()[0, : sim.slots], sim._slot_pose[mods[2].id][0], atol=1e-7
    )
    assert sim.env_module == [mods[2].id, mods[1].id]


def test_a_world_out_of_contact_room_is_refused_not_truncated() -> None:
    """MuJoCo Warp drops contacts beyond those allocated; the engine says so instead."""
    from assetgen.core.rotations import matrix_to_quat
    from sim.engines.warp.batch import WarpBatchSim

    mod = load_dataset(_dataset())[0]
    sim = WarpBatchSim([mod], _quiet(), nconmax=1, njmax=3)
    down = mod.bottom[:3, 2]
    sim.set_pose(
        np.array([0]),
        mod.bottom[None, :3, 3] - 1e-4 * down,
        matrix_to_quat(mod.bottom[None, :3, :3]),
    )
    with pytest.raises(RuntimeError, match="larger nconmax / njmax"):
        sim.step(np.zeros((1, 6)))


def test_a_missing_warp_extra_is_named_in_one_line() -> None:
    from cli import missing_extra_message

    msg = missing_extra_message("eval", "mujoco_warp", "mujoco-warp")
    assert msg is not None and "[warp]" in msg and "\n" not in msg
    assert "[warp]" in (missing_extra_message("bench", "warp._src.context", "mujoco-warp") or "")


def test_bench_sim_runs_on_warp(capsys) -> None:
    """`assetgen bench sim --sim mujoco-warp`: the env's rate, the raw rate, the expert's, and
    the env on the device with random actions and with a policy in the loop."""
    import json

    from cli import main

    args = ["bench", "sim", "--sim", "mujoco-warp", "--dataset", str(_dataset()), "--allow-cpu"]
    assert main([*args, "--envs", "2", "--steps", "2", "--json"]) == 0
    res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert res["engine"] == "mujoco-warp" and res["envs"] == 2 and res["modules"] == 3
    for key in (
        "env_steps_per_s",
        "rollout_steps_per_s",
        "expert_env_steps_per_s",
        "device_env_steps_per_s",
        "device_policy_env_steps_per_s",
    ):
        assert res[key] > 0, key


@pytest.mark.parametrize("command", ["bench", "eval", "train"])
def test_without_a_gpu_warp_asks_for_allow_cpu(command, monkeypatch, capsys, tmp_path) -> None:
    """With no CUDA GPU, --sim mujoco-warp stops in one line that says Warp would run on the
    CPU and how much slower, and names --allow-cpu, before any env is built."""
    import sim.engines.warp.batch
    from cli import main
    from sim import env as sim_env

    monkeypatch.setattr(sim.engines.warp.batch, "default_device", lambda: "cpu")
    built = []
    monkeypatch.setattr(sim_env.PegInHoleVecEnv, "__init__", lambda *a, **k: built.append(a))
    data = str(_dataset())
    argv = {
        "bench": ["bench", "sim", "--dataset", data, "--envs", "2", "--steps", "2"],
        "eval": ["eval", "--agent", "random", "--dataset", data, "--attempts", "1"],
        "train": ["train", "--algo", "ppo", "--dataset", data, "--steps", "64"],
    }[command]
    if command == "train":
        argv += ["--out", str(tmp_path / "run")]
    assert main([*argv, "--sim", "mujoco-warp"]) != 0
    err = capsys.readouterr().err.strip()
    slowdown = sim.engines.warp.batch.CPU_SLOWDOWN
    assert "--allow-cpu" in err and f"{slowdown} times slower" in err, err
    assert "\n" not in err and not built


def test_bench_build_sizes_what_a_module_costs_the_warp_engine() -> None:
    """`assetgen bench load --sim mujoco-warp`: the per-module cost at construction. The
    model the device gets holds each module's meshes, so it grows with the modules."""
    from sim.bench.build import bench_build

    two = bench_build(_dataset(), n=2, engine="mujoco-warp")
    three = bench_build(_dataset(), n=3, engine="mujoco-warp")
    assert two["modules"] == 2 and three["modules"] == 3
    assert two["build_ms_per_module"] > 0 and two["device_model_mb_per_module"] > 0
    assert three["device_model_mb_per_module"] * 3 > two["device_model_mb_per_module"] * 2
    with pytest.raises(ValueError, match="at least 2 modules"):
        bench_build(_dataset(), n=1, engine="mujoco-warp")
