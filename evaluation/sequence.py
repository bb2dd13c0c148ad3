"""An assembly dataset's steps in sequence, under the paper's protocol (`assetgen eval
--dataset <assembly dataset>`).

Stage 1 (the first step's part, the profile) is evaluated as a Table I dataset is: one env per
assembly, `attempts` episodes back to back, noise on, full spawn ranges. Each later stage
continues only the attempts whose earlier stages all succeeded: one env per such attempt,
one episode, with the parts of its earlier stages as static geometry where that attempt left
them, in chunks of `chunk` envs (every env has its own model then).

Where a part is left: the task counts a success once the part is within `success_radius`
(5 mm) of its seat, where a robot would finish by pushing it home. So each successful part
is pressed home along its insertion axis and keeps the lateral offset and the tilt the
agent left it with; unpressed, a profile seated 5 mm high would block the cross hole the
bolt goes through at 0.5 mm clearance.

The observation stays the 18-D pose of the active part in its own entrance and bottom
frames, and actions are velocities in its entrance frame: an agent trained on Table I
modules runs unchanged. A sequence succeeds when every stage does; its time is the sum of
the stages' times to success (the transfer between stages is not simulated).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from assetgen.core.recorded_path import recorded_path
from sim.assets.assembly import AssemblyStages
from sim.assets.loading import AssetError
from sim.env import PegInHoleVecEnv
from sim.task import rules as T
from sim.task.config import TaskConfig

SUCCESS, FAILURE, TRUNCATED = 0, 1, 2
"""Outcome codes of an episode."""


def pressed_home(
    pos: np.ndarray, quat: np.ndarray, design: np.ndarray, axis: np.ndarray
) -> np.ndarray:
    """(4, 4) pose of a part that ended at pos (3,), quat (4,) (module frame) near its
    design pose `design` (4, 4), pushed along its insertion direction `axis` (3,) until it
    is as deep as the design: the axial offset removed, the lateral offset and the
    orientation kept."""
    pose = T.pose(np.asarray(pos, float)[None], np.asarray(quat, float)[None])[0]
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    d = pose[:3, 3] - design[:3, 3]
    pose[:3, 3] = design[:3, 3] + d - (d @ axis) * axis
    return pose


class _Ends:
    """evaluation/protocol.py's Recorder that keeps each counted episode's outcome, time to success
    and the part's final pose, by (env, attempt); and, for the (env, attempt) pairs in
    `trace`, the part's true pose (7,) after every control step, the spawn first."""

    def __init__(self, n: int, attempts: int, trace: set[tuple[int, int]] = frozenset()) -> None:
        self.outcome = np.full((n, attempts), -1, dtype=np.int8)
        self.time = np.full((n, attempts), np.nan)
        self.pose = np.zeros((n, attempts, 7))
        self.trace = trace
        self.paths: dict[tuple[int, int], np.ndarray] = {}
        self._now: dict[int, list[np.ndarray]] = {}

    @staticmethod
    def _state(env: Any) -> np.ndarray:
        while not hasattr(env, "sim"):  # observation stacking wraps the env
            env = env.env
        return env.sim.state[:, 1:8]

    def begin(self, env: Any) -> None:
        if self.trace:
            state = self._state(env)
            self._now = {i: [state[i].copy()] for i in {i for i, _ in self.trace}}

    def step(self, env: Any, reward: np.ndarray, done: np.ndarray, info: dict[str, Any],
             live: np.ndarray, attempts: np.ndarray) -> None:  # fmt: skip
        del reward
        for i in self._now:
            if live[i]:
                self._now[i].append(np.asarray(info["peg_pose"][i], float).copy())
        for i in np.flatnonzero(done & live):
            j = attempts[i]
            ok, failed = bool(info["success"][i]), bool(info["failure"][i])
            self.outcome[i, j] = SUCCESS if ok else FAILURE if failed else TRUNCATED
            self.time[i, j] = info["time_to_success"][i]
            self.pose[i, j] = info["peg_pose"][i]
            if i in self._now:
                if (i, int(j)) in self.trace:
                    self.paths[(i, int(j))] = np.array(self._now[i])
                # the env has spawned its next episode already: that is where it starts
                self._now[i] = [self._state(env)[i].copy()]


def _offset(
    progress: Callable[[str, int, int], None] | None, part: str, start: int, total: int
) -> Callable[[int, int], None] | None:
    """evaluation/protocol.py's progress(done, total) of one chunk as the stage's."""
    if progress is None:
        return None
    return lambda done, _: progress(part, start + done, total)


def _summary(outcome: np.ndarray, times: np.ndarray) -> dict[str, Any]:
    """Rates over the episodes of one stage that were played (outcome >= 0)."""
    played = outcome >= 0
    n = int(played.sum())
    tts = times[outcome == SUCCESS]
    rate = lambda code: float((outcome == code).sum() / n) if n else float("nan")  # noqa: E731
    return {
        "episodes": n,
        "successes": int((outcome == SUCCESS).sum()),
        "success_rate": rate(SUCCESS),
        "failure_rate": rate(FAILURE),
        "truncation_rate": rate(TRUNCATED),
        "median_time_to_success_s": float(np.median(tts)) if len(tts) else float("nan"),
        "time_to_success_s": tts.tolist(),
    }


