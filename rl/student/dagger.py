"""DAgger (Ross, Gordon and Bagnell 2011) from a privileged teacher to a student that sees.

The teacher is a trained checkpoint that observes the paper's 18-D pose of the peg relative
to the hole. The student observes a depth image and the peg's own pose in the module frame
(the env's "peg" reading: what an arm knows of its hand), never the hole's. Each iteration
plays `collect_steps` vector steps, the teacher driving a share beta of the episodes (all of
them in the first iteration, then beta_decay^i) and the student the rest; every frame, whoever
drove it, is stored with the teacher's action for it, and the student regresses the
aggregated frames (mean squared error) for `grad_steps` steps. So the student learns to
recover from the states its own mistakes lead to, which behaviour cloning of the teacher's
episodes alone never shows it.

The env is the caller's (a vector env made with the "peg" reading and a depth camera:
benchmarks/vision.py), so the agents stay apart from the simulator. A run folder holds
`student.safetensors` (the weights and, in its metadata, the settings, the camera, the
teacher and the counters; rewritten atomically after every iteration) and `metrics.csv` (one
row an iteration).
"""

from __future__ import annotations

import csv
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import torch

from rl import checkpoint as ckpt
from rl.student.config import StudentConfig
from rl.student.net import VisionPolicy
from rl.student.symmetry import half_turn_symmetric, nearest_seat

FILE_NAME = "student.safetensors"
READINGS = ("peg",)
"""What the student reads besides its camera."""
METRICS = ("iteration", "env_steps", "wall_s", "beta", "frames", "loss", "student_episodes",
           "student_success_rate")  # fmt: skip


def camera_record(env: Any) -> dict[str, Any]:
    """The env's camera (TaskConfig.camera) as a plain record, as the student keeps it."""
    camera = getattr(env.cfg, "camera", None)
    if camera is None:
        raise ValueError("the student sees: make its env with a camera (TaskConfig.camera)")
    return asdict(camera)


def _columns(env: Any, camera: dict[str, Any]) -> tuple[slice, slice]:
    """The columns of `env`'s observation the student reads: the peg reading's and the depth
    channel of its camera's image (the last channel of depth and rgbd)."""
    layout = {name: (cols, shape) for name, cols, shape in env.observation_layout()}
    name = f"camera_{camera['view']}_{camera['modality']}"
    if "peg" not in layout or name not in layout or camera["modality"] == "rgb":
        raise ValueError(
            f"the env's observation has {sorted(layout)}: the student needs 'peg' and a depth "
            f"camera's image (readings={READINGS}, a camera with depth or rgbd)"
        )
    cols, (channels, height, width) = layout[name]
    first = cols.start + (channels - 1) * height * width
    return layout["peg"][0], slice(first, first + height * width)


