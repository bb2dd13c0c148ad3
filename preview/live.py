"""A trained policy inserting the peg, live in the viewer (`assetgen view DATASET --policy RUN`).

`LivePolicy` owns one simulated env on one module, the agent, the stepping thread and the
episode recordings; it knows nothing of viser. After every control step (and at every
spawn) it calls `on_step(LiveFrame)`; when the policy fails (NaN actions) it stops and calls
`on_error(text)`. The server draws both.

The env is the evaluation task (`sim.task.config.EVAL_CONFIG`: observation and action noise on,
full spawn ranges): the policy sees what it would see in `assetgen eval`. Real time: each
control step takes `control_dt` of wall time, or longer where the machine is slower.

Every episode played is written to the recording folder as `live_NNNNN_<module>.npz` in the
format of evaluation/recording.py (with `dt`), loadable with the viewer's "Load episode"; one cut
short (new spawn, another module, the viewer closing) is written too, as no success.

This module, rl, torch and sim are imported only when a policy is given: the viewer itself
runs without the [rl] extra.
"""

from __future__ import annotations

import re
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from assetgen.core.rotations import matrix_to_quat, rot6d_to_matrix
from preview.scene import PreviewError

CHECKPOINT = "checkpoint.safetensors"
"""The file a run or exported policy folder holds (rl.run_state.CHECKPOINT; not imported from
there because that imports torch, and a missing file is reported without it)."""
RECORDING = re.compile(r"live_(\d+)_.+\.npz")
"""Names of the episode files written here: live_<number>_<module>.npz."""
STOP_JOIN_S = 2.0
"""How long `pause` waits for the stepping thread to finish its step."""


@dataclass(frozen=True)
class LiveFrame:
    """The state after one control step (step 0: the spawn), for display."""

    module_id: str
    step: int
    """Control steps taken since the spawn."""
    dt: float
    """Seconds per control step."""
    max_steps: int
    """The step limit of an episode."""
    true_pose: np.ndarray
    """(7,) the peg's pose: position (m), quaternion wxyz, module frame."""
    observed_pose: np.ndarray
    """(7,) the pose the policy observed (with the task's estimation noise), same form."""
    reward: float
    """Reward of this step (0 at the spawn)."""
    episode_return: float
    success: bool
    ended: str | None = None
    """None while the episode goes on; else why it ended: success, failure, step limit or
    unstable physics."""
    recording: Path | None = None
    """The episode file, written when the episode ended."""
    joints: np.ndarray | None = None
    """The robot's joint positions (rad) when a robot holds the peg, else None."""

    @property
    def time_s(self) -> float:
        """Simulated seconds since the spawn."""
        return self.step * self.dt

    def observation_error(self) -> tuple[float, float]:
        """(position error m, rotation error degrees) of the observed against the true pose."""
        d = float(np.linalg.norm(self.observed_pose[:3] - self.true_pose[:3]))
        dot = abs(float(self.observed_pose[3:] @ self.true_pose[3:]))
        return d, float(np.degrees(2.0 * np.arccos(min(1.0, dot))))


def find_checkpoint(path: str | Path) -> Path:
    """The checkpoint file of a run or exported policy folder (or the file itself);
    PreviewError naming what to give when there is none."""
    p = Path(path)
    if p.is_dir():
        f = p / CHECKPOINT
        if f.is_file():
            return f
        raise PreviewError(
            f"--policy {p}: the folder holds no {CHECKPOINT}; give a training run folder "
            "(`assetgen train --out RUN`) or an exported policy (`assetgen export RUN --out DIR`)"
        )
    if p.is_file():
        return p
    raise PreviewError(
        f"--policy {p} does not exist; give a training run folder or an exported policy "
        f"folder (both hold {CHECKPOINT})"
    )


