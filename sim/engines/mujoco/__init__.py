"""MuJoCo on the CPU, the simulator: the scene of one or more envs (scene.py) and the
batched stepping over per-env models (batch.py)."""
