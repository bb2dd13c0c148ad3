"""Batched MuJoCo simulation of the peg-in-hole task over a dataset of modules.

    from sim import PegInHoleVecEnv, TaskConfig
    env = PegInHoleVecEnv("datasets/test", num_envs=1024, config=TaskConfig())
    obs = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(actions)

Files: config.py (the task's numbers), assets.py (module.json + STL only), scene.py (MJCF
model of one or more envs), batch.py (mujoco.rollout over per-env models), task.py
(observation, reward, success, failure, spawn), step_kernel.py (the per-step arithmetic,
compiled), env.py (the vector env), expert.py (a scripted expert), recording.py (episodes
for the preview), bench.py (throughput), gym_adapter.py / torch_adapter.py (gymnasium and
torch views), usd_module.py / physx_config.py / physx_batch.py (PhysX, the referee engine).
"""

from sim.assets.loading import AssetError, load_dataset, load_module
from sim.task.config import EVAL_CONFIG, PhysicsConfig, TaskConfig
from sim.env import PegInHoleVecEnv, make_eval_env, make_train_env

__all__ = [
    "EVAL_CONFIG",
    "AssetError",
    "PegInHoleVecEnv",
    "PhysicsConfig",
    "TaskConfig",
    "load_dataset",
    "load_module",
    "make_eval_env",
    "make_train_env",
]
