"""The vector env: observation, rewards by hand, episode ends, determinism, bad input."""

from __future__ import annotations

import csv
import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from assetgen.core.rotations import rot6d
from assetgen.dataset.reader import Dataset
from sim.assets.loading import AssetError, load_dataset
from sim.env import PegInHoleVecEnv, assign_modules
from sim.task import rules as T
from sim.task.expert import expert_action
from tests.test_sim_common import make_env, modules, quiet, sim_dataset


def _hover(env: PegInHoleVecEnv, i: int, height: float) -> np.ndarray:
    """Aligned with the hole (bottom frame's orientation), on its axis, `height` above the
    entrance along the axis."""
    pose = env.bottom[i].copy()
    depth = -pose[2, 3] / pose[2, 2]
    pose[:3, 3] += (depth + height) * pose[:3, 2]
    return pose


def test_observation_is_the_peg_pose_in_both_frames() -> None:
    env = make_env(2)
    obs = env.reset(seed=3)
    peg = env.peg_poses()
    for i in range(2):
        in_e = np.linalg.inv(env.entrance[i]) @ peg[i]
        in_b = np.linalg.inv(env.bottom[i]) @ peg[i]
        want = np.concatenate([in_e[:3, 3], rot6d(in_e[:3, :3]), in_b[:3, 3], rot6d(in_b[:3, :3])])
        assert obs[i] == pytest.approx(want, abs=1e-6)
    assert obs.shape == (2, 18) and obs.dtype == np.float32


def test_noise_perturbs_one_pose_estimate_consistently() -> None:
    """Both transforms come from one estimate: T_B^-1 T_E recovered from them is exact."""
    env = make_env(1, replace(quiet(), noise=True))
    obs = env.reset(seed=0)
    truth = np.linalg.inv(env.bottom[0]) @ env.entrance[0]
    from sim.task.expert import _split

    t_e, r_e, t_b, r_b = _split(obs.astype(np.float64))
    r_be = r_b[0] @ r_e[0].T
    assert r_be == pytest.approx(truth[:3, :3], abs=1e-5)
    assert t_b[0] - r_be @ t_e[0] == pytest.approx(truth[:3, 3], abs=1e-5)
    clean = T.observe_matrices(env.peg_poses(), env.entrance_inv, env.bottom_inv)
    err = np.abs(obs[0, :3] - clean[0, :3]).max()
    assert 1e-6 < err < 0.003  # 0.5 mm standard deviation


def test_rewards_by_hand() -> None:
    env = make_env(1)
    env.reset(seed=0)
    start = _hover(env, 0, 0.05)
    start[:3, 3] += [0.01, 0.0, 0.0]
    env.set_peg_poses(np.array([0]), start[None])
    d0 = 0.8 * np.linalg.norm((np.linalg.inv(env.bottom[0]) @ start)[:3, 3]) + 0.2 * np.linalg.norm(
        (np.linalg.inv(env.bottom[0]) @ start)[:3, :3] - np.eye(3)
    )
    _, r, term, trunc, _ = env.step(np.zeros((1, 6)))
    assert r[0] == pytest.approx(0.0, abs=1e-9)  # first step, no motion: no progress
    down = np.zeros((1, 6))
    down[0, :3] = -env.bottom[0, :3, 2]  # along the hole axis, into the hole
    _, r, term, trunc, _ = env.step(down * 0.5)
    rel = np.linalg.inv(env.bottom[0]) @ env.peg_poses()[0]
    d1 = 0.8 * np.linalg.norm(rel[:3, 3]) + 0.2 * np.linalg.norm(rel[:3, :3] - np.eye(3))
    assert r[0] == pytest.approx(1 - np.sqrt(d1 / d0), rel=1e-9)
    assert r[0] > 0  # toward the seat
    _, r, _, _, _ = env.step(-down)
    assert r[0] < 0  # away from it
    assert not term[0] and not trunc[0]


