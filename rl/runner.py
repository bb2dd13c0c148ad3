"""The training loop: builds the agent, steps the env, logs, checkpoints, resumes.

    train(algo, env, preset, steps=..., minutes=..., seed=..., out_dir=..., resume=..., stack=...)

One iteration = `agent.steps_per_iteration` vector steps (PPO: a rollout of `horizon`),
then `agent.update`. Everything happens at iteration boundaries: a metrics row
(out_dir/metrics.csv, TensorBoard in out_dir/tb when installed), and every
`checkpoint_steps` env steps plus at the end a checkpoint (out_dir/checkpoint.safetensors,
written atomically; see rl/checkpoint.py). On an env with get_state/set_state, also one after
the first iteration that ends `checkpoint_minutes` (5) after the last, so that a stopped
machine costs minutes of training, not a whole checkpoint interval.

Exact resume (an interrupted run resumed with --resume ends with the same weights as an
uninterrupted one, on the same device and thread count) needs one of:
  * an env with get_state/set_state (rl/vec_env.py): exact from any checkpoint;
  * otherwise an env whose trajectories depend only on reset(seed) and the actions: the
    runner re-seeds it, reset(seed=env_seed(seed, iteration)), right after every periodic
    checkpoint (ending all episodes there; the cut episodes are bootstrapped like
    truncations), and does the same on resume. Resuming from a periodic checkpoint (the
    one a crash or kill leaves) is then exact; resuming from one written when a run
    stopped on --steps/--minutes elsewhere is correct but not bit-identical.
Counters, RNG states (torch CPU and CUDA, numpy's global, Python's), optimiser states, the
SAC replay buffer, Dreamer's sequence replay (up to its checkpoint_replay_mb) and per-env
recurrent state, and the episode-statistics window are all saved. A recurrent agent's
`reset(mask)` is called after every env.reset (see Agent).
A NaN/inf loss or action stops training with a message; the last good checkpoint is kept
(a checkpoint is never written from non-finite weights).
"""

from __future__ import annotations

import csv
import json
import math
import os
import random
import time
from collections import deque
from collections.abc import Callable
from dataclasses import asdict, fields, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import torch
from rich.console import Console

from rl import checkpoint as ckpt
from rl.dreamer.agent import Dreamer
from rl.dreamer.config import DreamerConfig
from rl.host_view import HostView, host
from rl.nets import NonFiniteLossError
from rl.ppo import PPO, PPOConfig
from rl.presets import AlgoConfig, Setup, get_setup
from rl.random_agent import RandomAgent, RandomConfig
from rl.sac import SAC, SACConfig
from rl.stack import StackObs
from rl.vec_env import VecEnv, is_stateful

ALGOS: dict[str, type] = {
    "ppo": PPOConfig,
    "sac": SACConfig,
    "dreamer": DreamerConfig,
    "random": RandomConfig,
}
"""Algorithm name -> its config class."""
CHECKPOINT = ckpt.FILE_NAME
BASE_COLUMNS = (
    "iteration",
    "env_steps",
    "wall_s",
    "steps_per_s",
    "episodes",
    "success_rate",
    "return_mean",
    "length_mean",
    "time_to_success_median",
)
"""Columns every metrics.csv has. wall_s: wall-clock seconds of training since the run
began (logs, probes and checkpoints included; a resumed run goes on from its checkpoint's);
steps_per_s: the env steps of the row's iteration over its own time."""

PROBE_COLUMNS = ("probe_success_rate", "probe_time_to_success_median", "probe_truncation_rate")
"""Columns of the frozen-policy probe (`train --probe-steps`), empty in other rows."""

console = Console(stderr=True, highlight=False)