def load_policy(path: str | Path) -> tuple[Any, dict[str, Any]]:
    """(agent on CPU, run metadata) of a checkpoint that fits the peg-in-hole task;
    PreviewError for a missing or corrupt checkpoint and for one trained on observations or
    actions of another size (naming the checkpoint's and the task's)."""
    from rl.checkpoint import CheckpointError
    from rl.run_state import load_agent
    from sim.task.rules import ACT_DIM, OBS_DIM

    ckpt = find_checkpoint(path)
    try:
        agent, meta = load_agent(ckpt, "cpu")  # one env: the CPU is as fast as any
    except CheckpointError as e:
        raise PreviewError(f"--policy {path}: {e}") from e
    stack, obs_dim, act_dim = int(meta["stack"]), int(meta["obs_dim"]), int(meta["act_dim"])
    if obs_dim != OBS_DIM * stack:
        raise PreviewError(
            f"--policy {path}: the policy takes observations of {obs_dim} values at stack "
            f"depth {stack}, but the peg-in-hole task gives {OBS_DIM} per step, so "
            f"{OBS_DIM * stack} at stack {stack}: it was trained on another task or "
            "observation; give a policy trained with `assetgen train`"
        )
    if act_dim != ACT_DIM:
        raise PreviewError(
            f"--policy {path}: the policy gives {act_dim} action values, the peg-in-hole task "
            f"takes {ACT_DIM}: give a policy trained with `assetgen train`"
        )
    return agent, meta