def test_successful_episode_returns_exactly_one() -> None:
    env = make_env(2, replace(quiet(), noise=True))
    obs = env.reset(seed=1)
    returns: list[float] = []
    total = np.zeros(2)
    for _ in range(500):
        obs, r, term, trunc, info = env.step(expert_action(obs))
        total += r
        for i in np.flatnonzero(term | trunc):
            assert info["success"][i]
            assert info["episode_return"][i] == 1.0
            assert total[i] == 1.0  # the float sum of the rewards, exactly
            assert info["time_to_success"][i] == info["episode_length"][i] * env.control_dt
            # within 5 mm of the seat, seen through the observation noise
            assert info["final_obs"][i][9:12] == pytest.approx(np.zeros(3), abs=0.0075)
            returns.append(total[i])
            total[i] = 0.0
        if len(returns) >= 2:
            break
    assert returns == [1.0, 1.0]


def test_going_below_the_surface_outside_the_hole_fails() -> None:
    env = make_env(1)
    env.reset(seed=0)
    beside = np.eye(4)
    beside[:3, 3] = [0.12, 0.0, 0.01]  # beyond the plate's edge (+-0.075 m)
    env.set_peg_poses(np.array([0]), beside[None])
    steps = 0
    while steps < 100:
        _, r, term, trunc, info = env.step(np.array([[0, 0, -1.0, 0, 0, 0]]))
        steps += 1
        if term[0]:
            break
    assert term[0] and not trunc[0]
    assert info["failure"][0] and not info["success"][0]
    assert r[0] == -1.0
    # it ends once the peg's lowest point is 2.5 mm below the surface: 12.5 mm of travel
    assert steps == pytest.approx(0.0125 / (0.25 * env.control_dt), abs=1.5)


def test_inside_the_hole_is_not_a_failure() -> None:
    env = make_env(1)
    env.reset(seed=0)
    env.set_peg_poses(np.array([0]), _hover(env, 0, -0.006)[None])  # 6 mm into the hole
    _, _, term, _, info = env.step(np.zeros((1, 6)))
    assert not term[0] and not info["failure"][0]


def test_truncation_at_the_step_limit_and_automatic_reset() -> None:
    env = make_env(2, replace(quiet(), max_steps=5))
    env.reset(seed=0)
    for k in range(5):
        obs, _, term, trunc, info = env.step(np.zeros((2, 6)))
        assert trunc.all() == (k == 4)
    assert not term.any()
    assert (info["episode_length"] == 5).all()
    assert np.isnan(info["time_to_success"]).all()
    assert not np.allclose(obs, info["final_obs"])  # obs already starts the next episode
    _, _, _, trunc, info = env.step(np.zeros((2, 6)))
    assert not trunc.any() and (info["episode_length"] == 1).all()


def test_same_seed_same_trajectories() -> None:
    def run(seed: int) -> list[np.ndarray]:
        env = make_env(2, replace(quiet(), noise=True, max_steps=20))
        rng = np.random.default_rng(7)
        out = [env.reset(seed=seed)]
        for _ in range(30):
            obs, r, term, trunc, _ = env.step(rng.uniform(-1, 1, (2, 6)))
            out += [obs, r, term, trunc]
        return out

    a, b, c = run(5), run(5), run(6)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not np.array_equal(a[0], c[0])


def test_bad_actions_raise_naming_the_envs() -> None:
    env = make_env(3)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(num_envs, 6\) = \(3, 6\), got \(3, 5\)"):
        env.step(np.zeros((3, 5)))
    bad = np.zeros((3, 6))
    bad[1, 2] = np.nan
    bad[2, 0] = np.inf
    with pytest.raises(ValueError, match=r"envs \[1, 2\] contain NaN or inf"):
        env.step(bad)


