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

from sim.engines.registry import DEFAULT_ENGINE, ENGINES, get_engine


def _rss_mb() -> float:
    """Resident memory of this process now, MB (Linux's /proc; 0 elsewhere)."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
    except (OSError, IndexError, ValueError):
        return 0.0
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def bench_build(dataset: str | Path, n: int = 128, engine: str = DEFAULT_ENGINE) -> dict:
    """Build `engine`'s simulator over the first `n` modules of `dataset` (8 envs, the rest
    waiting to rotate in) and report seconds and host MB a module, and for an engine with a
    model on a device, the MB a module of that model. A first build of one module, untimed,
    takes the engine's start-up (on a device, its kernels) out of the figures."""
    from assetgen.core.mujoco_config import physics_for
    from assetgen.dataset.reader import Dataset
    from sim.assets.loading import load_dataset
    from sim.engines.base import EngineOptions
    from sim.task.config import TaskConfig

    spec = get_engine(engine)
    if spec.one_env_per_module:
        rotating = [e.name for e in ENGINES.values() if not e.one_env_per_module]
        raise ValueError(f"engine {engine!r}: bench load builds {' or '.join(rotating)}")
    if n < 2:
        raise ValueError(f"--n {n}: build at least 2 modules (one env, one waiting)")
    ds = Dataset(dataset)
    modules = load_dataset(dataset, ds.ids[:n])
    cfg = TaskConfig(physics=physics_for(min(m.clearance for m in modules)))
    envs = min(8, len(modules) - 1)
    held, waiting = modules[:envs], modules[envs:]
    engine_sim = spec.load("sim")
    options = EngineOptions(nthread=1, shard_size=1)
    engine_sim.create(held[:1], cfg, waiting[:1], options).close()
    gc.collect()
    rss, t0 = _rss_mb(), time.perf_counter()
    sim = engine_sim.create(held, cfg, waiting, options)
    seconds, grown = time.perf_counter() - t0, _rss_mb() - rss
    device = sim.device_model_bytes()
    extra = {} if device is None else {"device_model_mb_per_module": device / 2**20 / len(modules)}
    per = len(modules)
    return {
        "engine": spec.name,
        "modules": per,
        "build_ms_per_module": 1e3 * seconds / per,
        "host_mb_per_module": grown / per,
        **extra,
        "build_min_for_100k_modules": seconds / per * 1e5 / 60,
        "host_gb_for_100k_modules": grown / per * 1e5 / 1024,
    }
