"""The cameras measured and shown: what an image costs, and what each camera sees in an episode.

    python -m benchmarks.cameras cost [--dataset test] [--envs 32] [--steps 100]
    python -m benchmarks.cameras strip [--dataset test] [--module 0] [--out FILE]

cost: one env of `--envs` envs without a camera and one with each of the wrist and fixed
cameras (depth, 64 x 64, noise on), the same modules and the same random actions, stepped
`--steps` control steps each in turns of 10 (so a machine's drift hits all alike), in one run;
prints env steps per second of each, their ratio to the env without a camera, and the
renderer's milliseconds per image alone. One simulator thread (MuJoCo's), as a training run.
strip: the direct scripted expert's episode on one module from the evaluation's spawn, both
cameras in RGB and depth, every 10th control step: a PNG (docs/images/camera_strip.png).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from sim.cameras.config import CameraConfig

ROOT = Path(__file__).resolve().parents[1]


def cost(dataset: str, envs: int, steps: int) -> dict:
    from sim.env import PegInHoleVecEnv, train_config

    root, task = train_config(dataset, curriculum_steps=0)
    cameras = {"none": None, "wrist": CameraConfig(), "fixed": CameraConfig(view="fixed")}
    made = {
        name: PegInHoleVecEnv(root, envs, replace(task, camera=cam), nthread=1)
        for name, cam in cameras.items()
    }
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.2, 0.2, (steps, envs, 6))
    seconds = dict.fromkeys(made, 0.0)
    for env in made.values():
        env.reset(seed=0)
        env.step(actions[0])  # untimed: the first images build each module's scene
    for start in range(0, steps, 10):
        for name, env in made.items():
            t = time.perf_counter()
            for a in actions[start : start + 10]:
                env.step(a)
            seconds[name] += time.perf_counter() - t
    out = {"envs": envs, "steps": steps}
    for name, env in made.items():
        rate = envs * steps / seconds[name]
        out[name] = {"env_steps_per_s": rate, "ratio": rate * seconds["none"] / (envs * steps)}
        if env.camera is not None:
            idx = np.arange(envs)
            t = time.perf_counter()
            for _ in range(10):
                env.camera.render(env.env_module, env.sim.peg_pos[idx], env.sim.peg_quat[idx])
            out[name]["ms_per_image"] = 1e3 * (time.perf_counter() - t) / (10 * envs)
        env.close()
    return out


def strip(dataset: str, module: int, out: Path, every: int = 10) -> Path:
    from PIL import Image

    from sim.env import make_eval_env
    from sim.task.expert import direct_expert_action

    views = [CameraConfig(view=v, modality="rgbd", depth_noise=0.0) for v in ("wrist", "fixed")]
    envs = [make_eval_env(dataset, None, 0, modules=module + 1, camera=c) for c in views]
    frames: list[list[np.ndarray]] = [[] for _ in views]
    obs = [env.reset(seed=0) for env in envs]
    parts = [env.observation_layout()[-1][1] for env in envs]  # the image's columns
    for _step in range(envs[0].cfg.max_steps):
        for j, env in enumerate(envs):
            frames[j].append(obs[j][module, parts[j]].reshape(env.cfg.camera.shape))
        action = direct_expert_action(obs[0][:, :18])
        done = False
        for j, env in enumerate(envs):
            obs[j], _, terminated, truncated, _ = env.step(action)
            done |= bool(terminated[module] or truncated[module])
        if done:
            break
    for env in envs:
        env.close()
    rows = []
    for shots in frames:
        picked = shots[::every] + ([shots[-1]] if (len(shots) - 1) % every else [])
        rgb = np.concatenate([s[:3].transpose(1, 2, 0) for s in picked], axis=1)
        depth = np.concatenate([s[3] for s in picked], axis=1)
        # near is white, far is black, over the depths this strip shows
        lo, hi = float(depth.min()), float(depth.max())
        grey = 1.0 - (depth - lo) / max(hi - lo, 1e-9)
        rows += [rgb, np.repeat(grey[..., None], 3, axis=2)]
    image = (np.concatenate(rows, axis=0) * 255).round().astype(np.uint8)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp.png")
    Image.fromarray(image).resize((image.shape[1] * 2, image.shape[0] * 2), Image.NEAREST).save(tmp)
    tmp.replace(out)
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.cameras", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("what", choices=("cost", "strip"))
    ap.add_argument("--dataset", default="test")
    ap.add_argument("--envs", type=int, default=32)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--module", type=int, default=0, help="strip: the dataset's module index")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "images" / "camera_strip.png")
    a = ap.parse_args(argv)
    if a.what == "cost":
        r = cost(a.dataset, a.envs, a.steps)
        print(f"{a.dataset}, {r['envs']} envs, {r['steps']} control steps each, one thread")
        for name in ("none", "wrist", "fixed"):
            f = r[name]
            ms = f" · {f['ms_per_image']:.2f} ms an image" if "ms_per_image" in f else ""
            print(f"  camera {name:5s}: {f['env_steps_per_s']:7.0f} env steps/s "
                  f"({f['ratio']:.2f} of none){ms}")  # fmt: skip
    else:
        print(strip(a.dataset, a.module, a.out))


if __name__ == "__main__":
    main()