class Student:
    """The student's network, its camera and the columns it reads: `act(obs)` -> actions."""

    def __init__(self, cfg: StudentConfig, camera: dict[str, Any]) -> None:
        self.cfg = cfg.validate()
        self.camera = dict(camera)
        c = self.camera
        self.net = VisionPolicy(c["height"], c["width"], c["far"], cfg.feature_dim, cfg.hidden)
        self.cols: tuple[slice, slice] | None = None

    def bind(self, env: Any) -> Student:
        """Read the columns of `env`'s observations; ValueError for an env whose camera is
        not the student's."""
        if camera_record(env) != self.camera:
            raise ValueError(
                f"the env's camera {camera_record(env)} is not the student's {self.camera}: "
                "make the env with the student's camera"
            )
        self.cols = _columns(env, self.camera)
        return self

    def inputs(self, obs: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
        peg, depth = self.cols
        image = torch.from_numpy(np.ascontiguousarray(obs[:, depth], dtype=np.float32))
        pose = torch.from_numpy(np.ascontiguousarray(obs[:, peg], dtype=np.float32))
        return image.view(-1, 1, self.camera["height"], self.camera["width"]), pose

    @torch.no_grad()
    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.net(*self.inputs(obs)).numpy()

    def save(self, path: Path, doc: dict[str, Any]) -> None:
        tensors = {f"net/{k}": v for k, v in self.net.state_dict().items()}
        ckpt.save(path, tensors, {"student": asdict(self.cfg), "camera": self.camera, **doc})

    @classmethod
    def load(cls, run: str | Path) -> tuple[Student, dict[str, Any]]:
        """(the student, its checkpoint's document) from a run folder or its file."""
        path = Path(run)
        path = path / FILE_NAME if path.is_dir() else path
        tensors, doc = ckpt.load(path)
        if "student" not in doc:
            raise ckpt.CheckpointError(f"{path} is a checkpoint, but not a student's")

        def tuples(d: dict[str, Any]) -> dict[str, Any]:  # JSON's lists back to tuples
            return {k: tuple(v) if isinstance(v, list) else v for k, v in d.items()}

        student = cls(StudentConfig(**tuples(doc["student"])), tuples(doc["camera"]))
        student.net.load_state_dict({k[4:]: v for k, v in tensors.items() if k.startswith("net/")})
        student.net.eval()
        return student, doc


def teacher_view(env: Any, cfg: StudentConfig) -> Callable[[np.ndarray], np.ndarray]:
    """obs (n, obs_dim) of `env` -> what the teacher observes (n, 18): the pose, with the
    nearest look-alike seat where cfg.nearest_seat (rl/student/symmetry.py)."""
    if not cfg.nearest_seat:
        return lambda obs: obs[:, :18]
    symmetric = np.array([half_turn_symmetric(m.peg) for m in env.modules])
    return lambda obs: nearest_seat(obs[:, :18], symmetric[env.env_module])


def load_teacher(teacher: str | Path) -> Any:
    """The teacher agent of a checkpoint: a policy on the 18-D pose alone."""
    from rl.run_state import load_agent

    agent, meta = load_agent(teacher, "cpu")
    if meta["obs_dim"] != 18 or int(meta.get("stack", 1)) != 1:
        raise ValueError(
            f"teacher {teacher}: a policy on the 18-D pose alone (obs_dim {meta['obs_dim']}, "
            f"stack {meta.get('stack', 1)}); give one trained without readings or a stack"
        )
    return agent


def distill(
    teacher: str | Path,
    env: Any,
    out: str | Path,
    minutes: float,
    seed: int = 0,
    cfg: StudentConfig | None = None,
    progress: Callable[[dict[str, float]], None] | None = None,
) -> dict[str, Any]:
    """Distil the checkpoint `teacher` into a student on the training env `env` (made with
    READINGS and a depth camera) for `minutes` of wall clock (whole iterations; at least one);
    writes the run folder `out` (see the module doc) and returns the last metrics row."""
    cfg = (cfg or StudentConfig()).validate()
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    agent = load_teacher(teacher)
    student = Student(cfg, camera_record(env)).bind(env)
    teacher_obs = teacher_view(env, cfg)
    opt = torch.optim.Adam(student.net.parameters(), lr=cfg.learning_rate)
    c, n_env = student.camera, env.num_envs
    images = np.zeros((cfg.buffer_size, 1, c["height"], c["width"]), dtype=np.float16)
    poses = np.zeros((cfg.buffer_size, 9), dtype=np.float32)
    labels = np.zeros((cfg.buffer_size, 6), dtype=np.float32)
    stored = head = 0
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    metrics = out / "metrics.csv"
    with open(metrics, "w", newline="") as f:
        csv.writer(f).writerow(METRICS)
    obs = env.reset(seed=seed)
    teacher_drives = np.ones(n_env, dtype=bool)
    t0, env_steps, it, row = time.perf_counter(), 0, 0, {}
    while it == 0 or time.perf_counter() - t0 < 60.0 * minutes:
        beta = cfg.beta_decay**it
        episodes = successes = 0
        student.net.eval()
        for _ in range(cfg.collect_steps):
            expert = np.clip(agent.policy(teacher_obs(obs), deterministic=True), -1.0, 1.0)
            image, pose = student.inputs(obs)
            rows = (head + np.arange(n_env)) % cfg.buffer_size
            images[rows], poses[rows], labels[rows] = image.numpy(), pose.numpy(), expert
            head, stored = (head + n_env) % cfg.buffer_size, min(stored + n_env, cfg.buffer_size)
            action = expert
            if not teacher_drives.all():
                with torch.no_grad():
                    own = student.net(image, pose).numpy()
                action = np.where(teacher_drives[:, None], expert, own)
            obs, _, terminated, truncated, info = env.step(action)
            env_steps += n_env
            done = terminated | truncated
            counted = done & ~teacher_drives
            episodes += int(counted.sum())
            successes += int((info["success"] & counted).sum())
            # a new episode's driver: the teacher with probability beta (the next
            # iteration's, for the first one's last episodes too)
            teacher_drives[done] = rng.random(int(done.sum())) < cfg.beta_decay ** (it + 1)
        student.net.train()
        losses = []
        for _ in range(cfg.grad_steps):
            pick = rng.integers(0, stored, cfg.batch_size)
            x = torch.from_numpy(images[pick].astype(np.float32))
            loss = torch.mean((student.net(x, torch.from_numpy(poses[pick]))
                               - torch.from_numpy(labels[pick])) ** 2)  # fmt: skip
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            losses.append(float(loss.detach()))
        row = {
            "iteration": it,
            "env_steps": env_steps,
            "wall_s": time.perf_counter() - t0,
            "beta": beta,
            "frames": stored,
            "loss": float(np.mean(losses)),
            "student_episodes": episodes,
            "student_success_rate": successes / episodes if episodes else float("nan"),
        }
        with open(metrics, "a", newline="") as f:
            csv.writer(f).writerow([row[k] for k in METRICS])
        student.net.eval()
        student.save(out / FILE_NAME, {"teacher": str(teacher), "seed": seed, **row})
        if progress is not None:
            progress(row)
        it += 1
    return row
