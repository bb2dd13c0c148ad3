"""Reading a report's inputs: training run folders (config.json, metrics.csv, eval_*.json)
and evaluation files, each named by its variant (`variant_name`: SAC + stack 10 ->
"SAC-STACK"). The file formats are described in rl/report.py.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

SAMPLED = " (sampled)"
"""Suffix of the row of a trained policy evaluated with sampled actions."""


class ReportError(ValueError):
    """A run folder or evaluation file that cannot be read; the message names the path."""


@dataclass(frozen=True)
class EvalResult:
    """One evaluation file.

    time_to_success_s: (k,) float seconds, one per successful episode (k = successes).
    """

    path: Path
    variant: str
    split: str
    policy: str
    episodes: int
    success_rate: float
    time_to_success_s: np.ndarray


@dataclass(frozen=True)
class Run:
    """One training run (one seed of a variant).

    env_steps: (T,) int env steps summed over envs at the end of each logged iteration.
    success_rate: (T,) float in [0, 1]; NaN where no training episode had finished yet.
    """

    path: Path
    variant: str
    seed: int
    env_steps: np.ndarray
    success_rate: np.ndarray
    evals: tuple[EvalResult, ...]
    probe_env_steps: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    """(P,) env steps of the rows with a frozen-policy probe (`train --probe-steps`)."""
    probe_success_rate: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """(P,) the probe's success rate there."""
    wall_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """(T,) wall-clock seconds of training at each logged iteration (a resumed run goes on
    from its checkpoint's); empty for a metrics file without the column."""
    episodes: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    """(T,) training episodes finished by each logged iteration; empty for a metrics file
    without the column."""

    @property
    def budget(self) -> tuple[int, float]:
        """(env steps, wall-clock seconds) at the run's last logged iteration."""
        steps = int(self.env_steps[-1]) if len(self.env_steps) else 0
        wall = float(self.wall_s[-1]) if len(self.wall_s) else math.nan
        return steps, wall


def variant_name(
    algo: str, stack: int, demos: str | None = None, overrides: dict[str, Any] | None = None
) -> str:
    """The paper's name for an agent: ("sac", 10) -> "SAC-STACK", ("ppo", 1) -> "PPO".

    A stack other than the paper's 10 keeps its size in the name ("SAC-STACK4") so runs
    that differ are never averaged together; so do demonstrations ("SAC+scripted") and
    config overrides ("SAC+scripted [bc_weight=0.0]").
    """
    name = _base_name(algo, stack)
    if demos:
        name += f"+{demos}"
    if overrides:
        name += " [" + ", ".join(f"{k}={v}" for k, v in sorted(overrides.items())) + "]"
    return name


TRAINING_OPTIONS = (
    "curriculum_success",
    "module_replay",
    "near_starts",
    "inside_starts",
    "inside_starts_until",
    "axis_shaping",
)
"""The env options of `assetgen train` that change what a run learns from (config.json's
env_options), named in its variant: runs that differ in them are never averaged together."""


def env_words(env_options: dict[str, Any]) -> str:
    """The training env options a run was made with, as "key=value" words ("" for none)."""
    return " ".join(
        f"{k}={env_options[k]}" for k in TRAINING_OPTIONS if env_options.get(k) is not None
    )


def _base_name(algo: str, stack: int) -> str:
    # the built-in agents keep their names
    if algo in ("random", "scripted", "scripted-fast", "scripted-direct"):
        base = algo
    elif algo.lower() in ("dreamer", "dreamerv3"):
        base = "DreamerV3"
    else:
        base = algo.upper()
    if stack <= 1:
        return base
    return f"{base}-STACK" if stack == 10 else f"{base}-STACK{stack}"


class NotAnEvalFileError(ReportError):
    """A readable JSON object that lacks the keys of an evaluation file."""


def _read_json(path: Path) -> dict[str, Any]:
    try:
        doc = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise ReportError(f"{path}: cannot read it as JSON ({e})") from e
    if not isinstance(doc, dict):
        raise ReportError(f"{path}: expected a JSON object")
    return doc


