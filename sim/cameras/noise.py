"""A depth sensor's errors on rendered images: Gaussian noise on every depth pixel and
dropped returns (pixels that read 0), drawn anew for every frame. RGB is left as rendered."""

from __future__ import annotations

import numpy as np

from sim.cameras.config import CameraConfig


def corrupt(images: np.ndarray, cfg: CameraConfig, rng: np.random.Generator) -> np.ndarray:
    """`images` (k, channels, height, width) with cfg's depth noise and dropout on the depth
    channel (in place, and returned); nothing is drawn for a camera without depth, nor for a
    noise or dropout of 0. A noisy depth stays within [0, far]."""
    if "depth" not in cfg.channels:
        return images
    depth = images[:, cfg.channels.index("depth")]
    if cfg.depth_noise > 0:
        depth += (cfg.depth_noise * rng.standard_normal(depth.shape)).astype(np.float32)
        np.clip(depth, 0.0, cfg.far, out=depth)
    if cfg.depth_dropout > 0:
        depth[rng.random(depth.shape) < cfg.depth_dropout] = 0.0
    return images
