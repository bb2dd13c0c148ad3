"""Reinforcement learning on the vector-env contract (rl/vec_env.py): PPO, SAC, a random
agent, observation stacking, a shared runner (logging, checkpoints, exact resume), the
evaluation protocol and the `train`, `eval --checkpoint` and `report` commands. rl/ never
imports the simulator.
"""