@pytest.mark.parametrize("shard_size", [1, 2])
def test_unstable_env_is_reset_and_reported_without_stopping_the_batch(shard_size: int) -> None:
    """Env 1 breaks. With one model per env only it is hit; in shards of 2, MuJoCo stops
    stepping its shard, so its shard-mate (env 0) is reported too; env 2 goes on."""
    env = make_env(3, shard_size=shard_size)
    twin = make_env(3, shard_size=shard_size)
    env.reset(seed=0)
    twin.reset(seed=0)
    env.sim.state[1, 8:] = np.nan  # broken physics in env 1 only
    obs, r, term, trunc, info = env.step(np.zeros((3, 6)))
    ref, *_ = twin.step(np.zeros((3, 6)))
    hit = [False, True, False] if shard_size == 1 else [True, True, False]
    assert info["unstable"].tolist() == hit
    assert trunc.tolist() == hit and not term.any()
    assert (r[hit] == 0.0).all() and env.unstable_count == sum(hit)
    assert np.isfinite(obs).all() and np.isfinite(env.sim.state).all()
    assert np.array_equal(obs[2], ref[2])  # the other shard is untouched
    obs, *_ = env.step(np.zeros((3, 6)))  # and the batch goes on
    assert np.isfinite(obs).all()


def test_envs_that_no_longer_count_are_parked_and_their_shards_skipped() -> None:
    """An evaluation's tail, in shards of 2. Envs 0, 1 (one shard) stop counting: parked
    above their holes, that shard is not stepped at all; envs 2, 3 move exactly as in a twin
    that steps every env (shards are separate MuJoCo models). Then env 3 stops counting
    too: its peg hangs at rest out of contact while env 2 plays on, and no parked episode
    ever ends. None gives the parked envs new episodes."""
    cfg = replace(quiet(), max_steps=3)
    env, twin = make_env(4, cfg, shard_size=2), make_env(4, cfg, shard_size=2)
    env.reset(seed=0)
    twin.reset(seed=0)
    act = np.random.default_rng(1).uniform(-1, 1, (4, 6))
    env.set_live(np.array([False, False, True, True]))
    parked = env.sim.state[:2].copy()
    up = env.entrance[:2, :3, 3] + env.PARK_HEIGHT * env.entrance[:2, :3, 2]
    assert np.allclose(parked[:, 1:4], up) and not parked[:, 8:].any()
    for _ in range(2):
        obs, _, term, trunc, info = env.step(act)
        ref, *_ = twin.step(act)
        # not stepped: the time stands, the pose moves by no more than the shard offset's
        # rounding (x + spacing - spacing)
        assert np.array_equal(env.sim.state[:2, 0], parked[:, 0])
        assert np.allclose(env.sim.state[:2], parked, rtol=0.0, atol=1e-12)
        assert np.array_equal(obs[2:], ref[2:])
        assert np.array_equal(env.sim.state[2:], twin.sim.state[2:])
    env.set_live(np.array([False, False, True, False]))
    for _ in range(5):  # past max_steps
        _, _, term, trunc, info = env.step(act)
        assert not (term | trunc)[[0, 1, 3]].any() and not info["unstable"].any()
    assert trunc[2] or term[2] or info["episode_length"][2] < 3  # env 2 goes on as before
    hang = env.entrance[3, :3, 3] + env.PARK_HEIGHT * env.entrance[3, :3, 2]
    assert np.linalg.norm(env.sim.state[3, 1:4] - hang) < 1e-3
    assert len(env.sim.contacts(3)[0]) == 0
    with pytest.raises(ValueError, match=r"live must have shape \(4,\)"):
        env.set_live(np.ones(3, dtype=bool))
    env.set_live(None)
    spawned = env.sim.state[[0, 1, 3], 1:4]
    assert (np.linalg.norm(spawned - np.vstack([up, hang]), axis=1) > 1e-3).all()  # new spawns
    t = env.sim.state[:, 0].copy()
    _, _, _, _, info = env.step(act)
    assert (env.sim.state[:, 0] > t).all() and (info["episode_length"][[0, 1, 3]] == 1).all()


