"""What an engine costs a module of its dataset at construction: time and host memory, and
for MuJoCo Warp the model it sends to the device.

Both engines build every module's model when they are made, the modules an env does not
hold yet among them (they rotate in between episodes): the CPU simulator one MjModel a
module, MuJoCo Warp one model holding every module's meshes. So these figures times the
dataset's size say how large a dataset an engine can take, and how long it takes to start.

    assetgen bench load --dataset train --n 128 --sim mujoco|mujoco-warp [--allow-cpu]
"""

from __future__ import annotations

import gc
import os
import time
from pathlib import Path


def _rss_mb() -> float:
    """Resident memory of this process now, MB (Linux's /proc; 0 elsewhere)."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
    except (OSError, IndexError, ValueError):
        return 0.0
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def bench_build(dataset: str | Path, n: int = 128, engine: str = "mujoco") -> dict:
    """Build `engine`'s simulator over the first `n` modules of `dataset` (8 envs, the rest
    waiting to rotate in) and report seconds and host MB a module; for mujoco-warp also the
    MB a module of the model on the device (its buffer), on Warp's default device."""
    from assetgen.core.mujoco_config import physics_for
    from assetgen.dataset.reader import Dataset
    from sim.assets.loading import load_dataset
    from sim.engines.mujoco.batch import BatchSim
    from sim.task.config import TaskConfig

    if n < 2:
        raise ValueError(f"--n {n}: build at least 2 modules (one env, one waiting)")
    ds = Dataset(dataset)
    modules = load_dataset(dataset, ds.ids[:n])
    cfg = TaskConfig(physics=physics_for(min(m.clearance for m in modules)))
    envs = min(8, len(modules) - 1)
    held, waiting = modules[:envs], modules[envs:]
    if engine == "mujoco-warp":
        from sim.engines.warp.batch import WarpBatchSim

        WarpBatchSim(held[:1], cfg, waiting[:1])  # Warp's start and kernels, not the modules
        gc.collect()
        rss, t0 = _rss_mb(), time.perf_counter()
        sim = WarpBatchSim(held, cfg, waiting)
        seconds, grown = time.perf_counter() - t0, _rss_mb() - rss
        extra = {"device_model_mb_per_module": sim.mjm.nbuffer / 2**20 / len(modules)}
    elif engine == "mujoco":
        gc.collect()
        rss, t0 = _rss_mb(), time.perf_counter()
        sim = BatchSim(held, cfg, nthread=1, shard_size=1, spare_assets=waiting)
        seconds, grown = time.perf_counter() - t0, _rss_mb() - rss
        extra = {}
    else:
        raise ValueError(f"engine {engine!r}: bench load builds mujoco or mujoco-warp")
    per = len(modules)
    return {
        "engine": engine,
        "modules": per,
        "build_ms_per_module": 1e3 * seconds / per,
        "host_mb_per_module": grown / per,
        **extra,
        "build_min_for_100k_modules": seconds / per * 1e5 / 60,
        "host_gb_for_100k_modules": grown / per * 1e5 / 1024,
    }
