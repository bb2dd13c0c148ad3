"""The env on the device (sim/engines/warp/env.py), run on Warp's CPU device so that CI needs
no GPU: the same states, observations and rewards as the host env on the same engine, the host's
module rotation, each world's fields those of its module, and the spawn's ranges."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("warp", reason="the warp extra: pip install -e '.[warp]'")
pytest.importorskip("mujoco_warp", reason="the warp extra: pip install -e '.[warp]'")
torch = pytest.importorskip("torch")

from sim.assets.loading import load_dataset  # noqa: E402
from sim.engines.warp.env import WarpTorchVecEnv  # noqa: E402
from sim.env import PegInHoleVecEnv  # noqa: E402
from sim.task.expert import DIRECT, expert_action  # noqa: E402
from tests.test_warp import _dataset, _quiet  # noqa: E402


def _fixed_contact():
    """No noise, and contact draws that cannot differ between the two envs' generators."""
    return replace(_quiet(), friction_range=(0.6, 0.6), restitution_range=(0.3, 0.3))


def test_the_same_steps_as_the_host_env_on_the_same_engine() -> None:
    """From the same poses with the same actions (the direct expert's, into contact and the
    seat), the device env's physics gives the host env's states bit for bit, and its
    arithmetic the host kernels' observations, rewards and outcomes, up to the episodes'
    ends (after which each env draws its own spawns)."""
    mods = load_dataset(_dataset())[:2]
    cfg = _fixed_contact()
    host = PegInHoleVecEnv(mods, 2, cfg, engine="mujoco-warp", warp_device="cpu")
    dev = WarpTorchVecEnv(mods, 2, cfg, device="cpu")
    host.reset(seed=0)
    dev.reset(seed=0)
    # upright, 2 cm and 1.5 cm beside the hole, pressed 0.2 mm into the mounting surface:
    # the expert slides them on it into the hole
    poses = np.stack([m.entrance for m in mods])
    low = np.array([m.peg.vertices[:, 2].min() for m in mods])
    poses[:, :3, 3] += np.array([[0.02, 0.0, 0.0], [0.0, -0.015, 0.0]])
    poses[:, 2, 3] += -low - 2e-4
    host.set_peg_poses(np.arange(2), poses)
    dev.set_peg_poses(np.arange(2), poses)
    obs = host._obs.copy()
    np.testing.assert_allclose(dev._episode.last_obs.numpy(), obs, rtol=0, atol=1e-6)
    live = np.ones(2, dtype=bool)
    seen = {"success": 0, "contact steps": 0}
    for _ in range(200):
        a = expert_action(obs, DIRECT)
        obs, r, term, trunc, info = host.step(a)
        dobs, dr, dterm, dtrunc, dinfo = dev.step(torch.as_tensor(a))
        np.testing.assert_array_equal(dinfo["peg_pose"].numpy()[live], info["peg_pose"][live])
        np.testing.assert_allclose(dr.numpy()[live], r[live], rtol=0, atol=1e-6)
        np.testing.assert_allclose(dinfo["final_obs"].numpy()[live], info["final_obs"][live],
                                   rtol=0, atol=1e-5)  # fmt: skip
        for k in ("success", "failure", "unstable"):
            np.testing.assert_array_equal(dinfo[k].numpy()[live], info[k][live])
        np.testing.assert_array_equal(dterm.numpy()[live], term[live])
        np.testing.assert_array_equal(dtrunc.numpy()[live], trunc[live])
        seen["success"] += int(info["success"][live].sum())
        seen["contact steps"] += int(host.sim.data.nacon.numpy()[0] > 0)
        live &= ~(term | trunc)
        np.testing.assert_allclose(dobs.numpy()[live], obs[live], rtol=0, atol=1e-5)
        if not live.any():
            break
    assert seen["success"] == 2 and seen["contact steps"] > 5, seen
    host.close()
    dev.close()


