"""The PhysX referee (sim/engines/physx/batch.py, sim/engines/physx/usd_module.py): modules read
from their USD files, the same task in the same env, free flight that matches MuJoCo's, an
expert that inserts, and errors that name the file and prim."""

from __future__ import annotations

import functools
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sapien", reason="the physx extra: pip install -e '.[physx]'")
pytest.importorskip("pxr", reason="the physx extra: pip install -e '.[physx]'")

from assetgen.core.mujoco_config import physics_for
from sim.assets.loading import AssetError, load_dataset
from sim.engines.physx.config import PhysxConfig
from sim.engines.physx.usd_module import load_usd_module
from sim.env import PegInHoleVecEnv
from sim.task.config import TaskConfig
from sim.task.expert import DIRECT, expert_action


@functools.cache
def _dataset() -> Path:
    """Three test-split modules (seeds 2048-2050) with MJCF and USD, generated once."""
    import atexit

    from assetgen.dataset.generate import generate
    from assetgen.dataset.spec import DatasetSpec
    from assetgen.params.sampler import SamplerConfig

    tmp = Path(tempfile.mkdtemp(prefix="physx-tests-"))
    atexit.register(shutil.rmtree, tmp, ignore_errors=True)
    spec = DatasetSpec("t", 2048, 3, SamplerConfig(), ("collision", "mjcf", "usd"))
    assert not generate(tmp / "ds", spec, workers=1, progress=False).failures
    return tmp / "ds"


def _quiet() -> TaskConfig:
    return TaskConfig(noise=False, curriculum_steps=0, physics=physics_for(0.001))


def test_the_usd_says_what_module_json_and_the_mjcf_say() -> None:
    for asset in load_dataset(_dataset()):
        usd = load_usd_module(asset.folder, asset)  # checks the frames and the mass
        assert len(usd.pieces) == len(asset.pieces)
        for got, want in zip(usd.pieces, asset.pieces, strict=True):
            np.testing.assert_allclose(np.sort(got, 0), np.sort(want.vertices, 0), atol=1e-7)
        np.testing.assert_allclose(
            np.sort(usd.peg_vertices, 0), np.sort(asset.peg.vertices, 0), atol=1e-7
        )
        assert usd.peg_mass == pytest.approx(asset.peg_mass, rel=1e-6)
        np.testing.assert_allclose(
            np.sort(usd.peg_inertia_diag), np.linalg.eigvalsh(asset.peg_inertia), rtol=1e-5
        )


def test_a_usd_an_engine_cannot_use_names_the_file_and_prim(tmp_path: Path) -> None:
    src = load_dataset(_dataset())[0].folder
    module = tmp_path / "m"
    shutil.copytree(src, module)
    usda = module / "peg_in_hole.usda"
    text = usda.read_text()
    usda.write_text(text.replace('"convex_pieces" {', '"other_pieces" {'))
    with pytest.raises(AssetError, match=r"peg_in_hole.usda: prim /module has no 'convex_pieces'"):
        load_usd_module(module)
    usda.write_text(text.replace("float physics:mass = 0.2", "float physics:mass = 0"))
    with pytest.raises(AssetError, match=r"prim /module/peg has mass 0"):
        load_usd_module(module)
    usda.unlink()
    with pytest.raises(AssetError, match="no such USD file"):
        load_usd_module(module)


def test_free_flight_matches_mujoco() -> None:
    """No contact: the same module, pose and actions give the same trajectory within
    0.1 mm over 60 control steps (PhysX's drive and MuJoCo's actuators both track the
    command with the same gains, integrated implicitly; they differ in the integrator)."""
    mods = load_dataset(_dataset())
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.5, 0.5, (60, len(mods), 6))
    traj = {}
    for engine in ("mujoco", "physx"):
        env = PegInHoleVecEnv(mods, len(mods), _quiet(), engine=engine, nthread=1)
        env.reset(seed=0)
        poses = np.tile(np.eye(4), (len(mods), 1, 1))
        poses[:, 2, 3] = 0.12  # high above the plate
        env.set_peg_poses(np.arange(len(mods)), poses)
        states = []
        for a in actions:
            env.step(a)
            states.append(env.sim.state[:, 1:8].copy())
        traj[engine] = np.array(states)
    mj, px = traj["mujoco"], traj["physx"]
    travel = np.linalg.norm(mj[-1, :, :3] - mj[0, :, :3], axis=1)
    assert travel.min() > 0.01, "the pegs must move for the comparison to mean anything"
    np.testing.assert_allclose(px[..., :3], mj[..., :3], rtol=0, atol=1e-4)
    dot = np.abs(np.einsum("tni,tni->tn", px[..., 3:], mj[..., 3:]))
    assert (1 - dot).max() < 1e-6


