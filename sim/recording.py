"""Episodes recorded as they are played (`assetgen eval --record DIR`), one .npz per episode
for the browser preview: module_id, poses (T, 7) true position + quaternion (w x y z) after
each control step, spawn_pose (7,), reward (T,), success.

`EpisodeRecorder` follows the recorder protocol of the evaluation loop (rl/evaluate.py), so
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
        self.folder.mkdir(parents=True, exist_ok=True)
        poses = self._poses[i]
        np.savez_compressed(
            self.folder / f"episode_{self.written:05d}_{module}_{attempt}.npz",
            module_id=np.array(module),
            poses=np.asarray(poses[1:], dtype=np.float32),
            spawn_pose=np.asarray(poses[0], dtype=np.float32),
            reward=np.asarray(self._rewards[i], dtype=np.float32),
            success=np.array(success),
        )
        self.written += 1
