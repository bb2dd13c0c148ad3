"""A training run's checkpoint state: what must match between a checkpoint and the run
that resumes it (run_meta, the env's physics among it), writing a run's checkpoint at an
iteration boundary (networks, optimisers, agent extras, RNG states, episode window, env
state), and loading an agent from a checkpoint or run folder (load_agent).
"""

from __future__ import annotations

import json
import random
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

import numpy as np
import torch

from rl import checkpoint as ckpt
from rl.agents import Agent, build_agent, config_from_dict, default_device
from rl.algorithms import ALGOS, config_class
from rl.metrics import EpisodeStats
from rl.presets import AlgoConfig
from rl.vec_env import VecEnv, is_stateful

CHECKPOINT = ckpt.FILE_NAME


def with_new_defaults(run: dict[str, Any]) -> dict[str, Any]:
    """A checkpoint's run record with the config fields added since it was written at their
    defaults (which keep the old behaviour), so that adding a field does not strand runs."""
    algo = run.get("algo", "")
    saved = run.get("config")
    if algo not in ALGOS or not isinstance(saved, dict):
        return run
    cls = config_class(algo)
    if not set(saved) <= {f.name for f in fields(cls)}:  # a removed field: report it as is
        return run
    return {**run, "config": _jsonable(asdict(config_from_dict(run["algo"], saved)))}


def _jsonable(x: Any) -> Any:
    return json.loads(json.dumps(x))


def _rng_state(tensors: dict[str, torch.Tensor]) -> dict[str, Any]:
    tensors["rng/torch"] = torch.get_rng_state()
    if torch.cuda.is_available():
        for i, s in enumerate(torch.cuda.get_rng_state_all()):
            tensors[f"rng/cuda/{i}"] = s
    # numpy's legacy global generator: rl/ does not use it, envs and user code may
    np_state = np.random.get_state(legacy=False)  # noqa: NPY002
    key = np_state["state"]["key"].astype(np.int64)  # uint32: stored as int64
    tensors["rng/numpy_key"] = torch.from_numpy(key)
    return {
        "numpy": {k: v for k, v in np_state.items() if k != "state"}
        | {"pos": np_state["state"]["pos"]},
        "python": random.getstate(),
        "cuda_devices": torch.cuda.device_count() if torch.cuda.is_available() else 0,
    }


def load_rng_state(doc: dict[str, Any], tensors: dict[str, torch.Tensor]) -> None:
    torch.set_rng_state(tensors["rng/torch"])
    if torch.cuda.is_available() and doc["cuda_devices"] == torch.cuda.device_count():
        torch.cuda.set_rng_state_all([tensors[f"rng/cuda/{i}"] for i in range(doc["cuda_devices"])])
    n = doc["numpy"]
    key = tensors["rng/numpy_key"].numpy().astype(np.uint32)
    np_state = {
        "bit_generator": n["bit_generator"],
        "has_gauss": n["has_gauss"],
        "gauss": n["gauss"],
        "state": {"key": key, "pos": n["pos"]},
    }
    np.random.set_state(np_state)  # noqa: NPY002
    v, internal, gauss = doc["python"]
    random.setstate((v, tuple(internal), gauss))


def env_physics(env: Any) -> dict[str, Any] | None:
    """The simulator's physics settings of `env` (through wrappers such as StackObs), or None
    for an env without them (a toy env)."""
    while env is not None:
        physics = getattr(getattr(env, "cfg", None), "physics", None)
        if physics is not None:
            return asdict(physics)
        env = getattr(env, "env", None)
    return None


def run_meta(algo: str, config: AlgoConfig, env: VecEnv, stack: int, seed: int) -> dict[str, Any]:
    """What must match between a checkpoint and the run that resumes it (the env's physics
    among it: a run continued on a dataset of other physics would mix two tasks)."""
    physics = env_physics(env)
    return _jsonable(
        {
            "algo": algo,
            "config": asdict(config),
            "obs_dim": env.obs_dim,
            "act_dim": env.act_dim,
            "stack": stack,
            "num_envs": env.num_envs,
            "seed": seed,
            **({} if physics is None else {"physics": physics}),
        }
    )


def save_run(
    path: Path,
    meta: dict[str, Any],
    agent: Agent,
    counters: dict[str, Any],
    stats: EpisodeStats,
    env: VecEnv,
    obs: np.ndarray,
) -> None:
    """Write the checkpoint of a run at an iteration boundary."""
    tensors: dict[str, torch.Tensor] = {}
    extra_t, extra_v = agent.extra_state()
    doc = {
        "run": meta,
        "counters": counters,
        "agent": ckpt.pack_modules(agent.modules(), "agent", tensors),
        "agent_extra": {"values": extra_v, "tensors": ckpt.pack(extra_t, "extra", tensors)},
        "rng": _rng_state(tensors),
        "episodes": stats.state(),
        "env": None,
        "versions": {"torch": torch.__version__, "numpy": np.__version__},
    }
    if is_stateful(env):
        doc["env"] = {
            "state": ckpt.pack(env.get_state(), "env", tensors),
            "obs": ckpt.pack(np.asarray(obs), "obs", tensors),
        }
    ckpt.save(path, tensors, _jsonable(doc))


def load_agent(
    path: str | Path, device: str | torch.device | None = None
) -> tuple[Agent, dict[str, Any]]:
    """(agent with the checkpoint's weights, its run metadata: algo, config, obs_dim,
    act_dim, stack, num_envs, seed) from a checkpoint file or a run folder."""
    path = Path(path)
    if path.is_dir():
        path = path / CHECKPOINT
    tensors, doc = ckpt.load(path)
    return agent_from(tensors, doc, path, device), doc["run"]


def agent_from(
    tensors: dict[str, torch.Tensor],
    doc: dict[str, Any],
    path: Path,
    device: str | torch.device | None,
) -> Agent:
    """The agent a loaded checkpoint (tensors, JSON document) describes, with its weights."""
    meta = doc["run"]
    if meta["algo"] not in ALGOS:
        raise ckpt.CheckpointError(f"{path}: unknown algorithm {meta['algo']!r}")
    mixed_up = (
        "the checkpoint was edited or mixed up with another run's: use the run's own "
        "checkpoint, or train again"
    )
    try:
        config = config_from_dict(meta["algo"], meta["config"])
    except (TypeError, ValueError) as e:  # a field of another algorithm's config
        raise ckpt.CheckpointError(
            f"{path}: its algorithm {meta['algo']!r} does not match the configuration saved "
            f"with its weights ({e}); {mixed_up}"
        ) from e
    agent = build_agent(
        meta["algo"],
        meta["obs_dim"],
        meta["act_dim"],
        meta["num_envs"],
        config,
        device or default_device(),
        meta["seed"],
    )
    modules = agent.modules()
    if doc.get("policy_only"):  # an exported policy: the networks, no optimisers
        modules = {k: m for k, m in modules.items() if isinstance(m, torch.nn.Module)}
    try:
        ckpt.load_modules(modules, doc["agent"], tensors)
    except ckpt.CheckpointError as e:
        raise ckpt.CheckpointError(
            f"{path}: its weights do not fit a {meta['algo']!r} agent ({e}); {mixed_up}"
        ) from e
    return agent