class LivePolicy:
    """A policy playing one module at a time in real time, recording every episode.

    Call `set_module` first (and again for another module), then `run` / `pause` / `step`
    / `spawn`. Public methods may be called from any thread; `on_step` and `on_error` are
    called from the stepping thread or the caller's, never with this object's lock held
    (so they may take the viewer's lock while the viewer calls in here).
    """

    def __init__(
        self,
        path: str | Path,
        record_dir: str | Path | None = None,
        *,
        seed: int = 0,
        on_step: Callable[[LiveFrame], None] | None = None,
        on_error: Callable[[str], None] | None = None,
        robot: str | None = None,
    ) -> None:
        import torch

        from rl.agents import reset_hook

        self.robot = robot
        """The registered robot holding the peg (None: the floating peg)."""
        self.checkpoint = find_checkpoint(path)
        self.agent, self.meta = load_policy(path)
        self._reset_agent = reset_hook(self.agent)
        # Dreamer samples latents even when deterministic: seeded, runs repeat.
        torch.manual_seed(seed)
        if record_dir is None:  # after loading: a bad policy leaves no empty folder behind
            record_dir = tempfile.mkdtemp(prefix="assetgen-live-")
        self.record_dir = Path(record_dir)
        try:
            self.record_dir.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise PreviewError(
                f"--record {self.record_dir}: cannot create the folder ({e.strerror}); "
                "give a writable folder"
            ) from e
        self.on_step = on_step or (lambda frame: None)
        self.on_error = on_error or (lambda text: None)
        self._rng = np.random.default_rng(seed)
        self._lock = threading.RLock()
        """Env and episode state: the stepping thread against calls from the GUI."""
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.env: Any = None
        """The env the policy steps (wrapped in StackObs for a stacking policy)."""
        self.base_env: Any = None
        """The PegInHoleVecEnv itself: frames, true poses, control period."""
        self.module_id: str | None = None
        self.module_dir: Path | None = None
        self.frame: LiveFrame | None = None
        """The last frame shown (None before the first spawn)."""
        self.written: list[Path] = []
        self._obs: np.ndarray | None = None
        self._spawn_pose: np.ndarray | None = None
        self._poses: list[np.ndarray] = []
        self._rewards: list[float] = []
        # numbered after the files already there: a reused folder keeps its recordings
        found = (RECORDING.fullmatch(f.name) for f in self.record_dir.glob("live_*.npz"))
        self._next_file = 1 + max((int(m[1]) for m in found if m), default=-1)

    @property
    def algo(self) -> str:
        return str(self.meta["algo"])

    @property
    def stack(self) -> int:
        return int(self.meta["stack"])

    # ------------------------------------------------------------------ module and episodes

    def set_module(self, module_dir: str | Path) -> LiveFrame:
        """Play the module in `module_dir` (a no-op when it is the one played): a new env, and
        a spawn shown. PreviewError when the simulator cannot load the module."""
        from sim.assets.loading import AssetError, load_module
        from sim.env import PegInHoleVecEnv
        from sim.task.config import EVAL_CONFIG

        module_dir = Path(module_dir)
        if module_dir == self.module_dir and self.frame is not None:
            return self.frame
        self.pause()
        with self._lock:
            self._end_cut_short()
            try:
                asset = load_module(module_dir)
            except AssetError as e:
                raise PreviewError(f"cannot simulate this module: {e}") from e
            if self.env is not None:
                self.env.close()
            try:  # one env, one thread
                env = PegInHoleVecEnv([asset], 1, EVAL_CONFIG, nthread=1, robot=self.robot)
            except ValueError as e:  # a module the robot refuses, or cannot hold over its hole
                raise PreviewError(f"cannot simulate this module: {e}") from e
            self.base_env = env
            if self.stack > 1:
                from rl.stack import StackObs

                env = StackObs(env, self.stack)  # newest observation first, as in training
            self.env = env
            self.module_dir = module_dir
            self.module_id = asset.id
            frame = self._spawn()
        self.on_step(frame)
        return frame

    def spawn(self) -> LiveFrame:
        """A new random start pose on the same module (the episode under way is recorded)."""
        self.pause()
        with self._lock:
            self._require_module()
            self._end_cut_short()
            frame = self._spawn()
        self.on_step(frame)
        return frame

    def _require_module(self) -> None:
        if self.env is None:
            raise PreviewError("no module to play yet: pick one first")

    def _spawn(self) -> LiveFrame:
        obs = self.env.reset(int(self._rng.integers(2**31)))
        return self._begin(obs)

    def _begin(self, obs: np.ndarray) -> LiveFrame:
        """Start the episode whose first observation is `obs` (the env is at its spawn)."""
        if self._reset_agent is not None:
            self._reset_agent(np.ones(1, dtype=bool))  # a recurrent policy starts afresh
        self._obs = obs
        self._spawn_pose = self.base_env.sim.state[0, 1:8].copy()
        self._poses, self._rewards = [], []
        self.frame = self._frame(0, self._spawn_pose, obs[0], 0.0, 0.0, False)
        return self.frame

    def _frame(
        self,
        step: int,
        true_pose: np.ndarray,
        obs: np.ndarray,
        reward: float,
        ret: float,
        success: bool,
        ended: str | None = None,
        recording: Path | None = None,
    ) -> LiveFrame:
        assert self.module_id is not None
        return LiveFrame(
            self.module_id,
            step,
            self.base_env.control_dt,
            self.base_env.cfg.max_steps,
            np.asarray(true_pose, dtype=np.float64).copy(),
            self.observed_pose(obs),
            reward,
            ret,
            success,
            ended,
            recording,
            None if self.robot is None else self.base_env.sim.joint_positions()[0],
        )

    def observed_pose(self, obs: np.ndarray) -> np.ndarray:
        """(7,) position + quaternion wxyz in the module frame of the pose in an observation:
        its first 9 values are the peg's pose in the entrance frame (position, then the
        first two rotation columns); a stacked observation starts with the newest."""
        o = np.asarray(obs, dtype=np.float64)[:9]
        in_entrance = np.eye(4)
        in_entrance[:3, :3] = rot6d_to_matrix(o[3:9])
        in_entrance[:3, 3] = o[:3]
        m = self.base_env.entrance[0] @ in_entrance
        return np.concatenate([m[:3, 3], matrix_to_quat(m[:3, :3])])

    # ------------------------------------------------------------------ stepping

    def step(self) -> LiveFrame | None:
        """One control step (while paused: the step-by-step mode). After an ended episode the
        first call shows the next spawn. None when the policy failed (on_error was called)."""
        self.pause()
        return self._advance()

    def _advance(self) -> LiveFrame | None:
        error = None
        with self._lock:
            self._require_module()
            assert self.frame is not None and self._obs is not None
            if self.frame.ended is not None:
                frame: LiveFrame | None = self._begin(self._obs)  # the env has spawned anew
            else:
                frame, error = self._control_step()
        if frame is not None:
            self.on_step(frame)
        if error is not None:
            self.on_error(error)
            return None
        return frame

    def _control_step(self) -> tuple[LiveFrame | None, str | None]:
        """(frame, None) after one step; (None, message) when the policy failed (its
        non-finite actions never reach the simulator); (frame, message) when the ended
        episode could not be written."""
        assert self.frame is not None and self._obs is not None
        k = self.frame.step
        try:
            actions = np.asarray(self.agent.policy(self._obs, deterministic=True), np.float64)
        except Exception as e:  # any failure of the network is shown in the page, not raised
            return None, (
                f"the policy failed at step {k} on module {self.module_id} "
                f"({type(e).__name__}: {e}); the run is stopped"
            )
        if actions.shape != (1, 6) or not np.isfinite(actions).all():
            return None, (
                f"the policy gave non-finite or malformed actions {actions.tolist()} at step {k} "
                f"on module {self.module_id}; the run is stopped: its weights are probably NaN "
                "(a diverged run), pick another checkpoint with --policy"
            )
        obs, reward, terminated, truncated, info = self.env.step(actions)
        true_pose = info["peg_pose"][0]
        r = float(reward[0])
        self._poses.append(true_pose.copy())
        self._rewards.append(r)
        done = bool(terminated[0] or truncated[0])
        ret = float(sum(self._rewards))
        success = bool(info["success"][0])
        if not done:
            self._obs = obs
            self.frame = self._frame(k + 1, true_pose, obs[0], r, ret, success)
            return self.frame, None
        if success:
            ended = "success"
        elif bool(info["failure"][0]):
            ended = "failure"
        elif bool(info["unstable"][0]):
            ended = "unstable physics"
        else:
            ended = "step limit"
        error = path = None
        try:
            path = self._record(success)
        except OSError as e:
            error = f"cannot write the episode into {self.record_dir} ({e}); give --record DIR"
        # the env has reset itself: obs is the next episode's first observation
        final_obs = info["final_obs"][0]
        self._obs = obs
        self.frame = self._frame(k + 1, true_pose, final_obs, r, ret, success, ended, path)
        return self.frame, error

    def run(self) -> None:
        """Step in real time until the episode ends, `pause`, or the policy fails. After an
        ended episode it starts the next one from its spawn."""
        with self._lock:
            self._require_module()
            if self._thread is not None and self._thread.is_alive():
                return
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, daemon=True, name="live-policy")
            self._thread.start()

    def _run(self) -> None:
        assert self.frame is not None
        dt = self.frame.dt
        if self.frame.ended is not None and self._advance() is None:
            return
        t_next = time.perf_counter()
        while not self._stop.is_set():
            t_next += dt
            delay = t_next - time.perf_counter()
            if delay > 0:
                if self._stop.wait(delay):
                    return
            else:
                t_next = time.perf_counter()  # behind: as fast as possible, no catching up
            frame = self._advance()
            if frame is None or frame.ended is not None:
                return

    def stop_soon(self) -> None:
        """Ask the stepping thread to stop after its current step, without waiting (safe
        while holding a lock the thread's `on_step` takes)."""
        self._stop.set()

    def pause(self) -> None:
        """Stop stepping and wait for the thread (a no-op when not running)."""
        self._stop.set()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=STOP_JOIN_S)
        self._thread = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    # ------------------------------------------------------------------ recordings

    def _record(self, success: bool) -> Path:
        from evaluation.recording import save_episode

        assert self.module_id is not None and self._spawn_pose is not None
        path = self.record_dir / f"live_{self._next_file:05d}_{self.module_id}.npz"
        self._next_file += 1
        save_episode(
            path,
            self.module_id,
            self._spawn_pose,
            self._poses,
            self._rewards,
            success,
            dt=self.base_env.control_dt,
        )
        self.written.append(path)
        self._poses, self._rewards = [], []
        return path

    def _end_cut_short(self) -> None:
        """Record the episode under way, if it took a step, as no success."""
        if self.frame is not None and self.frame.ended is None and self._poses:
            try:
                self._record(False)
            except OSError:
                pass  # only a cut-short episode; a finished one's failure is reported

    def close(self) -> None:
        """Stop, record the episode under way, free the simulator."""
        self.pause()
        with self._lock:
            self._end_cut_short()
            if self.env is not None:
                self.env.close()
                self.env = None
