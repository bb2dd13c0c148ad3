"""The contact stress benchmark: how hard and how still an engine's contacts are for a module.

    assetgen bench contacts DATASET [--limit N] [--set FIELD=VALUE ...] [--source sim|mjcf]

The same runs on every engine: the cases (cases.py: the runs of a module), the figures
(figures.py: a run's record, the summaries, the contact targets), one runner per
engine (mujoco.py, physx.py, warp.py; sim/engines/registry.py names each) and the command
(command.py: `main`, which sim/bench/command.py calls).
"""
