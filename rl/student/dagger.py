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

A run folder holds `student.safetensors` (the weights and, in its metadata, the settings,
the teacher and the counters; rewritten atomically after every iteration) and `metrics.csv`
(one row an iteration).
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
from sim.cameras.config import CameraConfig

FILE_NAME = "student.safetensors"
READINGS = ("peg",)
"""What the student reads besides its camera."""
METRICS = ("iteration", "env_steps", "wall_s", "beta", "frames", "loss", "student_episodes",
           "student_success_rate")  # fmt: skip


def _parts(env: Any, cfg: StudentConfig) -> tuple[slice, slice]:
    """The columns of the observation the student reads: the peg reading's and the depth
    channel of its camera's image."""
    layout = {name: cols for name, cols, _ in env.observation_layout()}
    name = f"camera_{cfg.camera.view}_{cfg.camera.modality}"
    if "peg" not in layout or name not in layout:
        raise ValueError(
            f"the env's observation has {sorted(layout)}: the student needs 'peg' and {name!r} "
            f"(readings={READINGS}, camera={cfg.camera})"
        )
    cam = layout[name]
    pixels = cfg.camera.height * cfg.camera.width
    first = cam.start + cfg.camera.channels.index("depth") * pixels
    return layout["peg"], slice(first, first + pixels)


class Student:
    """The student's network and the columns it reads: `act(obs)` -> (N, 6) actions."""

    def __init__(self, cfg: StudentConfig, net: VisionPolicy | None = None) -> None:
        self.cfg = cfg.validate()
        c = cfg.camera
        self.net = net or VisionPolicy(c.height, c.width, c.far, cfg.feature_dim, cfg.hidden)
        self.cols: tuple[slice, slice] | None = None

    def bind(self, env: Any) -> Student:
        """Read the columns of `env`'s observations (one made with READINGS and the camera)."""
        self.cols = _parts(env, self.cfg)
        return self

    def inputs(self, obs: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
        peg, depth = self.cols
        c = self.cfg.camera
        image = torch.from_numpy(np.ascontiguousarray(obs[:, depth], dtype=np.float32))
        pose = torch.from_numpy(np.ascontiguousarray(obs[:, peg], dtype=np.float32))
        return image.view(-1, 1, c.height, c.width), pose

    @torch.no_grad()
    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.net(*self.inputs(obs)).numpy()

    def save(self, path: Path, doc: dict[str, Any]) -> None:
        tensors = {f"net/{k}": v for k, v in self.net.state_dict().items()}
        ckpt.save(path, tensors, {"student": asdict(self.cfg), **doc})

    @classmethod
    def load(cls, run: str | Path) -> tuple[Student, dict[str, Any]]:
        """(the student, its checkpoint's document) from a run folder or its file."""
        path = Path(run)
        path = path / FILE_NAME if path.is_dir() else path
        tensors, doc = ckpt.load(path)
        if "student" not in doc:
            raise ckpt.CheckpointError(f"{path} is a checkpoint, but not a student's")
        d = dict(doc["student"])
        cam = d.pop("camera")
        cam = CameraConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in cam.items()})
        cfg = StudentConfig(camera=cam, **{k: tuple(v) if isinstance(v, list) else v
                                           for k, v in d.items()})  # fmt: skip
        student = cls(cfg)
        student.net.load_state_dict({k[4:]: v for k, v in tensors.items() if k.startswith("net/")})
        student.net.eval()
        return student, doc


def distill(
    teacher: str | Path,
    dataset: str,
    out: str | Path,
    minutes: float,
    seed: int = 0,
    cfg: StudentConfig | None = None,
    progress: Callable[[dict[str, float]], None] | None = None,
) -> dict[str, Any]:
    """Distil the checkpoint `teacher` (a policy on the 18-D pose) into a student on `dataset`
    for `minutes` of wall clock (whole iterations; at least one); writes the run folder `out`
    (see the module doc) and returns the last metrics row."""
    from rl.run_state import load_agent
    from sim.env import make_train_env

    cfg = (cfg or StudentConfig()).validate()
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    agent, meta = load_agent(teacher, "cpu")
    if meta["obs_dim"] != 18 or int(meta.get("stack", 1)) != 1:
        raise ValueError(
            f"teacher {teacher}: a policy on the 18-D pose alone (obs_dim {meta['obs_dim']}, "
            f"stack {meta.get('stack', 1)}); give one trained without readings or a stack"
        )
    env = make_train_env(dataset, cfg.envs, seed, curriculum_steps=0, readings=READINGS,
                         camera=cfg.camera)  # fmt: skip
    student = Student(cfg).bind(env)
    opt = torch.optim.Adam(student.net.parameters(), lr=cfg.learning_rate)
    c, n_env = cfg.camera, cfg.envs
    images = np.zeros((cfg.buffer_size, 1, c.height, c.width), dtype=np.float16)
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
            expert = np.clip(agent.policy(obs[:, :18], deterministic=True), -1.0, 1.0)
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
        student.save(out / FILE_NAME, {"teacher": str(teacher), "dataset": dataset,
                                       "seed": seed, **row})  # fmt: skip
        if progress is not None:
            progress(row)
        it += 1
    env.close()
    return row


def evaluate_student(
    run: str | Path, dataset: str, attempts: int, seed: int = 0, modules: int | None = None
) -> dict[str, Any]:
    """The paper's protocol (one env per module, `attempts` episodes each, noise on) for the
    student in `run`: evaluation/protocol.py's result with the protocol's fields."""
    from evaluation.protocol import evaluate
    from evaluation.recording import env_labels
    from sim.env import make_eval_env

    student, doc = Student.load(run)
    env = make_eval_env(dataset, None, seed, modules=modules, readings=READINGS,
                        camera=student.cfg.camera)  # fmt: skip
    student.bind(env)
    res = evaluate(student.act, env, attempts, seed=seed, labels=env_labels(env),
                   live=getattr(env, "set_live", None))  # fmt: skip
    env.close()
    head = {"algo": "student", "run": str(run), "teacher": doc["teacher"],
            "trained_env_steps": doc["env_steps"], "policy": "deterministic"}  # fmt: skip
    return {**head, **env.protocol, "attempts": attempts, "seed": seed, **res}