def test_runaway_peg_is_reset_and_reported() -> None:
    """A finite but runaway state (a solver blow-up) is unstable too: left alone it would
    feed km-scale observations to the learner."""
    env = make_env(2)
    env.reset(seed=0)
    # the controller halves the speed every physics step: still ~70 m/s after the 4 substeps
    env.sim.qvel[0, :3] = [0.0, 0.0, 1000.0]
    env.sim.qvel[1, :3] = [0.0, 8.0, 0.0]  # fast, but below runaway_speed: physics
    _, r, term, trunc, info = env.step(np.zeros((2, 6)))
    assert info["unstable"].tolist() == [True, False] and trunc.tolist() == [True, False]
    assert not term.any()
    assert r[0] == 0.0 and env.unstable_count == 1
    assert np.abs(env.sim.qvel[0]).max() == 0.0  # reset at rest
    assert np.linalg.norm(env.sim.qvel[1, :3]) < 8.0  # damped, not flagged


def test_missing_or_corrupt_dataset_fails_before_simulating(tmp_path: Path) -> None:
    with pytest.raises(AssetError, match="not a dataset"):
        PegInHoleVecEnv(tmp_path / "nothing")
    broken = tmp_path / "ds"
    shutil.copytree(sim_dataset(), broken)
    mid = load_dataset(broken)[0].id
    mjcf = broken / "modules" / mid / "peg_in_hole.xml"
    good = mjcf.read_bytes()
    mjcf.write_bytes(good[: len(good) // 2])  # truncated
    with pytest.raises(AssetError, match=r"peg_in_hole\.xml: not valid XML"):
        PegInHoleVecEnv(broken)
    # the peg's faces point past its vertices
    mjcf.write_bytes(good.replace(b'face="', b'face="999 998 997 ', 1))
    with pytest.raises(AssetError, match=r"peg_in_hole\.xml: mesh 'peg': face index"):
        PegInHoleVecEnv(broken)
    mjcf.unlink()
    with pytest.raises(AssetError, match=r"peg_in_hole\.xml: missing"):
        PegInHoleVecEnv(broken)
    mjcf.write_bytes(good)
    meta = broken / "modules" / mid / "module.json"
    d = json.loads(meta.read_text())
    del d["frames"]
    meta.write_text(json.dumps(d))
    with pytest.raises(AssetError, match=r"module\.json.*frames"):
        PegInHoleVecEnv(broken)


def test_curriculum_grows_the_spawn_ranges() -> None:
    cfg = replace(quiet(), curriculum_steps=1000)
    env = make_env(4, cfg)
    obs = env.reset(seed=0)
    assert np.abs(obs[:, :2]).max() < 1e-9  # scale 0: at the entrance, upright
    assert obs[:, 2] == pytest.approx(0.001, abs=1e-6)  # lifted 1 mm clear of the surface
    env.global_step = 500  # half way
    obs = env.reset(seed=0)
    assert np.abs(obs[:, :2]).max() <= 0.125
    assert (obs[:, 2] <= 0.125 + 1e-6).all()
    env.global_step = 10**9
    assert env.curriculum_scale() == 1.0
    full = make_env(4).reset(seed=0)  # curriculum off: full ranges
    assert np.abs(full[:, :2]).max() > 0.05 and (full[:, 2] >= 0.15 - 1e-6).all()


def test_module_assignment() -> None:
    assert assign_modules(4, 3, 0).tolist() == [0, 1, 2]
    a = assign_modules(4, 11, 9)
    assert a[:4].tolist() == [0, 1, 2, 3]
    assert sorted(a[4:8].tolist()) == [0, 1, 2, 3]  # each module once per round
    assert np.array_equal(a, assign_modules(4, 11, 9))
    env = PegInHoleVecEnv(list(modules()), 6, quiet(), nthread=1)
    assert env.env_module.tolist()[:4] == [0, 1, 2, 3]


def test_conforms_to_the_rl_contract() -> None:
    from rl.vec_env import StatefulVecEnv, check_step

    env = make_env(3, replace(quiet(), noise=True, max_steps=2))
    assert isinstance(env, StatefulVecEnv)
    env.reset(seed=0)
    for _ in range(3):  # across an episode end
        check_step(env, env.step(np.zeros((3, 6), dtype=np.float32)))


def _rotating_env(cfg, seed: int = 0) -> PegInHoleVecEnv:
    """2 envs taking turns over the 4 modules."""
    return PegInHoleVecEnv(
        list(modules()), 2, cfg, nthread=1, rotate_modules=True, assignment_seed=seed
    )


def test_module_rotation_trains_on_every_module() -> None:
    env = _rotating_env(replace(quiet(), max_steps=2), seed=1)
    assert env.rotate_modules and env.sim.shard_size == 1
    env.reset(seed=0)
    seen = []
    for _ in range(8):
        *_, truncated, info = env.step(np.zeros((2, 6)))
        seen += info["module"][truncated].tolist()
        for e in range(2):  # the env's constants and model are its current module's
            m = modules()[env.env_module[e]]
            assert np.array_equal(env.entrance[e], m.entrance)
            assert np.array_equal(env.peg_vertices[e, : len(m.peg.vertices)], m.peg.vertices)
            peg = env.sim.models[e].geom("peg")
            assert env.sim.peg_geom[e] == peg.id
            assert env.sim.models[e].ngeom == env.sim.pool[m.id].ngeom
    # 8 episodes over 4 modules: each module twice, two envs never on the same one
    assert np.bincount(seen, minlength=4).tolist() == [2, 2, 2, 2]
    assert len(set(env.env_module.tolist())) == 2
    # without rotation (or with as many envs as modules) the assignment stays
    fixed = PegInHoleVecEnv(list(modules()), 4, quiet(), nthread=1, rotate_modules=True)
    assert not fixed.rotate_modules


@pytest.mark.parametrize("rotate", [False, True])
def test_exact_resume_from_get_state(rotate: bool) -> None:
    cfg = replace(quiet(), noise=True, max_steps=12, curriculum_steps=400)
    rng = np.random.default_rng(3)
    n = 2 if rotate else 3
    acts = [rng.uniform(-1, 1, (n, 6)) for _ in range(30)]

    def build() -> PegInHoleVecEnv:
        return _rotating_env(cfg) if rotate else make_env(3, cfg, shard_size=2)

    env = build()
    env.reset(seed=4)
    for a in acts[:10]:
        env.step(a)
    state = env.get_state()
    state["rng"] = json.loads(json.dumps(state["rng"]))  # JSON-able, as checkpoints need
    after = [env.step(a) for a in acts[10:]]
    other = build()
    other.reset(seed=99)  # a different history, overwritten by the state
    for _ in range(13):  # and other modules, when rotating
        other.step(acts[0])
    other.set_state(state)
    again = [other.step(a) for a in acts[10:]]
    for x, y in zip(after, again, strict=True):
        for u, v in zip(x[:4], y[:4], strict=True):
            assert np.array_equal(u, v)
        assert np.array_equal(x[4]["episode_return"], y[4]["episode_return"])
        assert np.array_equal(x[4]["module"], y[4]["module"])
    if rotate:
        assert len({tuple(x[4]["module"]) for x in after}) > 1  # modules did change
    with pytest.raises(ValueError, match="shard_state"):
        make_env(2, cfg).set_state(state)


def test_a_state_saved_right_after_a_reset_holds_the_new_spawn() -> None:
    # a reset writes the per-env state only; a state saved before the next step must still
    # carry it, or the resumed env starts its new episode where the last one ended
    env = make_env(3, quiet(curriculum_steps=400))
    env.reset(seed=6)
    env.set_peg_poses(np.array([0]), env.bottom[[0]])  # on the seat: succeeds at once
    _, _, term, _, _ = env.step(np.zeros((3, 6)))
    assert term[0]
    other = make_env(3, quiet(curriculum_steps=400))
    other.reset(seed=7)
    other.set_state(env.get_state())
    assert np.array_equal(other.sim.state, env.sim.state)
    acts = np.random.default_rng(1).uniform(-1, 1, (5, 3, 6))
    for a in acts:
        assert np.array_equal(env.step(a)[0], other.step(a)[0])


def test_factories_for_rl() -> None:
    from sim.env import make_eval_env, make_train_env

    env = make_train_env(str(sim_dataset()), 5, 1)
    assert env.num_envs == 5 and env.cfg.curriculum_steps == 50_000_000
    assert make_train_env(str(sim_dataset()), 3, 1).rotate_modules  # fewer envs than modules
    assert make_eval_env(str(sim_dataset()), 4, 0).curriculum_scale() == 1.0
    with pytest.raises(ValueError, match="no dataset spec named"):
        make_eval_env("no-such-dataset", 1, 0)


_BLOCK = """
import sys
class _Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {blocked!r}:
            raise ModuleNotFoundError(f"{{name}} is blocked by this test", name=name)
sys.meta_path.insert(0, _Block())
"""
_CAD_STACK = {"fcl", "manifold3d", "coacd", "pxr", "trimesh", "scipy", "viser"}


def test_training_needs_no_cad_stack_nor_viewer(tmp_path: Path) -> None:
    """What a training machine installs (the base and the `rl` extra) is enough: with the
    generator's libraries (python-fcl, manifold3d, USD, ...) and viser blocked, the CLI
    trains a few steps on a dataset made elsewhere and evaluates the checkpoint."""
    import os
    import subprocess
    import sys

    (tmp_path / "sitecustomize.py").write_text(_BLOCK.format(blocked=sorted(_CAD_STACK)))
    repo = Path(__file__).resolve().parents[1]
    path = [str(tmp_path), str(repo), *filter(None, [os.environ.get("PYTHONPATH")])]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(path))

    def cli(*args: str) -> subprocess.CompletedProcess:
        cmd = [sys.executable, "-m", "cli", *args]
        return subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tmp_path)

    data, run = str(sim_dataset()), str(tmp_path / "run")
    r = cli("train", "--algo", "ppo", "--preset", "debug", "--dataset", data, "--envs", "2",
            "--steps", "64", "--out", run, "--no-progress", "--json")  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    assert json.loads(r.stdout.strip().splitlines()[-1])["env_steps"] == 64
    r = cli("eval", "--checkpoint", run, "--dataset", data, "--attempts", "1", "--json",
            "--record", str(tmp_path / "rec"))  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    assert res["episodes"] == len(Dataset(data)) and res["policy"] == "deterministic"
    assert len(list((tmp_path / "rec").glob("*.npz"))) == len(Dataset(data))
    # the blocker works: the generator and the viewer cannot be imported under it
    for module in ("assetgen.checks.module_checks", "preview.server"):
        r = subprocess.run([sys.executable, "-c", f"import {module}"], env=env, text=True,
                           capture_output=True)  # fmt: skip
        assert r.returncode != 0 and "blocked by this test" in r.stderr, module
    # and a command that needs them says which extra to install, in one line
    r = cli("sample", "--n", "1", "--out", str(tmp_path / "d"), "--quiet")
    assert r.returncode == 2 and "[cad] extra" in r.stderr and "Traceback" not in r.stderr
    r = cli("view", data, "--html", str(tmp_path / "view.html"))
    assert r.returncode == 2 and "[view] extra" in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_sac_learns_from_the_scripted_teacher(tmp_path: Path) -> None:
    """`train --demos scripted`: the expert plays the warm-up (so those episodes succeed),
    its actions label the buffer, and the BC weight decays as configured; a missing source
    is refused by name."""
    import torch

    from cli import main

    torch.set_num_threads(1)
    data, run = str(sim_dataset()), tmp_path / "run"
    base = ["train", "--algo", "sac", "--preset", "debug", "--dataset", data, "--envs", "4",
            "--steps", "1536", "--no-progress"]  # fmt: skip
    argv = [*base, "--out", str(run), "--demos", "scripted", "--set", "warmup_steps=1024",
            "--set", "bc_decay_steps=2048", "--set", "teacher_noise=0"]  # fmt: skip
    assert main(argv) == 0
    meta = json.loads((run / "config.json").read_text())
    assert meta["demos"] == "scripted" and meta["overrides"]["bc_decay_steps"] == 2048
    assert meta["config"]["warmup_steps"] == 1024
    rows = list(csv.DictReader(open(run / "metrics.csv")))
    warm = [r for r in rows if int(r["env_steps"]) <= 1024 and r["success_rate"] not in ("", "nan")]
    assert warm and float(warm[-1]["success_rate"]) >= 0.9  # the expert's episodes
    w = [float(r["bc_weight"]) for r in rows]
    expected = [0.5 * max(0.0, 1 - int(r["env_steps"]) / 2048) for r in rows]
    assert w == pytest.approx(expected)
    assert any(r["bc_loss"] not in ("", "nan") for r in rows)
    assert main([*base, "--out", str(tmp_path / "r2"), "--demos", "nope"]) == 2
    assert main([*base, "--out", str(tmp_path / "r3"), "--set", "bc_wt=1"]) == 2