def evaluate_sequence(
    module_dirs: list[Path],
    policy: Callable[[np.ndarray], np.ndarray],
    attempts: int,
    config: TaskConfig,
    *,
    seed: int = 0,
    reset: Callable[[np.ndarray], None] | None = None,
    wrap: Callable[[PegInHoleVecEnv], Any] | None = None,
    chunk: int = 256,
    progress: Callable[[str, int, int], None] | None = None,
    record: Path | None = None,
    record_limit: int | None = None,
) -> dict[str, Any]:
    """Play every assembly in `module_dirs` `attempts` times through all its steps.

    policy, reset : as evaluation/protocol.py's (a recurrent policy's state restarts each episode)
    wrap          : applied to each stage's env (observation stacking)
    progress      : (stage part, episodes done, episodes of the stage)
    record        : a folder for the first attempt of the first `record_limit` assemblies
                    (default: each assembly's), one .npz per attempt (see save_sequence)

    Returns a JSON-ready dict: `stages` (one summary per step: episodes played, rates over
    them, and `success_rate_of_attempts`, the share of all attempts that got this far and
    succeeded), `sequence` (every stage succeeded; time = sum of the stages'), and
    `per_module` (each assembly's sequence success rate).
    """
    from evaluation.protocol import evaluate

    if attempts < 1:
        raise ValueError(f"attempts = {attempts}: give at least 1 episode per assembly")
    if chunk < 1:
        raise ValueError(f"chunk = {chunk}: give at least 1 env per chunk")
    t0 = time.perf_counter()
    stages = [AssemblyStages(d) for d in module_dirs]
    if not stages:
        raise AssetError("no assemblies given")
    parts = stages[0].parts
    odd = [s.dir.name for s in stages if s.parts != parts]
    if odd:
        raise AssetError(
            f"assemblies {odd[:5]} have other steps than {parts}: evaluate one family's "
            "dataset at a time"
        )
    n = len(stages)
    wrap = wrap or (lambda env: env)
    placed: dict[tuple[int, int], dict[str, np.ndarray]] = {}
    outcomes = np.full((len(parts), n, attempts), -1, dtype=np.int8)
    times = np.full((len(parts), n, attempts), np.nan)
    env_steps = 0
    traced = set() if record is None else {(a, 0) for a in range(min(n, record_limit or n))}
    paths: dict[tuple[int, int], list[np.ndarray]] = {key: [] for key in traced}

    def keep(k: int, ends: _Ends, rows: list[tuple[int, int]], col: int | None) -> None:
        """Stage k's outcomes by (assembly, attempt); its successes pressed home."""
        for i, (a, j) in enumerate(rows):
            c = j if col is None else col
            outcomes[k, a, j] = ends.outcome[i, c]
            times[k, a, j] = ends.time[i, c]
            if ends.outcome[i, c] == SUCCESS:
                pose = ends.pose[i, c]
                st = stages[a]
                home = pressed_home(pose[:3], pose[3:], st.design_pose(k), st.insertion_axis(k))
                placed.setdefault((a, j), {})[parts[k]] = home

    for k, part in enumerate(parts):
        if k == 0:
            env = PegInHoleVecEnv([s.stage(0) for s in stages], n, config, assignment_seed=seed)
            ends = _Ends(n, attempts, traced)
            shifted = _offset(progress, part, 0, n * attempts)
            res = evaluate(policy, wrap(env), attempts, seed=seed, reset=reset,
                           progress=shifted, recorder=ends)  # fmt: skip
            env_steps += res["env_steps"]
            for j in range(attempts):
                keep(0, ends, [(a, j) for a in range(n)], None)
            for key, path in ends.paths.items():
                paths[key].append(path)
            continue
        alive = (outcomes[:k] == SUCCESS).all(axis=0)
        todo = [(int(a), int(j)) for a, j in zip(*np.nonzero(alive), strict=True)]
        for c in range(0, len(todo), chunk):
            rows = todo[c : c + chunk]
            assets = [stages[a].stage(k, placed[(a, j)]) for a, j in rows]
            env = PegInHoleVecEnv(assets, len(assets), config, assignment_seed=seed)
            ends = _Ends(len(rows), 1, {(i, 0) for i, key in enumerate(rows) if key in traced})
            shifted = _offset(progress, part, c, len(todo))
            res = evaluate(policy, wrap(env), 1, seed=seed + 1_000_003 * k + c, reset=reset,
                           progress=shifted, recorder=ends)  # fmt: skip
            env_steps += res["env_steps"]
            keep(k, ends, rows, 0)
            for (i, _), path in ends.paths.items():
                paths[rows[i]].append(path)

    for a, j in sorted(paths):
        st = stages[a]
        save_sequence(
            Path(record) / f"sequence_{st.dir.name}_{j}.npz",  # type: ignore[arg-type]
            str(st.meta.get("id", st.dir.name)),
            parts,
            paths[(a, j)],
            outcomes[: len(paths[(a, j)]), a, j],
            [placed.get((a, j), {}).get(p, np.full((4, 4), np.nan)) for p in parts],
            config.control_dt,
        )
    done = (outcomes == SUCCESS).all(axis=0)
    seq_times = np.nansum(times, axis=0)[done]
    stage_rows = []
    for k, part in enumerate(parts):
        row = _summary(outcomes[k], times[k])
        row["part"] = part
        row["clearance_m"] = sorted({float(s.steps[k]["clearance"]) for s in stages})
        row["success_rate_of_attempts"] = row["successes"] / (n * attempts)
        stage_rows.append(row)
    ids = [str(s.meta.get("id", s.dir.name)) for s in stages]
    return {
        "assemblies": n,
        "attempts": attempts,
        "parts": parts,
        "stages": stage_rows,
        "sequence": {
            "episodes": n * attempts,
            "successes": int(done.sum()),
            "success_rate": float(done.mean()),
            "median_time_to_success_s": float(np.median(seq_times))
            if len(seq_times)
            else float("nan"),
            "time_to_success_s": seq_times.tolist(),
        },
        "per_module": {mid: float(done[a].mean()) for a, mid in enumerate(ids)},
        "env_steps": env_steps,
        "seconds": time.perf_counter() - t0,
    }


