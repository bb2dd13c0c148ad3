"""Other views of the vector env: gymnasium's Env and VectorEnv (gymnasium_env.py, which
registers assetgen/PegInHole-v0) and torch tensors (torch_env.py)."""