def test_dreamer_warm_up_is_played_by_the_teacher(tmp_path: Path) -> None:
    """`train --algo dreamer --demos scripted-fast`: the fast expert plays the warm-up, so
    its episodes succeed and their rewards are in the replay; PPO has no teacher."""
    import torch

    from cli import main
    from rl import checkpoint as ckpt

    torch.set_num_threads(1)
    data, run = str(sim_dataset()), tmp_path / "run"
    base = ["train", "--preset", "debug", "--dataset", data, "--envs", "4", "--steps", "1024",
            "--no-progress"]  # fmt: skip
    argv = [*base, "--algo", "dreamer", "--out", str(run), "--demos", "scripted-fast",
            "--set", "warmup_steps=1024", "--set", "teacher_noise=0"]  # fmt: skip
    assert main(argv) == 0
    assert json.loads((run / "config.json").read_text())["demos"] == "scripted-fast"
    rows = list(csv.DictReader(open(run / "metrics.csv")))
    done = [r for r in rows if r["success_rate"] not in ("", "nan")]
    assert done and float(done[-1]["success_rate"]) >= 0.9
    tensors, doc = ckpt.load(run / "checkpoint.safetensors")
    replay = ckpt.unpack(doc["agent_extra"]["tensors"], tensors)
    rewards = np.concatenate([np.asarray(v).ravel() for k, v in _leaves(replay) if "reward" in k])
    assert rewards.sum() > 4  # several episodes' worth of progress reward (1 per success)
    ppo = [*base, "--algo", "ppo", "--out", str(tmp_path / "ppo"), "--demos", "scripted"]
    assert main(ppo) == 2


