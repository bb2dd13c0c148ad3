"""The evaluation protocol over the vector-env contract: every env plays exactly
`episodes_per_env` episodes back to back (with one env per module, the paper's "10 attempts
per module"); success rate and time to success.

Episodes are counted per env, so envs with short episodes do not weigh more: an env that has
finished its quota keeps stepping (its further episodes are ignored) until all have.

This one loop serves every agent: the scripted expert, the random agent and trained
checkpoints (`assetgen eval` builds the env and the policy, then calls `evaluate`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from rl.vec_env import VecEnv

if TYPE_CHECKING:
    from evaluation.snapshots import EvalSnapshots

Policy = Callable[[np.ndarray], np.ndarray]
"""obs (N, obs_dim) float32 -> actions (N, act_dim) in [-1, 1]."""

PolicyState = tuple[Callable[[], dict[str, Any]], Callable[[dict[str, Any]], None]]
"""(get, set) of a recurrent policy's per-env state, for snapshots."""


class Recorder(Protocol):
    """Keeps episodes as they are played (evaluation/recording.py writes them for the preview)."""

    def begin(self, env: Any) -> None:
        """Called after env.reset: every env starts an episode."""

    def step(
        self,
        env: Any,
        reward: np.ndarray,
        done: np.ndarray,
        info: dict[str, Any],
        live: np.ndarray,
        attempts: np.ndarray,
    ) -> None:
        """Called after every env.step: `done` (N,) ended episodes (their envs have already
        started the next), `live` (N,) envs whose episodes still count, `attempts` (N,)
        episodes each env had finished before this step."""


