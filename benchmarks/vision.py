"""The policy that sees, trained and measured: DAgger students of a privileged teacher.

    python -m benchmarks.vision train --seed S [--minutes 40] [--beta-decay 0.5] [--out DIR]
    python -m benchmarks.vision check --seed S [--modules 32] [--steps 150] [--out DIR]
    python -m benchmarks.vision eval --seed S [--dataset test] [--attempts 10] [--out DIR]

train: rl/student/dagger.py's distillation of checkpoints/sac-direct-bc on the train split
(--envs 32, the full spawn ranges, the wrist camera's depth at 64 x 64) for --minutes of wall
clock, one torch thread, into DIR (default
runs/vision/student-sS); --beta-decay near 1 keeps the teacher driving (behaviour cloning);
--own-seat labels with the seat's own frame (rl/student/symmetry.py: the default shows the
teacher the nearest seat that looks the same).
check: the student's actions against the teacher's on the teacher's own episodes (the teacher
drives) on the first --modules train modules: the mean squared difference per action
component over the first 30 control steps (the approach) and over the rest (at the hole),
and the teacher's success there.
eval: the paper's protocol on --dataset (every module x --attempts, noise on) for the
student; writes docs/results/vision/student-sS_<dataset>.json.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results" / "vision"
TEACHER = "checkpoints/sac-direct-bc"
APPROACH = 30
"""Control steps counted as the approach by `check`."""


def check(run: Path, teacher: str, modules: int, steps: int) -> dict:
    """The figures `check` prints (see the module doc)."""
    from evaluation.student import student_env
    from rl.student.dagger import Student, load_teacher, teacher_view

    student, _ = Student.load(run)
    agent = load_teacher(teacher)
    env = student_env(student, "train", 0, modules)
    teacher_obs = teacher_view(env, student.cfg)
    obs = env.reset(seed=0)
    errors, ended, won = [], np.zeros(env.num_envs, bool), np.zeros(env.num_envs, bool)
    for _ in range(steps):
        expert = np.clip(agent.policy(teacher_obs(obs), deterministic=True), -1.0, 1.0)
        live = ~ended
        errors.append(np.where(live, ((student.act(obs) - expert) ** 2).mean(1), np.nan))
        obs, _, terminated, truncated, info = env.step(expert)
        won |= info["success"] & live
        ended |= terminated | truncated
    env.close()
    e = np.array(errors)
    return {"approach": float(np.nanmean(e[:APPROACH])), "hole": float(np.nanmean(e[APPROACH:])),
            "teacher_success": float(won.mean()), "modules": modules}  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    import torch

    ap = argparse.ArgumentParser(prog="python -m benchmarks.vision", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("what", choices=("train", "check", "eval"))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--minutes", type=float, default=40.0)
    ap.add_argument("--beta-decay", type=float, default=None)
    ap.add_argument(
        "--own-seat",
        action="store_true",
        help="train: label with the seat's own frame, not the nearest look-alike",
    )
    ap.add_argument("--teacher", default=TEACHER)
    ap.add_argument("--dataset", default="test")
    ap.add_argument("--attempts", type=int, default=10)
    ap.add_argument("--modules", type=int, default=32)
    ap.add_argument("--envs", type=int, default=32, help="train: training envs")
    ap.add_argument("--steps", type=int, default=150)
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    run = a.out or ROOT / "runs" / "vision" / f"student-s{a.seed}"
    torch.set_num_threads(1)
    if a.what == "train":
        from rl.student.config import StudentConfig
        from rl.student.dagger import READINGS, distill
        from sim.cameras.config import CameraConfig
        from sim.env import make_train_env

        def show(row: dict) -> None:
            print(f"iteration {row['iteration']:3d} · {row['env_steps'] / 1e3:7.1f} k env steps"
                  f" · {row['wall_s'] / 60:5.1f} min · beta {row['beta']:.3f} · loss "
                  f"{row['loss']:.4f} · student success {row['student_success_rate']:.3f} "
                  f"({row['student_episodes']} episodes)", flush=True)  # fmt: skip

        cfg = StudentConfig(nearest_seat=not a.own_seat)
        if a.beta_decay is not None:
            cfg = replace(cfg, beta_decay=a.beta_decay)
        env = make_train_env("train", a.envs, a.seed, curriculum_steps=0, readings=READINGS,
                             camera=CameraConfig())  # fmt: skip
        distill(a.teacher, env, run, a.minutes, a.seed, cfg, progress=show)
        env.close()
    elif a.what == "check":
        r = check(run, a.teacher, a.modules, a.steps)
        print(f"{run}: on the teacher's episodes of {r['modules']} train modules (teacher "
              f"success {100 * r['teacher_success']:.1f} %), mean squared action difference "
              f"{r['approach']:.4f} over the first {APPROACH} steps, "
              f"{r['hole']:.4f} after")  # fmt: skip
    else:
        from assetgen.core.atomic_file import strict_json, write_json
        from evaluation.student import evaluate_student

        res = evaluate_student(run, a.dataset, a.attempts, seed=a.seed)
        out = write_json(RESULTS / f"student-s{a.seed}_{a.dataset}.json", strict_json(res))
        print(
            f"{out}: {100 * res['success_rate']:.2f} % of {res['episodes']} episodes, "
            f"median {res['median_time_to_success_s']:.2f} s, {res['seconds']:.0f} s"
        )


if __name__ == "__main__":
    main()