def load_eval(path: str | Path) -> EvalResult:
    """Read one evaluation JSON (schema in the module docstring)."""
    path = Path(path)
    doc = _read_json(path)
    missing = [
        k for k in ("success_rate", "episodes", "time_to_success_s", "dataset") if k not in doc
    ]
    policy = str(doc.get("policy", "deterministic"))
    if policy not in ("deterministic", "stochastic"):
        raise ReportError(f"{path}: policy {policy!r} is neither deterministic nor stochastic")
    if "algo" in doc:
        variant = variant_name(
            doc["algo"], int(doc.get("stack", 1)), doc.get("demos"), doc.get("overrides")
        )
        if policy == "stochastic":
            variant += SAMPLED
    elif "agent" in doc:
        variant = variant_name(str(doc["agent"]), 1)
    else:
        missing.append("algo or agent")
    if missing:
        raise NotAnEvalFileError(
            f"{path}: not an evaluation file of `assetgen eval --out` (missing {missing}); "
            "re-run the evaluation with --out"
        )
    split = Path(str(doc["dataset"])).name  # "datasets/test" and "test" both name the split
    noise = float(doc.get("noise_scale", 1.0))
    if noise != 1.0:  # a robustness evaluation gets its own column
        split += f" (noise ×{noise:g})"
    return EvalResult(
        path=path,
        variant=variant,
        split=split,
        policy=policy,
        episodes=int(doc["episodes"]),
        success_rate=float(doc["success_rate"]),
        time_to_success_s=np.asarray(doc["time_to_success_s"], dtype=float),
    )


def _read_metrics(
    path: Path,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        cols = reader.fieldnames or []
        if "env_steps" not in cols or "success_rate" not in cols:
            raise ReportError(
                f"{path}: needs the columns env_steps and success_rate (rl/runner.py); has {cols}"
            )
        rows = list(reader)
    # an empty cell or "nan": no training episode had finished by that iteration
    rate = [float(r["success_rate"]) if r["success_rate"] else math.nan for r in rows]
    steps = np.array([int(float(r["env_steps"])) for r in rows], dtype=np.int64)
    probed = [i for i, r in enumerate(rows) if r.get("probe_success_rate")]
    probe = np.array([float(rows[i]["probe_success_rate"]) for i in probed])
    wall = np.array([float(r["wall_s"]) for r in rows]) if "wall_s" in cols else np.zeros(0)
    episodes = np.array(
        [int(float(r["episodes"])) for r in rows] if "episodes" in cols else [], dtype=np.int64
    )
    return steps, np.array(rate), steps[probed], probe, wall, episodes


def load_run(path: str | Path, label: str | None = None) -> Run:
    """Read a run folder: config.json, metrics.csv and any eval_*.json. label: the run's
    row instead of its variant's name (a screening page, where every run is a candidate of
    its own and two runs of one variant are not seeds of one recipe)."""
    path = Path(path)
    config, metrics = path / "config.json", path / "metrics.csv"
    if not path.is_dir() or not config.is_file() or not metrics.is_file():
        raise ReportError(
            f"{path} is not a training run: it needs config.json and metrics.csv "
            "(written by `assetgen train --out RUN_DIR`); give run folders only"
        )
    meta = _read_json(config)
    if "algo" not in meta:
        raise ReportError(f"{config}: no 'algo' key; is this a run of `assetgen train`?")
    policy = variant_name(
        meta["algo"], int(meta.get("stack", 1)), meta.get("demos"), meta.get("overrides")
    )
    # an evaluation file names the policy only; the run's training env options follow it
    variant = f"{policy} {env_words(meta.get('env_options') or {})}".strip()
    steps, rate, probe_steps, probe_rate, wall, episodes = _read_metrics(metrics)
    evals = tuple(load_eval(p) for p in sorted(path.glob("eval_*.json")))
    for e in evals:
        if e.variant.removesuffix(SAMPLED) != policy:
            raise ReportError(f"{e.path} evaluates {e.variant}, but the run {path} is {policy}")
    evals = tuple(
        replace(e, variant=variant + (SAMPLED if e.variant.endswith(SAMPLED) else ""))
        for e in evals
    )
    kinds = [(e.split, e.policy) for e in evals]
    if len(set(kinds)) != len(kinds):
        raise ReportError(
            f"{path} has two evaluation files of one dataset and policy: keep one of each"
        )
    seed = int(meta.get("seed", 0))
    if label is not None:
        variant = label
        evals = tuple(
            replace(e, variant=label + (SAMPLED if e.variant.endswith(SAMPLED) else ""))
            for e in evals
        )
    return Run(path, variant, seed, steps, rate, evals, probe_steps, probe_rate, wall, episodes)


def load_baselines(paths: list[str | Path]) -> tuple[list[EvalResult], list[Path]]:
    """(evaluation results, skipped files) from evaluation files given directly or folders.

    A file named directly must be an evaluation file. In a folder, every *.json directly
    inside is read; valid JSON without the evaluation keys (a `bench --json` output, say)
    is skipped and returned, so a results/ folder can be passed as it is."""
    results: list[EvalResult] = []
    skipped: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            for f in sorted(p.glob("*.json")):
                try:
                    results.append(load_eval(f))
                except NotAnEvalFileError:  # unreadable JSON is still an error
                    skipped.append(f)
        elif p.is_file():
            results.append(load_eval(p))
        else:
            raise ReportError(f"{p}: no such file or folder of evaluation JSONs")
    return results, skipped
