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
recurrent state, and the episode-statistics window are all saved (rl/run_state.py). A
recurrent agent's `reset(mask)` is called after every env.reset (see rl/agents.py's Agent).
A NaN/inf loss or action stops training with a message; the last good checkpoint is kept
(a checkpoint is never written from non-finite weights).

The pieces around the loop live beside it: rl/agents.py (the algorithms, building an
agent), rl/run_state.py (checkpoint state: save, resume, load_agent), rl/metrics.py
(metrics.csv columns, episode statistics, the CSV/TensorBoard writer), rl/progress.py (the
console and progress bar) and rl/export.py (export_policy).
"""

from __future__ import annotations

import json
import math
import random
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import torch

from rl import checkpoint as ckpt
from rl.agents import Agent, build_agent, default_device, reset_hook
from rl.host_view import HostView
from rl.metrics import BASE_COLUMNS, PROBE_COLUMNS, EpisodeStats, MetricsLog
from rl.nets import NonFiniteLossError
from rl.presets import Setup, get_setup
from rl.progress import ProgressBar, console
from rl.run_state import CHECKPOINT, load_rng_state, run_meta, save_run, with_new_defaults
from rl.stack import StackObs
from rl.vec_env import VecEnv, is_stateful


def env_seed(seed: int, iteration: int) -> int:
    """The env seed used at `iteration` (0: the start) of a run seeded `seed`."""
    return int(np.random.SeedSequence([seed, iteration]).generate_state(1)[0])


TENSOR_ALGOS = frozenset({"ppo"})
"""Agents that step an env on torch tensors (`tensor_io`) directly; others see it through
rl/host_view.py's numpy view."""


def _all_finite(actions: Any) -> bool:
    if isinstance(actions, torch.Tensor):
        return bool(torch.isfinite(actions).all())
    return bool(np.isfinite(actions).all())


def _finite(agent: Agent) -> bool:
    return all(
        torch.isfinite(p).all()
        for m in agent.modules().values()
        if isinstance(m, torch.nn.Module)
        for p in m.state_dict().values()
        if p.is_floating_point()
    )


def env_part(env: Any, name: str) -> Any | None:
    """The attribute `name` of `env` or of an env it wraps, or None."""
    while env is not None:
        found = getattr(env, name, None)
        if found is not None:
            return found
        env = getattr(env, "env", None)
    return None


def env_curriculum(env: Any) -> Any | None:
    """The success-gated curriculum of `env` (through wrappers; sim/task/curriculum.py), whose
    level the metrics log as curriculum_scale, or None."""
    return env_part(env, "curriculum")


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
        ckpt.check_compatible(with_new_defaults(doc["run"]), wanted, path)
        ckpt.load_modules(agent.modules(), doc["agent"], tensors)
        extra = doc["agent_extra"]
        agent.load_extra_state(ckpt.unpack(extra["tensors"], tensors), extra["values"])
        load_rng_state(doc["rng"], tensors)
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
    # the share of inside starts, where a take-off gate can end them (sim/task/takeoff_gate.py)
    inside = env_part(env, "inside_share") if env_part(env, "inside_gate") else None
    columns = BASE_COLUMNS + tuple(agent.log_keys) + (PROBE_COLUMNS if probe else ())
    columns += ("curriculum_scale",) if curriculum is not None else ()
    columns += ("inside_share",) if inside is not None else ()
    log = MetricsLog(out_dir, columns, iteration if resume else None, tensorboard)
    bar = ProgressBar(progress, steps, env_steps)
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
                **({} if inside is None else {"inside_share": inside()}),
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
        from rich.markup import escape

        kept = (
            f"the checkpoint of iteration {last_saved} in {escape(str(out_dir))} is kept; "
            "continue with the same command and --resume"
            if last_saved is not None
            else "no checkpoint had been written yet; run the same command again to start over"
        )
        console.print(
            f"[bold red]error:[/] interrupted (Ctrl-C) at iteration {iteration}: {kept}",
            soft_wrap=True,
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