class Agent(Protocol):
    """What the runner needs of an algorithm (PPO, SAC, Dreamer, RandomAgent).

    A recurrent agent (Dreamer) also has `reset(mask (N,) bool)`: new episodes start where
    mask is True. The runner calls it after every env.reset, evaluation/protocol.py after each
    step; stateless agents need not define it (see `reset_hook`).
    """

    steps_per_iteration: int
    log_keys: tuple[str, ...]

    def act(self, obs: np.ndarray) -> np.ndarray: ...
    def policy(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray: ...
    def process_step(
        self,
        next_obs: np.ndarray,
        reward: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        info: dict[str, Any],
    ) -> None: ...
    def update(self, last_obs: np.ndarray) -> dict[str, float]: ...
    def modules(self) -> dict[str, torch.nn.Module | torch.optim.Optimizer]: ...
    def extra_state(self) -> tuple[dict[str, torch.Tensor], dict[str, Any]]: ...
    def load_extra_state(
        self, tensors: dict[str, torch.Tensor], values: dict[str, Any]
    ) -> None: ...


def build_agent(
    algo: str,
    obs_dim: int,
    act_dim: int,
    num_envs: int,
    config: AlgoConfig,
    device: str | torch.device,
    seed: int = 0,
) -> Agent:
    """A fresh agent of `algo` ("ppo", "sac", "dreamer", "random")."""
    if algo == "ppo":
        return PPO(obs_dim, act_dim, num_envs, config, device)  # type: ignore[arg-type]
    if algo == "sac":
        return SAC(obs_dim, act_dim, num_envs, config, device)  # type: ignore[arg-type]
    if algo == "dreamer":
        return Dreamer(obs_dim, act_dim, num_envs, config, device, seed)  # type: ignore[arg-type]
    if algo == "random":
        return RandomAgent(act_dim, seed, config)  # type: ignore[arg-type]
    raise ValueError(f"unknown algorithm {algo!r}; valid algorithms: {sorted(ALGOS)}")


def reset_hook(agent: Any) -> Callable[[np.ndarray], None] | None:
    """The agent's `reset(mask)` when it keeps a recurrent state, else None."""
    fn = getattr(agent, "reset", None)
    return fn if callable(fn) else None


def acting_state_hooks(agent: Any) -> tuple[Callable[[], Any], Callable[[Any], None]] | None:
    """(acting_state, load_acting_state) of an agent with a recurrent state, else None: what
    an evaluation's snapshot saves of the policy (evaluation/protocol.py)."""
    get, put = getattr(agent, "acting_state", None), getattr(agent, "load_acting_state", None)
    return (get, put) if callable(get) and callable(put) else None


def config_from_dict(algo: str, d: dict[str, Any]) -> AlgoConfig:
    """Rebuild a config dataclass from its JSON form (lists back to tuples)."""
    cls = ALGOS[algo]
    tuples = {f.name for f in fields(cls) if isinstance(f.default, tuple)}
    return cls(**{k: tuple(v) if k in tuples else v for k, v in d.items()})


def _with_new_defaults(run: dict[str, Any]) -> dict[str, Any]:
    """A checkpoint's run record with the config fields added since it was written at their
    defaults (which keep the old behaviour), so that adding a field does not strand runs."""
    cls = ALGOS.get(run.get("algo", ""))
    saved = run.get("config")
    if cls is None or not isinstance(saved, dict):
        return run
    if not set(saved) <= {f.name for f in fields(cls)}:  # a removed field: report it as is
        return run
    return {**run, "config": _jsonable(asdict(config_from_dict(run["algo"], saved)))}


def env_seed(seed: int, iteration: int) -> int:
    """The env seed used at `iteration` (0: the start) of a run seeded `seed`."""
    return int(np.random.SeedSequence([seed, iteration]).generate_state(1)[0])


def default_device() -> str:
    """CUDA when present, else CPU."""
    return "cuda" if torch.cuda.is_available() else "cpu"


def _jsonable(x: Any) -> Any:
    return json.loads(json.dumps(x))


TENSOR_ALGOS = frozenset({"ppo"})
"""Agents that step an env on torch tensors (`tensor_io`) directly; others see it through
rl/host_view.py's numpy view."""


def _all_finite(actions: Any) -> bool:
    if isinstance(actions, torch.Tensor):
        return bool(torch.isfinite(actions).all())
    return bool(np.isfinite(actions).all())


# ----------------------------------------------------------------------------- statistics


class EpisodeStats:
    """The last `size` finished episodes: (return, length, success, time to success)."""

    def __init__(self, size: int) -> None:
        self.window: deque[tuple[float, int, bool, float]] = deque(maxlen=size)
        self.total = 0

    def add(self, done: Any, info: dict[str, Any]) -> None:
        """Record the episodes that ended where done (N,) is True (arrays or tensors)."""
        idx = np.flatnonzero(host(done))
        if not len(idx):
            return
        keys = ("episode_return", "episode_length", "success", "time_to_success")
        r, n, s, t = (host(info[k])[idx] for k in keys)
        for row in zip(r.tolist(), n.tolist(), s.tolist(), t.tolist(), strict=True):
            self.window.append((float(row[0]), int(row[1]), bool(row[2]), float(row[3])))
        self.total += len(idx)

    def summary(self) -> dict[str, float]:
        """Means over the window (NaN when empty)."""
        if not self.window:
            return {
                k: math.nan
                for k in ("success_rate", "return_mean", "length_mean", "time_to_success_median")
            }
        r, n, s, t = (np.array(c, dtype=float) for c in zip(*self.window, strict=True))
        t = t[s > 0]
        return {
            "success_rate": float(s.mean()),
            "return_mean": float(r.mean()),
            "length_mean": float(n.mean()),
            "time_to_success_median": float(np.median(t)) if len(t) else math.nan,
        }

    def state(self) -> dict[str, Any]:
        return {"window": [list(w) for w in self.window], "total": self.total}

    def load(self, state: dict[str, Any]) -> None:
        self.window.extend(tuple(w) for w in state["window"])
        self.total = state["total"]


class MetricsLog:
    """metrics.csv (fixed columns) and, when tensorboard is installed, TensorBoard scalars."""

    def __init__(
        self,
        out_dir: Path,
        columns: tuple[str, ...],
        resume_iteration: int | None,
        tensorboard: bool,
    ) -> None:
        self.path = out_dir / "metrics.csv"
        self.columns = columns
        rows: list[dict[str, str]] = []
        if resume_iteration is not None and self.path.exists():
            # drop rows logged after the checkpoint: the resumed run logs them again
            with open(self.path, newline="") as f:
                rows = [r for r in csv.DictReader(f) if int(r["iteration"]) <= resume_iteration]
        with open(self.path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=columns)
            w.writeheader()
            w.writerows(rows)
        self.tb = None
        if tensorboard:
            try:
                from torch.utils.tensorboard import SummaryWriter
            except ImportError:
                console.print("tensorboard is not installed: logging to metrics.csv only")
            else:
                self.tb = SummaryWriter(str(out_dir / "tb"), purge_step=resume_iteration)

    def write(self, row: dict[str, float]) -> None:
        with open(self.path, "a", newline="") as f:
            csv.DictWriter(f, fieldnames=self.columns).writerow(
                {k: row.get(k, "") for k in self.columns}
            )
        if self.tb is not None:
            step = int(row["env_steps"])
            for k, v in row.items():
                if k not in ("iteration", "env_steps") and not math.isnan(v):
                    self.tb.add_scalar(k, v, step)

    def close(self) -> None:
        if self.tb is not None:
            self.tb.close()


# ----------------------------------------------------------------------------- checkpoints


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


def _load_rng_state(doc: dict[str, Any], tensors: dict[str, torch.Tensor]) -> None:
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


def _finite(agent: Agent) -> bool:
    return all(
        torch.isfinite(p).all()
        for m in agent.modules().values()
        if isinstance(m, torch.nn.Module)
        for p in m.state_dict().values()
        if p.is_floating_point()
    )


def env_physics(env: Any) -> dict[str, Any] | None:
    """The simulator's physics settings of `env` (through wrappers such as StackObs), or None
    for an env without them (a toy env)."""
    while env is not None:
        physics = getattr(getattr(env, "cfg", None), "physics", None)
        if physics is not None:
            return asdict(physics)
        env = getattr(env, "env", None)
    return None


def env_curriculum(env: Any) -> Any | None:
    """The success-gated curriculum of `env` (through wrappers; sim/task/curriculum.py), whose
    level the metrics log as curriculum_scale, or None."""
    while env is not None:
        found = getattr(env, "curriculum", None)
        if found is not None:
            return found
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
    return _agent_from(tensors, doc, path, device), doc["run"]


def _agent_from(
    tensors: dict[str, torch.Tensor],
    doc: dict[str, Any],
    path: Path,
    device: str | torch.device | None,
) -> Agent:
    """The agent a loaded checkpoint (tensors, JSON document) describes, with its weights."""
    meta = doc["run"]
    if meta["algo"] not in ALGOS:
        raise ckpt.CheckpointError(f"{path}: unknown algorithm {meta['algo']!r}")
    agent = build_agent(
        meta["algo"],
        meta["obs_dim"],
        meta["act_dim"],
        meta["num_envs"],
        config_from_dict(meta["algo"], meta["config"]),
        device or default_device(),
        meta["seed"],
    )
    modules = agent.modules()
    if doc.get("policy_only"):  # an exported policy: the networks, no optimisers
        modules = {k: m for k, m in modules.items() if isinstance(m, torch.nn.Module)}
    ckpt.load_modules(modules, doc["agent"], tensors)
    return agent


RUN_FILES = ("config.json", "metrics.csv")
"""Copied by `export_policy` with the weights: what `assetgen report` reads of a run."""


def export_policy(run: str | Path, out_dir: str | Path) -> dict[str, Any]:
    """Write a run's networks, without optimiser states, replay buffer or RNG states, to
    out_dir/checkpoint.safetensors (what `load_agent` and `assetgen eval --checkpoint` read;
    it cannot be resumed), with the run's config.json, metrics.csv and evaluation files.
    Returns {"files": {name: bytes}}. The folder is filled under a temporary name and then
    renamed, so an interrupted export leaves nothing half-written."""
    import shutil

    run = Path(run)
    src = run / CHECKPOINT if run.is_dir() else run
    tensors, doc = ckpt.load(src)
    if doc.get("policy_only"):
        raise ckpt.CheckpointError(f"{src} is already an exported policy")
    agent = _agent_from(tensors, doc, src, "cpu")
    keep: dict[str, torch.Tensor] = {}
    nets = {k: m for k, m in agent.modules().items() if isinstance(m, torch.nn.Module)}
    out_doc = {
        "run": doc["run"],
        "counters": doc["counters"],
        "agent": ckpt.pack_modules(nets, "agent", keep),
        "policy_only": True,
        "versions": doc.get("versions", {}),
    }
    out_dir = Path(out_dir)
    if out_dir.exists():
        raise ckpt.CheckpointError(f"{out_dir} exists: choose a new folder for the export")
    tmp = out_dir.with_name(f".{out_dir.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    ckpt.save(tmp / CHECKPOINT, keep, out_doc)
    folder = src.parent
    for f in [*(folder / n for n in RUN_FILES), *sorted(folder.glob("eval_*.json"))]:
        if f.is_file():
            shutil.copy2(f, tmp / f.name)
    os.replace(tmp, out_dir)
    return {"files": {f.name: f.stat().st_size for f in sorted(out_dir.iterdir())}}


# ----------------------------------------------------------------------------- train

CHECKPOINT_MINUTES = 5.0
"""Wall-clock minutes between checkpoints on envs with get_state (besides checkpoint_steps)."""


def train(
    algo: str,
    env: VecEnv,
    preset: str | Setup = "cpu",
    *,
    steps: int | None = None,
    minutes: float | None = None,
    seed: int = 0,
    out_dir: str | Path,
    resume: bool = False,
    stack: int = 1,
    device: str | torch.device | None = None,
    progress: bool = True,
    tensorboard: bool = True,
    env_options: dict[str, Any] | None = None,
    teacher: Callable[[np.ndarray], np.ndarray] | None = None,
    demos: str | None = None,
    overrides: dict[str, Any] | None = None,
    probe: Callable[[Any], dict[str, float]] | None = None,
    probe_steps: int | None = None,
    checkpoint_minutes: float | None = CHECKPOINT_MINUTES,
) -> dict[str, Any]:
    """Train `algo` ("ppo", "sac", "dreamer", "random") on `env` (the rl/vec_env.py contract).

    preset: a name from rl/presets.py or a Setup. steps: total env steps (summed over envs,
    counted from the run's start, rounded up to whole iterations); minutes: total wall-clock
    budget, also counted from the run's start (a resumed run spends what its checkpoint had
    left: a run cut short and resumed with the same command ends at the same budget);
    neither: the preset's total_steps. stack > 1 wraps the env in
    StackObs(env, stack). resume continues the run saved in out_dir (same settings
    required). env_options: how `env` was made (e.g. its curriculum length), recorded with
    the run and checked on resume. teacher: a policy of the env's unstacked observations
    (e.g. the scripted expert) that an agent with `set_teacher` (SAC) learns from, named
    `demos` in the run's metadata. overrides: config fields replaced in the preset's config
    (ablations: {"bc_weight": 0.0}). probe: agent -> {"probe_success_rate", ...}, run
    every `probe_steps` env steps (rounded to iterations) and logged with that row: the
    frozen deterministic policy on fixed episodes (evaluation/probe.py), because the training
    columns describe a policy that changes at every gradient step. checkpoint_minutes: on an
    env with get_state/set_state, a checkpoint at the end of the first iteration this long
    after the last one as well (None: every checkpoint_steps only; an env without
    get_state is re-seeded at each checkpoint, so there its timing must not depend on the
    clock). Returns {"status":
    "done" | "nan" | "interrupted", "iterations", "env_steps", "seconds", "episodes",
    "checkpoint", "metrics" (the last row)}.
    """
    if checkpoint_minutes is not None and checkpoint_minutes <= 0:
        raise ValueError(f"checkpoint_minutes = {checkpoint_minutes}: give a positive number")
    setup = get_setup(preset, algo) if isinstance(preset, str) else preset
    config = replace(setup.config, **(overrides or {}))
    base_dim = env.obs_dim
    if getattr(env, "tensor_io", False) and not (stack == 1 and algo in TENSOR_ALGOS):
        env = HostView(env)  # the agent or the stack takes numpy arrays
    if stack > 1:
        env = StackObs(env, stack)
    elif stack < 1:
        raise ValueError(f"stack = {stack}: stack at least 1 observation (1 = no stacking)")
    if steps is None and minutes is None:
        steps = setup.total_steps
    device = torch.device(device or default_device())
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / CHECKPOINT
    meta = run_meta(algo, config, env, stack, seed) | {
        "env_options": env_options or {},
        "demos": demos if teacher is not None else None,
        "overrides": overrides or {},
    }
    if probe is not None:  # it draws from the global RNGs: a resume must probe alike
        meta["probe_steps"] = probe_steps
    n = env.num_envs

    # seeding before the networks are built makes their initialisation reproducible
    torch.manual_seed(seed)
    np.random.seed(seed)  # noqa: NPY002 (for envs and user code that use the global one)
    random.seed(seed)
    agent = build_agent(algo, env.obs_dim, env.act_dim, n, config, device, seed)
    if teacher is not None:
        if not hasattr(agent, "set_teacher"):
            raise ValueError(
                f"demonstrations (a teacher) are supported by sac and dreamer, not by {algo}"
            )
        # stacked observations hold the newest first: the teacher sees that one
        agent.set_teacher(lambda o: teacher(np.asarray(o)[:, :base_dim]))
    stats = EpisodeStats(max(100, n))
    iteration = env_steps = 0
    wall = 0.0
    stateful = is_stateful(env)

    if resume:
        tensors, doc = ckpt.load(path)
        if doc.get("policy_only"):
            raise ckpt.CheckpointError(
                f"{path} is an exported policy (`assetgen export`): without its optimiser "
                "states and replay it evaluates but cannot resume; resume the original run"
            )
        wanted = meta
        if "physics" in meta and "physics" not in doc["run"]:
            # written before runs recorded their physics: it cannot be checked
            console.print(
                f"[yellow]{path} does not record its physics; resuming it on this dataset's "
                f"(timestep {meta['physics']['timestep']} s)[/]"
            )
            wanted = {k: v for k, v in meta.items() if k != "physics"}
        ckpt.check_compatible(_with_new_defaults(doc["run"]), wanted, path)
        ckpt.load_modules(agent.modules(), doc["agent"], tensors)
        extra = doc["agent_extra"]
        agent.load_extra_state(ckpt.unpack(extra["tensors"], tensors), extra["values"])
        _load_rng_state(doc["rng"], tensors)
        stats.load(doc["episodes"])
        c = doc["counters"]
        iteration, env_steps, wall = c["iteration"], c["env_steps"], c["wall_s"]
        if stateful:
            if doc["env"] is None:
                raise ckpt.CheckpointError(f"{path} holds no env state, but this env has one")
            env.set_state(ckpt.unpack(doc["env"]["state"], tensors))  # type: ignore[attr-defined]
            obs = np.asarray(ckpt.unpack(doc["env"]["obs"], tensors))
        else:
            obs = env.reset(seed=env_seed(seed, iteration))
            _episodes_restart(agent, n)
        console.print(f"resumed {path} at iteration {iteration}, {env_steps:,} env steps")
    else:
        if path.exists():
            raise ckpt.CheckpointError(
                f"{out_dir} already holds a run ({CHECKPOINT}): pass --resume to continue it, "
                "or choose another --out folder"
            )
        obs = env.reset(seed=env_seed(seed, 0))
        _episodes_restart(agent, n)
    (out_dir / "config.json").write_text(json.dumps(meta | {"device": str(device)}, indent=2))

    spi = agent.steps_per_iteration
    per_iter = n * spi
    ckpt_every = max(1, math.ceil(setup.checkpoint_steps / per_iter))
    by_clock = 60.0 * checkpoint_minutes if stateful and checkpoint_minutes else math.inf
    if probe is not None and (probe_steps is None or probe_steps < 1):
        raise ValueError(f"probe_steps = {probe_steps}: give a positive number of env steps")
    probe_every = math.ceil(probe_steps / per_iter) if probe is not None and probe_steps else 0
    curriculum = env_curriculum(env)
    columns = BASE_COLUMNS + tuple(agent.log_keys) + (PROBE_COLUMNS if probe else ())
    columns += ("curriculum_scale",) if curriculum is not None else ()
    log = MetricsLog(out_dir, columns, iteration if resume else None, tensorboard)
    bar = _Progress(progress, steps, env_steps)
    t_start = time.perf_counter()
    wall_before = wall  # spent before this call (a resumed run's checkpoint)
    first_iteration = iteration
    status, row = "done", {}
    last_saved = iteration if resume else None
    budget_spent = False
    t_saved = time.perf_counter()
    try:
        while True:
            if steps is not None and env_steps >= steps:
                break
            spent = wall_before + time.perf_counter() - t_start
            if minutes is not None and spent >= 60.0 * minutes:
                # the checkpoint records the budget as spent, so that the same command with
                # --resume stops at once instead of taking one more iteration
                budget_spent = iteration > first_iteration
                wall = spent if budget_spent else wall
                break
            t_iter = time.perf_counter()
            for _ in range(spi):
                actions = agent.act(obs)
                if not _all_finite(actions):
                    raise NonFiniteLossError(
                        "the policy produced NaN/inf actions: its weights or the observations "
                        "are not finite"
                    )
                next_obs, reward, terminated, truncated, info = env.step(actions)
                agent.process_step(next_obs, reward, terminated, truncated, info)
                stats.add(terminated | truncated, info)
                obs = next_obs
            losses = agent.update(obs)
            if not _finite(agent):
                raise NonFiniteLossError("the weights became NaN/inf in the last update")
            iteration += 1
            env_steps += per_iter
            now = time.perf_counter()
            dt = now - t_iter
            wall = wall_before + now - t_start  # logs, probes and checkpoints included
            row = {
                "iteration": iteration,
                "env_steps": env_steps,
                "wall_s": wall,
                "steps_per_s": per_iter / dt,
                "episodes": stats.total,
                **stats.summary(),
                **losses,
                **({} if curriculum is None else {"curriculum_scale": curriculum.level}),
            }
            if probe_every and iteration % probe_every == 0:
                # before the checkpoint: its RNG state is then the one a resume continues from
                row |= probe(agent)
            log.write(row)
            bar.update(per_iter, row)
            if iteration % ckpt_every == 0 or time.perf_counter() - t_saved >= by_clock:
                _save(path, meta, agent, iteration, env_steps, wall, stats, env, obs)
                last_saved, t_saved = iteration, time.perf_counter()
                if not stateful:  # the re-seed a resumed run repeats (see module doc)
                    obs = env.reset(seed=env_seed(seed, iteration))
                    _episodes_restart(agent, n)
        if last_saved != iteration or budget_spent:
            _save(path, meta, agent, iteration, env_steps, wall, stats, env, obs)
    except NonFiniteLossError as e:
        status = "nan"
        kept = (
            f"the checkpoint of iteration {last_saved} is kept"
            if last_saved is not None
            else "no checkpoint had been written yet"
        )
        console.print(f"[bold red]training stopped at iteration {iteration + 1}:[/] {e}; {kept}")
    except KeyboardInterrupt:
        status = "interrupted"
        console.print(
            f"interrupted at iteration {iteration}; the checkpoint of iteration {last_saved} "
            "is kept: continue with --resume"
        )
    finally:
        bar.close()
        log.close()
    return {
        "status": status,
        "iterations": iteration,
        "env_steps": env_steps,
        "seconds": wall,
        "episodes": stats.total,
        "checkpoint": str(path) if path.exists() else None,
        "metrics": row,
    }


def _episodes_restart(agent: Agent, n: int) -> None:
    """Tell a recurrent agent that every env just started a new episode (env.reset)."""
    hook = reset_hook(agent)
    if hook is not None:
        hook(np.ones(n, dtype=bool))


def _save(
    path: Path,
    meta: dict[str, Any],
    agent: Agent,
    iteration: int,
    env_steps: int,
    wall: float,
    stats: EpisodeStats,
    env: VecEnv,
    obs: np.ndarray,
) -> None:
    counters = {"iteration": iteration, "env_steps": env_steps, "wall_s": wall}
    save_run(path, meta, agent, counters, stats, env, obs)


class _Progress:
    """A rich progress bar over env steps (or elapsed time only when there is no total)."""

    def __init__(self, enabled: bool, total: int | None, done: int) -> None:
        self.p = None
        if not enabled:
            return
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.p = Progress(
            TextColumn("[bold]train"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[info]}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=console,
        )
        self.p.start()
        self.task = self.p.add_task("train", total=total, completed=done, info="")

    def update(self, advance: int, row: dict[str, float]) -> None:
        if self.p is None:
            return
        info = (
            f"{row['steps_per_s']:,.0f} steps/s  success {row['success_rate']:.1%}  "
            f"return {row['return_mean']:.3f}"
        )
        self.p.update(self.task, advance=advance, info=info)

    def close(self) -> None:
        if self.p is not None:
            self.p.stop()
