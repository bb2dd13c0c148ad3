"""Checkpoints: round trip, corrupt files, checkpoints of another configuration."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from rl import checkpoint as ckpt
from rl.ppo import PPOConfig
from rl.presets import Setup
from rl.run_state import CHECKPOINT, load_agent
from rl.runner import train
from tests.toy_env import ToyEnv

torch.set_num_threads(1)
SETUP = Setup(PPOConfig(hidden=(8,), horizon=4, minibatch_size=16, epochs=1), 4, 32, 16)


def _run(tmp_path, stack: int = 1, **kw) -> dict:
    return train("ppo", ToyEnv(4), kw.pop("setup", SETUP), seed=0, out_dir=tmp_path, stack=stack,
                 progress=False, tensorboard=False, **kw)  # fmt: skip


def test_pack_round_trip(tmp_path) -> None:
    tree = {
        "a": torch.arange(6.0).reshape(2, 3),
        "opt": {"state": {0: {"step": torch.tensor(3.0)}, 1: {}}, "groups": [{"lr": 1e-3}]},
        "rng": {"state": 2**127 + 5, "name": "PCG64"},
        "arr": np.array([1, 2, 3], dtype=np.int64),
        "flags": np.array([True, False]),
        "pair": (1.5, None),
    }
    tensors: dict[str, torch.Tensor] = {}
    doc = ckpt.pack(tree, "t", tensors)
    ckpt.save(tmp_path / "c.safetensors", tensors, {"tree": doc})
    t2, doc2 = ckpt.load(tmp_path / "c.safetensors")
    back = ckpt.unpack(doc2["tree"], t2)
    assert torch.equal(back["a"], tree["a"])
    assert back["opt"]["state"][0]["step"].item() == 3.0 and back["opt"]["state"][1] == {}
    assert back["rng"]["state"] == 2**127 + 5 and back["pair"] == [1.5, None]
    assert isinstance(back["arr"], np.ndarray) and back["arr"].tolist() == [1, 2, 3]
    assert back["flags"].tolist() == [True, False]
    assert not list(tmp_path.glob(".*tmp*"))  # no temporary file left behind


def test_agent_round_trip(tmp_path) -> None:
    _run(tmp_path)
    agent, meta = load_agent(tmp_path, "cpu")
    assert meta["algo"] == "ppo" and meta["obs_dim"] == 4 and meta["stack"] == 1
    agent2, _ = load_agent(tmp_path / CHECKPOINT, "cpu")
    for (k, a), b in zip(agent.net.state_dict().items(), agent2.net.state_dict().values(),
                         strict=True):  # fmt: skip
        assert torch.equal(a, b), k
    obs = np.random.default_rng(0).normal(size=(5, 4)).astype(np.float32)
    np.testing.assert_array_equal(agent.policy(obs), agent2.policy(obs))
    # the counters alone, without the tensors: what an evaluation records of its weights
    _, doc = ckpt.load(tmp_path / CHECKPOINT)
    assert ckpt.read_counters(tmp_path) == doc["counters"] and "env_steps" in doc["counters"]
    with pytest.raises(ckpt.CheckpointError, match="no checkpoint at"):
        ckpt.read_counters(tmp_path / "missing")


def test_corrupt_checkpoints_raise(tmp_path) -> None:
    _run(tmp_path)
    path = tmp_path / CHECKPOINT
    good = path.read_bytes()

    path.write_bytes(good[: len(good) // 2])  # truncated
    with pytest.raises(ckpt.CheckpointError, match="corrupt"):
        load_agent(tmp_path)
    flipped = bytearray(good)
    flipped[-3] ^= 0xFF  # a byte of tensor data
    path.write_bytes(bytes(flipped))
    with pytest.raises(ckpt.CheckpointError, match="SHA-256"):
        load_agent(tmp_path)
    path.write_bytes(b"not a checkpoint at all")
    with pytest.raises(ckpt.CheckpointError, match="corrupt or not a checkpoint"):
        load_agent(tmp_path)
    from safetensors.torch import save_file

    save_file({"x": torch.zeros(2)}, str(path))
    with pytest.raises(ckpt.CheckpointError, match="not a rl-checkpoint"):
        load_agent(tmp_path)
    with pytest.raises(ckpt.CheckpointError, match="no checkpoint at"):
        load_agent(tmp_path / "missing")


def test_resume_of_another_configuration_raises(tmp_path) -> None:
    _run(tmp_path)
    with pytest.raises(ckpt.CheckpointError, match=r"obs_dim: checkpoint 4, now 12.*stack"):
        _run(tmp_path, stack=3, resume=True, steps=64)
    other = Setup(PPOConfig(hidden=(16,), horizon=4, minibatch_size=16, epochs=1), 4, 32, 16)
    with pytest.raises(ckpt.CheckpointError, match=r"config.hidden: checkpoint \[8\], now \[16\]"):
        _run(tmp_path, setup=other, resume=True, steps=64)
    with pytest.raises(ckpt.CheckpointError, match="algo: checkpoint 'ppo', now 'sac'"):
        train("sac", ToyEnv(4), "debug", seed=0, out_dir=tmp_path, resume=True,
              progress=False, tensorboard=False)  # fmt: skip
    with pytest.raises(ckpt.CheckpointError, match="already holds a run"):
        _run(tmp_path)  # a fresh run never overwrites one
    with pytest.raises(ckpt.CheckpointError, match="no checkpoint at"):
        _run(tmp_path / "empty", resume=True)


def test_resume_on_other_physics_is_refused_and_names_what_differs(tmp_path) -> None:
    """A run records its env's physics; resumed on a dataset of other physics (another
    version's timestep and contact), it is refused with the fields that differ. A run that
    predates the record resumes with a warning."""
    from types import SimpleNamespace

    from assetgen.core.mujoco_config import PhysicsConfig, physics_for

    def env(physics=None):
        e = ToyEnv(4)
        if physics is not None:
            e.cfg = SimpleNamespace(physics=physics)
        return e

    now = physics_for(0.001)
    v1 = PhysicsConfig(timestep=0.005, substeps=4, contact_timeconst=0.005)
    train("ppo", env(v1), SETUP, seed=0, out_dir=tmp_path / "v1", progress=False,
          tensorboard=False)  # fmt: skip
    with pytest.raises(ckpt.CheckpointError) as e:
        train("ppo", env(now), SETUP, seed=0, out_dir=tmp_path / "v1", resume=True, steps=64,
              progress=False, tensorboard=False)  # fmt: skip
    message = str(e.value)
    assert "physics.timestep: checkpoint 0.005, now 0.0005" in message
    assert "physics.contact_timeconst: checkpoint 0.005, now 0.001" in message
    assert "physics.friction" not in message  # only what differs
    train("ppo", env(), SETUP, seed=0, out_dir=tmp_path / "old", progress=False,
          tensorboard=False)  # fmt: skip
    res = train("ppo", env(now), SETUP, seed=0, out_dir=tmp_path / "old", resume=True,
                steps=64, progress=False, tensorboard=False)  # fmt: skip
    assert res["status"] == "done"


def test_check_compatible_lists_every_difference() -> None:
    with pytest.raises(ckpt.CheckpointError) as e:
        ckpt.check_compatible({"a": 1, "c": {"x": 1}}, {"a": 2, "c": {"x": 1, "y": 2}}, "p")
    assert "a: checkpoint 1, now 2" in str(e.value) and "c.y: checkpoint '<missing>'" in str(
        e.value
    )
    ckpt.check_compatible({"a": [1]}, {"a": [1]}, "p")


def test_a_config_field_added_later_resumes_at_its_default(tmp_path) -> None:
    """A checkpoint written before a config field existed resumes when the run asks for the
    field's default (the behaviour it was trained with), and is refused when it asks for
    another value."""
    _run(tmp_path)
    path = tmp_path / CHECKPOINT
    tensors, doc = ckpt.load(path)
    del doc["run"]["config"]["obs_symlog_scale"]  # as written before the field existed
    ckpt.save(path, tensors, doc)
    other = Setup(PPOConfig(hidden=(8,), horizon=4, minibatch_size=16, epochs=1,
                            obs_symlog_scale=1000.0), 4, 32, 16)  # fmt: skip
    with pytest.raises(ckpt.CheckpointError, match="obs_symlog_scale: checkpoint None, now 1000"):
        _run(tmp_path, setup=other, resume=True, steps=64)
    assert _run(tmp_path, resume=True, steps=64)["status"] == "done"
