"""The frozen-policy probe of a training run (`assetgen train --probe-steps N`).

The training columns of metrics.csv (success rate, return, time to success) describe the
policy that acted while it learned: it changes at every gradient step, and on peg-in-hole
that movement alone frees pegs that a frozen policy leaves jammed (one SAC run logged 96 %
training success where its saved policy, run frozen from the same env state, succeeded in
53 % of episodes). The probe runs the deterministic policy, frozen, on the same episodes
every time (fixed modules of the training set, fixed spawns), through the one evaluation
loop, and logs `probe_success_rate`, `probe_time_to_success_median` and
`probe_truncation_rate` with that iteration's row.

A recurrent agent's acting state (Dreamer's h, z, previous action) is saved before the
probe and put back after it, so training carries on where it was.

`dataset_probe` is the probe factory `assetgen train` receives from cli.py (rl/commands.py's
MakeProbe): the probe on the simulator's evaluation env of the dataset's first modules.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from evaluation.protocol import evaluate
from rl.agents import reset_hook
from rl.stack import StackObs


def make_probe(env: Any, attempts: int, stack: int = 1, seed: int = 0) -> Callable[[Any], dict]:
    """agent -> probe columns, for an evaluation env (one env per probed module) that the
    probe keeps; `attempts` episodes per env, env reset with `seed` each time."""
    if attempts < 1:
        raise ValueError(f"probe attempts {attempts}: give at least 1 episode per module")
    if stack > 1:
        env = StackObs(env, stack)

    def probe(agent: Any) -> dict[str, float]:
        saved = agent.acting_state() if hasattr(agent, "acting_state") else None
        try:
            res = evaluate(
                lambda o: agent.policy(o, deterministic=True),
                env,
                attempts,
                seed=seed,
                reset=reset_hook(agent),
            )
        finally:
            if saved is not None:
                agent.load_acting_state(saved)
        return {
            "probe_success_rate": res["success_rate"],
            "probe_time_to_success_median": res["median_time_to_success_s"],
            "probe_truncation_rate": res["truncation_rate"],
        }

    return probe


def dataset_probe(
    dataset: str,
    modules: int,
    attempts: int,
    stack: int = 1,
    keep_physics: bool = False,
    **engine: Any,
) -> Callable[[Any], dict]:
    """The probe of `train --probe-steps`: the evaluation env (sim.make_eval_env, no env
    count limit, seed 0) of the dataset's first `modules` modules, `attempts` episodes per
    module; `keep_physics` and `engine` as for the training env."""
    from sim import make_eval_env

    env = make_eval_env(dataset, None, 0, modules=modules, keep_physics=keep_physics, **engine)
    return make_probe(env, attempts, stack)
