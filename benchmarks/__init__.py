"""Checks of the learning code outside the test suite: pendulum.py trains PPO or SAC on
gymnasium's Pendulum-v1 through the shared runner and reports whether it is solved."""
