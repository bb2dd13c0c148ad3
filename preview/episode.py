"""Recorded episodes (.npz) for replay: loading, validation against the dataset shown.

An episode file holds
    module_id  str         id of the module the episode ran on
    poses      (T, 7)      peg frame per control step in the module frame: position (m) and
                           quaternion (w, x, y, z)
    reward     (T,)        reward per step
    success    bool        whether the episode ended inserted
    dt         float       seconds per step (optional: DEFAULT_DT_S when absent, with a note)
    spawn_pose (7,)        optional: the pose before the first step; replayed as step 0
"""

from __future__ import annotations

import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from assetgen.dataset.reader import Dataset
from preview.scene import ModuleView, PreviewError

DEFAULT_DT_S = 0.02
"""Seconds per step assumed for an episode without `dt`: the simulator's 50 Hz control."""
FAR_FROM_MODULE_M = 0.5
"""A peg position this far (metres) from the module origin cannot belong to this module's
frame: the file was recorded in another frame, or is not an episode of this dataset."""
SEATED_TOLERANCE_M = 0.01
"""A successful episode must end with the peg frame within this distance (metres) of the
hole axis segment between bottom frame and entrance; else it ran on another module."""
REQUIRED = ("module_id", "poses", "reward", "success")
UNREADABLE = (zipfile.BadZipFile, zlib.error)
"""Raised by np.load on a truncated or bit-flipped .npz (besides OSError / ValueError)."""


@dataclass(frozen=True)
class Episode:
    """A validated episode, ready to replay."""

    path: Path
    module_id: str
    poses: np.ndarray
    """(T, 7) float64: peg position (m) and unit quaternion wxyz, module frame."""
    reward: np.ndarray
    """(T,) float64 reward per step (0 for a prepended spawn pose)."""
    success: bool
    dt: float
    """Seconds per step."""
    notes: tuple[str, ...] = field(default=())
    """Warnings found while loading (shown beside the timeline)."""

    @property
    def steps(self) -> int:
        return len(self.poses)

    @property
    def duration_s(self) -> float:
        return (self.steps - 1) * self.dt

    @property
    def returns(self) -> np.ndarray:
        """(T,) cumulative reward up to and including each step."""
        return np.cumsum(self.reward)


def _scalar(z: np.lib.npyio.NpzFile, key: str) -> np.ndarray:
    v = np.asarray(z[key])
    if v.size != 1:
        raise PreviewError(f"key {key!r} should hold one value, not shape {v.shape}")
    return v.reshape(())


def load_episode(path: str | Path, ds: Dataset) -> Episode:
    """Read and check an episode .npz against dataset `ds`.

    Raises PreviewError naming the problem: missing file, not an .npz, missing keys, wrong
    shapes, non-finite values, a module id that is not in `ds` (recorded on another
    dataset), poses far outside the module.
    """
    path = Path(path)
    if not path.is_file():
        raise PreviewError(f"episode file {path} does not exist")
    try:
        with np.load(path, allow_pickle=False) as z:
            missing = [k for k in REQUIRED if k not in z.files]
            if missing:
                raise PreviewError(
                    f"{path} is not an episode: missing key(s) {missing} (has {sorted(z.files)}); "
                    f"an episode needs {list(REQUIRED)} and optionally 'dt', 'spawn_pose'"
                )
            mid = _scalar(z, "module_id").item()
            module_id = mid.decode() if isinstance(mid, bytes) else str(mid)
            poses = np.asarray(z["poses"], dtype=np.float64)
            reward = np.asarray(z["reward"], dtype=np.float64).reshape(-1)
            success = bool(_scalar(z, "success"))
            dt = float(_scalar(z, "dt")) if "dt" in z.files else None
            spawn = None
            if "spawn_pose" in z.files:
                spawn = np.asarray(z["spawn_pose"], dtype=np.float64)
    except PreviewError as e:
        if str(path) in str(e):
            raise
        raise PreviewError(f"{path}: {e}") from e
    except (OSError, ValueError, EOFError, KeyError, TypeError, *UNREADABLE) as e:
        raise PreviewError(
            f"{path} is not a readable .npz episode ({type(e).__name__}: {e}); "
            "record one with `assetgen eval --record DIR`"
        ) from e
    notes: list[str] = []
    if poses.ndim != 2 or poses.shape[1] != 7 or len(poses) < 1:
        raise PreviewError(
            f"{path}: poses has shape {poses.shape}; expected (T, 7) with T >= 1 "
            "(position in metres, quaternion w x y z)"
        )
    if len(reward) != len(poses):
        raise PreviewError(
            f"{path}: reward has {len(reward)} values but poses has {len(poses)} steps"
        )
    if spawn is not None:
        if spawn.shape != (7,):
            raise PreviewError(f"{path}: spawn_pose has shape {spawn.shape}; expected (7,)")
        poses = np.concatenate([spawn[None], poses])
        reward = np.concatenate([[0.0], reward])
    if not (np.isfinite(poses).all() and np.isfinite(reward).all()):
        raise PreviewError(f"{path}: poses or reward hold NaN or infinite values")
    qn = np.linalg.norm(poses[:, 3:], axis=1)
    if (qn < 1e-6).any():
        raise PreviewError(f"{path}: step {int(np.argmin(qn))} has a zero quaternion")
    poses[:, 3:] /= qn[:, None]
    if dt is None:
        dt = DEFAULT_DT_S
        notes.append(f"no 'dt' in the file: assuming {dt} s per step (50 Hz control)")
    if not (np.isfinite(dt) and dt > 0):
        raise PreviewError(f"{path}: dt = {dt} s; it must be a positive number of seconds")
    if module_id not in ds.records:
        ids = ds.ids
        raise PreviewError(
            f"{path} was recorded on module {module_id!r}, which is not in {ds.root} "
            f"(ids {ids[0]} .. {ids[-1]}): it comes from another dataset; open that dataset"
        )
    far = float(np.abs(poses[:, :3]).max())
    if far > FAR_FROM_MODULE_M:
        raise PreviewError(
            f"{path}: peg positions reach {far:.2f} m from the module origin; poses must be "
            "in the module frame (metres) of a module of this dataset"
        )
    return Episode(path, module_id, poses, reward, success, dt, tuple(notes))


def fit_notes(ep: Episode, view: ModuleView) -> list[str]:
    """Warnings when the episode does not fit the module geometry it claims (e.g. same id in
    another dataset): a success that does not end near the hole axis."""
    if not ep.success:
        return []
    bottom = np.asarray(view.frames["bottom"].pos)
    entrance = np.asarray(view.frames["entrance"].pos)
    axis = view.hole_axis
    end = ep.poses[-1, :3]
    # Distance from the last position to the axis segment bottom -> entrance (+ clearance).
    t = float(np.clip((end - bottom) @ axis, 0.0, (entrance - bottom) @ axis))
    d = float(np.linalg.norm(end - (bottom + t * axis)))
    if d > SEATED_TOLERANCE_M:
        return [
            f"the episode reports success but ends {d * 1e3:.1f} mm from module {view.id}'s "
            "hole axis: it was probably recorded on another dataset with the same ids"
        ]
    return []