def _leaves(tree, prefix=""):
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield from _leaves(v, f"{prefix}/{k}")
    else:
        yield prefix, tree


def test_train_probe_on_the_first_modules(tmp_path: Path) -> None:
    """`train --probe-steps`: the frozen policy on the training set's first modules, logged
    in probe_* columns; bad probe settings are refused by name."""
    import torch

    from cli import main

    torch.set_num_threads(1)
    data, run = str(sim_dataset()), tmp_path / "run"
    base = ["train", "--algo", "sac", "--preset", "debug", "--dataset", data, "--envs", "4",
            "--steps", "128", "--no-progress"]  # fmt: skip
    argv = [*base, "--out", str(run), "--probe-steps", "64", "--probe-modules", "2",
            "--probe-attempts", "1"]  # fmt: skip
    assert main(argv) == 0
    rows = list(csv.DictReader(open(run / "metrics.csv")))
    probed = [r for r in rows if r["probe_success_rate"] != ""]
    assert [int(r["env_steps"]) for r in probed] == [64, 128]
    assert all(float(r["probe_truncation_rate"]) + float(r["probe_success_rate"]) <= 1.0
               for r in probed)  # fmt: skip
    assert json.loads((run / "config.json").read_text())["probe_steps"] == 64
    from sim import make_eval_env

    env = make_eval_env(data, None, 0, modules=2)
    assert env.num_envs == 2 and env.module_ids == sorted(env.module_ids)
    bad = [*base, "--out", str(tmp_path / "bad")]
    assert main([*bad, "--probe-steps", "0"]) == 2
    assert main([*bad, "--probe-steps", "64", "--probe-modules", "0"]) == 2
