"""The policy that sees, trained and evaluated: DAgger students of a privileged teacher.

    python -m benchmarks.vision train --seed S [--minutes 40] [--teacher checkpoints/sac-direct-bc]
    python -m benchmarks.vision eval --seed S [--dataset test] [--attempts 10]

train: rl/student/dagger.py's distil on the train split for --minutes of wall clock, one torch
thread and one simulator thread, into runs/vision/student-sS (resumes nothing: a new run).
eval: the paper's protocol on --dataset (every module x --attempts, noise on) for that run's
student; writes docs/results/vision/student-sS_<dataset>.json, which the results page reads.
"""

from __future__ import annotations

import argparse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "runs" / "vision"
RESULTS = ROOT / "docs" / "results" / "vision"
TEACHER = "checkpoints/sac-direct-bc"


def run_dir(seed: int) -> Path:
    return RUNS / f"student-s{seed}"


def main(argv: list[str] | None = None) -> None:
    import torch

    ap = argparse.ArgumentParser(prog="python -m benchmarks.vision", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("what", choices=("train", "eval"))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--minutes", type=float, default=40.0)
    ap.add_argument("--teacher", default=TEACHER)
    ap.add_argument("--dataset", default="test")
    ap.add_argument("--attempts", type=int, default=10)
    a = ap.parse_args(argv)
    torch.set_num_threads(1)
    if a.what == "train":
        from rl.student.dagger import distill

        def show(row: dict) -> None:
            print(f"iteration {row['iteration']:3d} · {row['env_steps'] / 1e3:7.1f} k env steps"
                  f" · {row['wall_s'] / 60:5.1f} min · beta {row['beta']:.3f} · loss "
                  f"{row['loss']:.4f} · student success {row['student_success_rate']:.3f} "
                  f"({row['student_episodes']} episodes)", flush=True)  # fmt: skip

        distill(a.teacher, "train", run_dir(a.seed), a.minutes, a.seed, progress=show)
    else:
        from assetgen.core.atomic_file import strict_json, write_json
        from rl.student.dagger import evaluate_student

        res = evaluate_student(run_dir(a.seed), a.dataset, a.attempts, seed=a.seed)
        res["run"] = f"runs/vision/student-s{a.seed}"
        out = write_json(RESULTS / f"student-s{a.seed}_{a.dataset}.json", strict_json(res))
        print(
            f"{out}: {100 * res['success_rate']:.2f} % of {res['episodes']} episodes, "
            f"median {res['median_time_to_success_s']:.2f} s, {res['seconds']:.0f} s"
        )


if __name__ == "__main__":
    main()