def test_the_direct_expert_inserts_under_physx() -> None:
    mods = load_dataset(_dataset())
    cfg = replace(_quiet(), noise=True)
    env = PegInHoleVecEnv(mods, len(mods), cfg, engine="physx")
    assert env.sim.cook_error.max() < 0.02 * min(m.clearance for m in mods)
    obs = env.reset(seed=0)
    done = np.zeros(len(mods), dtype=bool)
    success = np.zeros(len(mods), dtype=bool)
    for _ in range(150):
        obs, _r, term, trunc, info = env.step(expert_action(obs, DIRECT))
        success |= info["success"] & ~done
        done |= term | trunc
        if done.all():
            break
    assert success.all(), success


def test_physx_settings_are_checked() -> None:
    with pytest.raises(ValueError, match=r"timestep = 0.003: must divide the control step"):
        PhysxConfig(timestep=0.003).validate(0.02)
    with pytest.raises(ValueError, match="rest_offset"):
        PhysxConfig(rest_offset=0.003).validate(0.02)
    assert PhysxConfig().substeps(0.02) == 20
    with pytest.raises(ValueError, match="engine 'bullet' is not registered"):
        PegInHoleVecEnv(load_dataset(_dataset()), 3, _quiet(), engine="bullet")
    env = PegInHoleVecEnv(load_dataset(_dataset()), 3, _quiet(), engine="physx")
    with pytest.raises(ValueError, match="saving the env's state is MuJoCo's only"):
        env.get_state()


def test_eval_runs_on_physx_from_the_command_line(tmp_path: Path) -> None:
    import json
    import subprocess
    import sys

    out = tmp_path / "eval.json"
    r = subprocess.run(
        [sys.executable, "-m", "cli", "eval", "--agent", "scripted-direct", "--dataset",
         str(_dataset()), "--attempts", "1", "--sim", "physx", "--out", str(out), "--json"],
        capture_output=True, text=True, cwd=Path(__file__).resolve().parents[1],
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    res = json.loads(out.read_text())
    assert res["engine"] == "physx" and res["physx"]["timestep"] == PhysxConfig().timestep
    assert res["episodes"] == 3 and res["success_rate"] == 1.0


def test_a_piece_cut_in_two_is_the_piece() -> None:
    """_halves: two convex parts on either side of the middle of the longest extent whose
    volumes add up to the piece's and whose union holds every corner."""
    from scipy.spatial import ConvexHull

    from sim.engines.physx.batch import _halves

    rng = np.random.default_rng(0)
    v = rng.normal(size=(40, 3)) * [0.03, 0.01, 0.005]
    a, b = _halves(v)
    whole = ConvexHull(v).volume
    assert ConvexHull(a).volume + ConvexHull(b).volume == pytest.approx(whole, rel=1e-9)
    assert a[:, 0].max() == pytest.approx(b[:, 0].min())  # cut across x, the longest extent
    for p in v:
        assert p[0] <= a[:, 0].max() + 1e-12 or p[0] >= b[:, 0].min() - 1e-12


def test_without_the_extra_the_command_line_names_it(tmp_path: Path) -> None:
    import os
    import subprocess
    import sys

    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(
        "import sys\n"
        "class _Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] == 'sapien':\n"
        "            raise ModuleNotFoundError('sapien is blocked by this test', name=name)\n"
        "sys.meta_path.insert(0, _Block())\n"
    )
    repo = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), str(repo)]))
    r = subprocess.run(
        [sys.executable, "-m", "cli", "eval", "--agent", "scripted", "--dataset",
         str(_dataset()), "--attempts", "1", "--sim", "physx"],
        capture_output=True, text=True, env=env, cwd=repo,
    )  # fmt: skip
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr[-2000:]
    assert len(r.stderr.strip().splitlines()) == 1 and "[physx]" in r.stderr, r.stderr


def test_the_observation_of_a_pose_is_mujocos() -> None:
    mods = load_dataset(_dataset())
    rng = np.random.default_rng(1)
    poses = np.tile(np.eye(4), (len(mods), 1, 1))
    poses[:, :3, 3] = rng.uniform(-0.02, 0.02, (len(mods), 3)) + np.array([0, 0, 0.05])
    obs = {}
    for engine in ("mujoco", "physx"):
        env = PegInHoleVecEnv(mods, len(mods), _quiet(), engine=engine, nthread=1)
        env.reset(seed=0)
        env.set_peg_poses(np.arange(len(mods)), poses)
        obs[engine] = env._obs.copy()
    np.testing.assert_allclose(obs["physx"], obs["mujoco"], rtol=0, atol=1e-6)


