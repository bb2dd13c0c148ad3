"""Reinforcement learning on the vector-env contract (rl/vec_env.py): PPO, SAC, DreamerV3, a
random agent, observation stacking, a shared runner (logging, checkpoints, exact resume), the
report, and the `train`, `report` and `export` commands. rl/ never imports the simulator or
the evaluation (evaluation/ uses rl, not the other way round).
"""
