"""MuJoCo Warp, the simulator's physics on a GPU: the batched stepping (batch.py) and the
vector env whose task arithmetic also stays on the device (env.py)."""