def evaluate(
    policy_fn: Policy,
    env: VecEnv,
    episodes_per_env: int,
    *,
    seed: int | None = None,
    max_steps: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    reset: Callable[[np.ndarray], None] | None = None,
    labels: list[str] | None = None,
    recorder: Recorder | None = None,
    live: Callable[[np.ndarray | None], None] | None = None,
    snapshots: EvalSnapshots | None = None,
    policy_state: PolicyState | None = None,
) -> dict[str, Any]:
    """Run `policy_fn` until every env has finished `episodes_per_env` episodes.

    `seed` is passed to env.reset. `max_steps` (vector steps) guards against envs whose
    episodes never end: RuntimeError when exceeded. `progress(done, total)` is called as
    episodes finish. `reset(mask)` (a recurrent policy's, e.g. Dreamer.reset) is called with
    an all-True mask after env.reset and with terminated | truncated after every step, so
    the policy's state is carried through each episode and restarted at its end. `labels`
    (N,) names what each env plays (its module) for `per_module`; `recorder` sees every step
    (`--record`). `live(mask)` (the env's set_live, when it has one) is told before every
    step which envs still have episodes to play, so the simulator may skip the others.
    `snapshots` (evaluation/snapshots.py) saves the evaluation as it goes and resumes a saved
    one, with the same results as an uncut run: for an env with get_state/set_state, no
    `recorder`, and a policy whose state is torch's RNG, plus, for one with a `reset` hook,
    what `policy_state` = (get, set) saves and restores (Dreamer's acting state).
    Returns a JSON-ready dict:
        episodes                   N * episodes_per_env
        success_rate               successes / episodes
        successes                  count
        time_to_success_s          list of seconds, one per success (episode order)
        median_time_to_success_s   NaN when there is no success
        mean_return, std_return    over episodes
        mean_length                steps per episode
        truncation_rate            fraction of episodes ended by truncation
        failure_rate, unstable     episodes ended by the task's failure condition (fraction),
                                   by unstable physics (count); when info reports them
        per_env_success_rate       list (N,): success rate of each env
        per_module                 {label: success rate}, with `labels`
        env_steps, seconds         vector steps × envs (skipped envs included), wall time
    """
    if episodes_per_env < 1:
        raise ValueError(f"episodes_per_env = {episodes_per_env}: need at least 1")
    n = env.num_envs
    total = n * episodes_per_env
    t0 = time.perf_counter()
    counts = np.zeros(n, dtype=np.int64)
    wins = np.zeros(n, dtype=np.int64)
    returns: list[float] = []
    lengths: list[int] = []
    tts: list[float] = []
    truncations = failures = unstable = 0
    steps = 0
    saved = None
    if snapshots is not None:
        if (reset is not None and policy_state is None) or recorder is not None:
            raise ValueError(
                "snapshots need a policy whose episode state can be saved (a reset hook "
                "comes with policy_state) and no recorder"
            )
        if not hasattr(env, "get_state"):
            raise ValueError("snapshots need an env with get_state/set_state")
        saved = snapshots.load()
    if saved is not None:
        import torch

        env.set_state(saved["env"])  # type: ignore[attr-defined]
        obs = saved["obs"]
        counts[:], wins[:] = saved["counts"], saved["wins"]
        returns, lengths, tts = (saved[k].tolist() for k in ("returns", "lengths", "tts"))
        truncations, failures, unstable, steps = (
            int(saved[k]) for k in ("truncations", "failures", "unstable", "steps")
        )
        t0 -= float(saved["seconds"])  # the wall time reported is the whole evaluation's
        torch.set_rng_state(torch.from_numpy(saved["torch_rng"]))
        if policy_state is not None:
            policy_state[1](saved["policy"])
    else:
        obs = env.reset(seed)
        if reset is not None:
            reset(np.ones(n, dtype=bool))
    if recorder is not None:
        recorder.begin(env)
    try:
        while (counts < episodes_per_env).any():
            if max_steps is not None and steps >= max_steps:
                raise RuntimeError(
                    f"evaluation took more than max_steps = {max_steps} vector steps with "
                    f"{int((counts < episodes_per_env).sum())} envs short of {episodes_per_env} "
                    "episodes: do the env's episodes end (truncation)?"
                )
            counting = counts < episodes_per_env
            if live is not None:
                live(counting)
            obs, reward, terminated, truncated, info = env.step(policy_fn(obs))
            steps += 1
            done = np.asarray(terminated) | np.asarray(truncated)
            if reset is not None:
                reset(done)
            if recorder is not None:
                recorder.step(env, np.asarray(reward), done, info, counting, counts.copy())
            for i in np.flatnonzero(done & counting):
                ok = bool(info["success"][i])
                wins[i] += ok
                returns.append(float(info["episode_return"][i]))
                lengths.append(int(info["episode_length"][i]))
                if ok:
                    tts.append(float(info["time_to_success"][i]))
                truncations += bool(truncated[i]) and not bool(terminated[i])
                failures += bool(info["failure"][i]) if "failure" in info else 0
                unstable += bool(info["unstable"][i]) if "unstable" in info else 0
                counts[i] += 1
                if progress is not None:
                    progress(len(returns), total)
            if snapshots is not None and snapshots.due() and (counts < episodes_per_env).any():
                import torch

                snapshots.save(
                    {
                        "env": env.get_state(),  # type: ignore[attr-defined]
                        "obs": np.asarray(obs),
                        "counts": counts,
                        "wins": wins,
                        "returns": np.array(returns, dtype=np.float64),
                        "lengths": np.array(lengths, dtype=np.int64),
                        "tts": np.array(tts, dtype=np.float64),
                        "truncations": truncations,
                        "failures": failures,
                        "unstable": unstable,
                        "steps": steps,
                        "seconds": time.perf_counter() - t0,
                        "torch_rng": torch.get_rng_state().numpy(),
                        **({"policy": policy_state[0]()} if policy_state is not None else {}),
                    }
                )
    finally:
        if live is not None:
            live(None)  # the env steps every env again
    return {
        "episodes": total,
        "success_rate": float(wins.sum() / total),
        "successes": int(wins.sum()),
        "time_to_success_s": tts,
        "median_time_to_success_s": float(np.median(tts)) if tts else float("nan"),
        "mean_return": float(np.mean(returns)),
        "std_return": float(np.std(returns)),
        "mean_length": float(np.mean(lengths)),
        "truncation_rate": truncations / total,
        "failure_rate": failures / total,
        "unstable": unstable,
        "per_env_success_rate": (wins / episodes_per_env).tolist(),
        **({"per_module": _per_module(labels, wins, episodes_per_env)} if labels else {}),
        "env_steps": steps * n,
        "seconds": time.perf_counter() - t0,
    }


def _per_module(labels: list[str], wins: np.ndarray, episodes_per_env: int) -> dict[str, float]:
    """{label: success rate}, pooling the envs that share a label."""
    if len(labels) != len(wins):
        raise ValueError(f"{len(labels)} labels for {len(wins)} envs: give one per env")
    won: dict[str, int] = {}
    played: dict[str, int] = {}
    for label, w in zip(labels, wins.tolist(), strict=True):
        won[label] = won.get(label, 0) + w
        played[label] = played.get(label, 0) + episodes_per_env
    return {k: won[k] / played[k] for k in sorted(won)}