def test_the_stress_benchmark_measures_physx_friction() -> None:
    """The friction runs of the contact stress benchmark on PhysX: a peg slid across the
    plate under 1 N shows the configured coefficient (within 5 % at 0.1 and 0.5)."""
    from sim.bench.stress.cases import StressConfig
    from sim.bench.stress.physx import run_module_physx

    cfg = StressConfig(cases=("friction",), friction_values=(0.1, 0.5))
    asset = load_dataset(_dataset())[0]
    records = run_module_physx(asset, cfg, _quiet(), PhysxConfig())
    assert [r["mu"] for r in records] == [0.1, 0.5]
    for r in records:
        assert r["mu_effective"] == pytest.approx(r["mu"], rel=0.05), r
        assert 0 < r["slide_speed"] < cfg.friction_speed  # it slid, held back by friction


def test_the_packed_state_is_what_each_body_says() -> None:
    """PhysxBatchSim reads every peg from PhysX's packed copy (one call); it must agree with
    the bodies' own pose and velocity properties."""
    mods = load_dataset(_dataset())
    env = PegInHoleVecEnv(mods, len(mods), _quiet(), engine="physx")
    env.reset(seed=3)
    rng = np.random.default_rng(2)
    for _ in range(5):
        env.step(rng.uniform(-1, 1, (len(mods), 6)))
    assert np.abs(env.sim.state[:, 8:]).max() > 1e-3, "the pegs must move"
    # float32 copies: the same to float32 rounding
    np.testing.assert_allclose(env.sim.state, env.sim._read_each(), rtol=1e-6, atol=1e-7)


def test_bench_sim_runs_on_physx() -> None:
    """`assetgen bench sim --sim physx`: the env's rate next to the PhysX scene's own control
    steps, one env per module of the first `envs`."""
    from sim.bench.throughput import bench_engine

    res = bench_engine(_dataset(), envs=2, steps=4, rounds=2, engine="physx")
    assert res["engine"] == "physx" and res["envs"] == res["modules"] == 2
    assert res["steps"] == 4 and res["timestep"] == PhysxConfig().timestep
    assert res["env_steps_per_s"] > 0 and res["rollout_steps_per_s"] > 0
    # 20 physics steps per 20 ms control step at 1 ms
    assert res["physics_steps_per_s"] == pytest.approx(res["rollout_steps_per_s"] * 20)
    with pytest.raises(ValueError, match="envs = 0"):
        bench_engine(_dataset(), envs=0, engine="physx")


def test_train_runs_on_physx_from_the_command_line(tmp_path: Path) -> None:
    """`assetgen train --sim physx`: one env per module, the engine recorded with the run;
    fewer envs than modules are refused in one line."""
    import json
    import subprocess
    import sys

    repo = Path(__file__).resolve().parents[1]

    def train(envs: int, out: Path) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "cli", "train", "--algo", "ppo", "--preset", "debug",
             "--dataset", str(_dataset()), "--envs", str(envs), "--steps", "48", "--sim",
             "physx", "--out", str(out), "--no-progress", "--json", "--threads", "1"],
            capture_output=True, text=True, cwd=repo,
        )  # fmt: skip

    r = train(3, tmp_path / "run")
    assert r.returncode == 0, r.stderr[-2000:]
    assert json.loads(r.stdout.strip().splitlines()[-1])["env_steps"] >= 48
    config = json.loads((tmp_path / "run" / "config.json").read_text())
    assert config["env_options"]["engine"] == "physx"
    r = train(2, tmp_path / "few")
    assert r.returncode == 2 and "one env per module" in r.stderr, r.stderr[-2000:]
    assert "Traceback" not in r.stderr


def test_bench_contacts_takes_physx_settings_from_set(tmp_path: Path, capsys) -> None:
    """`bench contacts --sim physx --set FIELD=VALUE` sets PhysxConfig (PCM off here), records
    it in the JSON, and refuses a field PhysX does not have, naming its fields."""
    import json

    from cli import main

    out = tmp_path / "s.json"
    args = ["bench", "contacts", str(_dataset()), "--sim", "physx", "--limit", "1"]
    assert main([*args, "--cases", "friction", "--set", "pcm=false", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["physics"]["pcm"] is False
    assert main([*args, "--set", "solref=1"]) != 0
    assert "PhysxConfig's fields" in capsys.readouterr().err
