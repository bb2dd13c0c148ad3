"""Shared helpers of the sim tests: one small dataset per session, small env builders.

Kept as plain cached functions (not fixtures) so that every test_sim_* module can import them
without generating the dataset twice.
"""

from __future__ import annotations

import atexit
import functools
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from sim.assets.loading import ModuleAsset, load_dataset
from sim.env import PegInHoleVecEnv
from sim.task.config import TaskConfig

SEED_START = 2048
COUNT = 4


@functools.cache
def sim_dataset() -> Path:
    """Four test-set modules (seeds 2048-2051) with collision pieces, generated once."""
    from assetgen.dataset.generate import generate
    from assetgen.dataset.spec import DatasetSpec
    from assetgen.params.sampler import SamplerConfig

    tmp = Path(tempfile.mkdtemp(prefix="sim-tests-"))
    atexit.register(shutil.rmtree, tmp, ignore_errors=True)
    root = tmp / "ds"
    spec = DatasetSpec("t", SEED_START, COUNT, SamplerConfig(), ("collision", "mjcf"))
    summary = generate(root, spec, workers=1, progress=False)
    assert not summary.failures
    return root


@functools.cache
def modules() -> tuple[ModuleAsset, ...]:
    return tuple(load_dataset(sim_dataset()))


def quiet(**kw) -> TaskConfig:
    """Exact config for tests: no noise, no curriculum, friction fixed unless given."""
    return replace(TaskConfig(noise=False, curriculum_steps=0), **kw)


def debug_train_args() -> list[str]:
    """`assetgen train` on the sim dataset, as small as a run gets (PPO's debug preset, 2 envs,
    256 steps, one thread); a test adds its flags and --out."""
    return ["train", "--algo", "ppo", "--preset", "debug", "--dataset", str(sim_dataset()),
            "--envs", "2", "--steps", "256", "--no-progress", "--threads", "1"]  # fmt: skip


def make_env(n_modules: int = 1, config: TaskConfig | None = None, **kw) -> PegInHoleVecEnv:
    """Envs over the first n_modules modules (up to 4; more repeat them), one thread."""
    mods = [modules()[i % len(modules())] for i in range(n_modules)]
    return PegInHoleVecEnv(mods, config=config or quiet(), nthread=1, **kw)


def above_plate(env: PegInHoleVecEnv, i: int, height: float) -> np.ndarray:
    """An upright pose (4, 4) over the solid plate, in the corner away from the hole,
    `height` above it (bottom face parallel to the plate)."""
    e = env.entrance[i, :3, 3]
    r = np.linalg.norm(env.peg_vertices[i, :, :2], axis=1).max()
    xy = -np.sign(e[:2]) * (0.074 - r)
    assert np.linalg.norm(xy - e[:2]) > 2 * r + 0.005, "peg would overlap the hole"
    pose = np.eye(4)
    pose[:3, 3] = [xy[0], xy[1], height]
    return pose
