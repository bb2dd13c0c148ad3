"""The paper's protocol for a student that sees (rl/student): its env is made with the
student's camera and the peg reading, and it plays through evaluation/protocol.py's loop."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def student_env(student: Any, dataset: str, seed: int, modules: int | None = None) -> Any:
    """An evaluation env (noise on, one env per module) that shows `student` (rl/student) what
    it reads: its camera and the peg reading; the student is bound to it."""
    from rl.student.dagger import READINGS
    from sim.cameras.config import CameraConfig
    from sim.env import make_eval_env

    env = make_eval_env(dataset, None, seed, modules=modules, readings=READINGS,
                        camera=CameraConfig(**student.camera))  # fmt: skip
    student.bind(env)
    return env


def evaluate_student(
    run: str | Path, dataset: str, attempts: int, seed: int = 0, modules: int | None = None
) -> dict[str, Any]:
    """One env per module of `dataset` (its first `modules`), `attempts` episodes each, noise
    on, for the student in `run`: evaluation/protocol.py's result with the protocol's fields
    and the student's teacher and training steps."""
    from evaluation.protocol import evaluate
    from evaluation.recording import env_labels
    from rl.student.dagger import Student

    student, doc = Student.load(run)
    env = student_env(student, dataset, seed, modules)
    res = evaluate(student.act, env, attempts, seed=seed, labels=env_labels(env),
                   live=getattr(env, "set_live", None))  # fmt: skip
    env.close()
    head = {"algo": "student", "run": str(run), "teacher": doc["teacher"],
            "trained_env_steps": doc["env_steps"], "policy": "deterministic"}  # fmt: skip
    return {**head, **env.protocol, "attempts": attempts, "seed": seed, **res}