def save_sequence(
    path: Path,
    assembly_id: str,
    parts: list[str],
    poses: list[np.ndarray],
    outcome: np.ndarray,
    placed: list[np.ndarray],
    dt: float,
) -> Path:
    """One attempt at an assembly's sequence as an .npz for the viewer: assembly_id, parts
    (the steps' parts in order), dt (s per control step), and per stage reached k:
    poses_k (T_k, 7) the part's true position + quaternion (w x y z) in the module frame,
    the spawn first; outcome (stages reached,) 0 success, 1 failure, 2 truncated; placed
    (steps, 4, 4) where each successful part was pressed home and stayed (NaN otherwise)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(
        path,
        assembly_id=np.array(assembly_id),
        parts=np.array(parts),
        dt=np.array(float(dt)),
        outcome=np.asarray(outcome, dtype=np.int8),
        placed=np.asarray(placed, dtype=np.float64).reshape(len(parts), 4, 4),
        **{f"poses_{k}": np.asarray(p, dtype=np.float32) for k, p in enumerate(poses)},
    )
    return path


def is_assembly_dataset(dataset: str | Path) -> bool:
    """Whether `dataset` (a spec name or a folder) holds assemblies (a family of the assembly
    layout), which `assetgen eval` plays in sequence."""
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import DatasetError
    from assetgen.families.registry import is_assembly
    from sim.assets.loading import dataset_root

    try:
        return is_assembly(Dataset(dataset_root(dataset)).spec.family)
    except DatasetError:
        return False  # not a dataset: the caller's own loading says why


def evaluate_assembly_dataset(
    dataset: str | Path,
    policy: Callable[[np.ndarray], np.ndarray],
    attempts: int,
    *,
    seed: int = 0,
    reset: Callable[[np.ndarray], None] | None = None,
    wrap: Callable[[PegInHoleVecEnv], Any] | None = None,
    noise_scale: float = 1.0,
    progress: Callable[[str, int, int], None] | None = None,
    record: Path | None = None,
    record_limit: int | None = None,
    keep_physics: bool = False,
    modules: int | None = None,
) -> dict[str, Any]:
    """evaluate_sequence over every assembly of a dataset with the evaluation protocol's
    task config; the result names the dataset (folder and content hash) as `assetgen eval`'s
    files do. keep_physics: as for sim.env.make_train_env. modules: the dataset's first
    `modules` assemblies only (None: all, the protocol)."""
    from assetgen.core.mujoco_config import physics_from_record
    from assetgen.dataset.reader import Dataset, content_hash
    from sim.assets.loading import check_physics, dataset_root
    from sim.env import eval_config

    root = dataset_root(dataset)
    config = replace(eval_config(noise_scale), physics=check_physics(root, keep_physics))
    ds = Dataset(root)
    # what the files carry: the simulator's own physics unless told to keep other physics
    version, physics = physics_from_record(ds.info.get("physics"))
    if not ds.ids:
        raise AssetError(f"{root} holds no finished assemblies; generate them first")
    if modules is not None and modules < 1:
        raise ValueError(f"modules = {modules}: evaluate at least 1 assembly")
    ids = ds.ids if modules is None else ds.ids[:modules]
    res = evaluate_sequence(
        [ds.module_dir(m) for m in ids], policy, attempts, config,
        seed=seed, reset=reset, wrap=wrap, progress=progress, record=record,
        record_limit=record_limit,
    )  # fmt: skip
    return {
        "dataset_folder": recorded_path(root),
        "dataset_hash": content_hash(ds.records),
        "family": ds.spec.family,
        "control_dt": config.control_dt,
        "noise_scale": noise_scale,
        "physics_version": version,
        "timestep": (config.physics or physics).timestep,
        **({} if modules is None else {"modules": len(ids)}),
        **res,
    }
