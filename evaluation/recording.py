"""Episodes recorded as they are played (`assetgen eval --record DIR`), one .npz per episode
for the browser preview: module_id, poses (T, 7) true position + quaternion (w x y z) after
each control step, spawn_pose (7,), reward (T,), success; optionally dt (seconds per step).

`EpisodeRecorder` follows the recorder protocol of the evaluation loop (evaluation/protocol.py), so
the scripted, random and trained agents record the same way.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from sim.env import PegInHoleVecEnv


def env_labels(env: PegInHoleVecEnv) -> list[str]:
    """The module id each env plays (for per-module results)."""
    return [env.module_ids[k] for k in env.env_module]


class EpisodeRecorder:
    """Writes the first `limit` finished episodes (in the order they end) into `folder`.

    limit None: the first attempt of each env's module (one episode per env)."""

    def __init__(self, folder: str | Path, limit: int | None = None) -> None:
        self.folder = Path(folder)
        self.limit = limit
        self.written = 0
        self._poses: list[list[np.ndarray]] = []
        self._rewards: list[list[float]] = []

    def begin(self, env: PegInHoleVecEnv) -> None:
        if self.limit is None:
            self.limit = env.num_envs
        self._poses = [[p] for p in env.sim.state[:, 1:8].copy()]
        self._rewards = [[] for _ in range(env.num_envs)]

    def step(
        self,
        env: PegInHoleVecEnv,
        reward: np.ndarray,
        done: np.ndarray,
        info: dict[str, Any],
        live: np.ndarray,
        attempts: np.ndarray,
    ) -> None:
        if self.written >= (self.limit or 0):
            return
        for i in np.flatnonzero(live):
            self._poses[i].append(info["peg_pose"][i])
            self._rewards[i].append(float(reward[i]))
        for i in np.flatnonzero(done & live):
            if self.written < (self.limit or 0):
                mid = env.module_ids[env.env_module[i]]
                self._write(mid, int(attempts[i]), i, bool(info["success"][i]))
            # the env has already spawned its next episode: that is where it starts
            self._poses[i] = [env.sim.state[i, 1:8].copy()]
            self._rewards[i] = []

    def _write(self, module: str, attempt: int, i: int, success: bool) -> None:
        poses = self._poses[i]
        save_episode(
            self.folder / f"episode_{self.written:05d}_{module}_{attempt}.npz",
            module,
            poses[0],
            poses[1:],
            self._rewards[i],
            success,
        )
        self.written += 1


def save_episode(
    path: str | Path,
    module_id: str,
    spawn_pose: np.ndarray,
    poses: np.ndarray | list[np.ndarray],
    reward: np.ndarray | list[float],
    success: bool,
    dt: float | None = None,
) -> Path:
    """Write one episode file (the keys of the module docstring; `dt`, seconds per step,
    only when given). The one writer of this format, so every recording replays alike."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    extra = {} if dt is None else {"dt": np.array(float(dt))}
    np.savez_compressed(
        path,
        module_id=np.array(module_id),
        poses=np.asarray(poses, dtype=np.float32).reshape(-1, 7),
        spawn_pose=np.asarray(spawn_pose, dtype=np.float32),
        reward=np.asarray(reward, dtype=np.float32),
        success=np.array(success),
        **extra,
    )
    return path