def test_modules_rotate_as_in_the_host_env() -> None:
    """Batched on the device, the rotation is the host env's FIFO: envs that finish hand
    their modules to the back of the queue and take the front ones in env order, also when
    more envs finish at once than modules wait (4 modules, 3 envs: one waits). Each world's
    fields and fixed-geom poses are then its module's."""
    mods = load_dataset(_dataset())
    extra = [replace(mods[0], id=f"{mods[0].id}b")]  # a fourth module (the first's copy)
    mods = mods + extra
    cfg = _quiet()
    dev = WarpTorchVecEnv(mods, 3, cfg, rotate_modules=True, device="cpu")
    host = dev.base  # the host env's own rotation, run on its own copy of the assignment
    rng = np.random.default_rng(0)
    for _ in range(12):
        mask = rng.random(3) < 0.6
        dev.rotate_envs(torch.as_tensor(mask))
        host.rotate_envs(np.flatnonzero(mask))
        assert dev.env_module.tolist() == host.env_module.tolist()
        assert dev.module_queue.tolist() == host.module_queue
    dev._use_modules(torch.ones(3, dtype=torch.bool))
    sim = dev.sim
    for e, k in enumerate(dev.env_module.tolist()):
        want = sim.per_module[dev.module_ids[k]]
        np.testing.assert_array_equal(dev._fields["geom_dataid"][e].numpy(), want["geom_dataid"])
        np.testing.assert_allclose(dev._fields["geom_pos"][e].numpy(), want["geom_pos"], atol=1e-7)
        pos, _mat = sim._slot_pose[dev.module_ids[k]]
        np.testing.assert_allclose(dev._xpos[e, : sim.slots].numpy(), pos, atol=1e-7)
    dev.close()


def test_resets_draw_fresh_episodes_and_a_seed_repeats_them() -> None:
    """Finished envs start again at a new spawn with their contact drawn; a seeded reset
    repeats the same episodes."""
    mods = load_dataset(_dataset())
    env = WarpTorchVecEnv(mods, 2, replace(_quiet(), noise=True), rotate_modules=True,
                          device="cpu")  # fmt: skip
    first = env.reset(seed=3).clone()
    g = env.sim.peg_geom
    friction = env._fields["geom_friction"][:, g, 0].clone()
    assert ((friction >= 0) & (friction <= 1)).all() and friction[0] != friction[1]
    again = env.reset(seed=3)
    torch.testing.assert_close(again, first)
    torch.testing.assert_close(env._fields["geom_friction"][:, g, 0], friction)
    env.close()


def test_bad_actions_are_refused() -> None:
    env = WarpTorchVecEnv(load_dataset(_dataset())[:1], 1, _quiet(), device="cpu")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(num_envs, 6\) = \(1, 6\)"):
        env.step(torch.zeros(2, 6))
    env.close()


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_training_on_the_device_env(algo: str, tmp_path, monkeypatch) -> None:
    """`assetgen train --sim mujoco-warp` steps the env on the device: PPO hands it its
    actions as tensors (no copy through the host), SAC through the numpy view; both finish
    and write a checkpoint that evaluates on the host env."""
    import json

    from cli import main
    from rl.host_view import HostView
    from sim.engines.warp import env as warp_env

    seen: dict[str, int] = {"device": 0, "view": 0}
    steps = {"device": warp_env.WarpTorchVecEnv.step, "view": HostView.step}

    def spy(key: str):
        def step(self, actions):
            seen[key] += 1
            assert isinstance(actions, torch.Tensor) == (key == "device")
            return steps[key](self, actions)

        return step

    monkeypatch.setattr(warp_env.WarpTorchVecEnv, "step", spy("device"))
    monkeypatch.setattr(HostView, "step", spy("view"))
    out = tmp_path / algo
    sets = (["--set", "horizon=4", "--set", "minibatch_size=8", "--set", "epochs=1"]
            if algo == "ppo" else ["--set", "batch_size=8", "--set", "warmup_steps=4",
                                   "--set", "buffer_size=64"])  # fmt: skip
    argv = ["train", "--algo", algo, "--dataset", str(_dataset()), "--sim", "mujoco-warp",
            "--allow-cpu", "--envs", "2", "--steps", "16", "--out", str(out), "--json",
            "--no-progress", "--device", "cpu", *sets]  # fmt: skip
    assert main(argv) == 0
    assert seen["device"] >= 8 and seen["view"] == (0 if algo == "ppo" else seen["device"])
    rows = (out / "metrics.csv").read_text().splitlines()
    assert len(rows) >= 2 and (out / "checkpoint.safetensors").exists()
    res = tmp_path / "eval.json"
    assert main(["eval", "--checkpoint", str(out), "--dataset", str(_dataset()),
                 "--attempts", "1", "--out", str(res)]) == 0  # fmt: skip
    assert json.loads(res.read_text())["episodes"] == 3
