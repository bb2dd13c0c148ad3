"""What a camera sees and how: its view, its image, its intrinsics and its noise.

Two views. `wrist` rides on the peg's holder: a camera fixed in the peg frame above the peg's
top, looking down past it at its tip (where a robot holds the peg, its hand carries it the same
way, since the grasp is rigid). `fixed` stands in the module frame and looks at the plate.

Images are pinhole projections with square pixels and the principal point at the image's
centre. Depth is the distance along the optical axis (z-depth, m), clipped to [near, far]:
the background, and anything beyond `far`, reads `far`. RGB is in [0, 1].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

VIEWS = ("wrist", "fixed")
"""Where a camera can stand (see the module doc)."""
MODALITIES = {"depth": ("depth",), "rgb": ("red", "green", "blue"),
              "rgbd": ("red", "green", "blue", "depth")}  # fmt: skip
"""What a camera can render: its channels, in order."""


@dataclass(frozen=True)
class CameraConfig:
    """One camera of the env (sim.cameras.render draws it). Units: m, degrees, pixels."""

    view: str = "wrist"
    """"wrist" (on the peg's holder) or "fixed" (in the module frame)."""
    modality: str = "depth"
    """"depth", "rgb" or "rgbd" (MODALITIES)."""
    width: int = 64
    """Image width, pixels."""
    height: int = 64
    """Image height, pixels."""
    fovy: float = 60.0
    """Vertical field of view, degrees (the horizontal one follows from the aspect ratio)."""
    near: float = 0.01
    """Nearest depth rendered, m: nearer surfaces are clipped away."""
    far: float = 0.5
    """Farthest depth, m: the background and anything beyond read this."""
    wrist_offset: tuple[float, float, float] = (0.0, -0.1, 0.02)
    """The wrist camera's position relative to the centre of the peg's top face, peg frame
    (the holder's side, above the peg), m."""
    wrist_look_below: float = 0.01
    """The wrist camera looks at the point this far below the peg's tip on its axis, m."""
    fixed_position: tuple[float, float, float] = (0.0, -0.2, 0.2)
    """The fixed camera's position in the module frame, m (the plate's top face is z = 0,
    its centre the origin)."""
    fixed_target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """The point the fixed camera looks at, module frame, m."""
    depth_noise: float = 0.0005
    """Std of the Gaussian noise added to each depth pixel, m (on where the task's noise is:
    training and the evaluation protocol)."""
    depth_dropout: float = 0.0
    """Share of depth pixels that return nothing (0, as depth sensors report a missing
    return), drawn anew each frame where the task's noise is on."""

    @property
    def channels(self) -> tuple[str, ...]:
        """The image's channels, in order."""
        return MODALITIES[self.modality]

    @property
    def shape(self) -> tuple[int, int, int]:
        """(channels, height, width) of one image."""
        return (len(self.channels), self.height, self.width)

    @property
    def size(self) -> int:
        """Values one image adds to the observation."""
        return int(np.prod(self.shape))

    def intrinsics(self) -> np.ndarray:
        """(3, 3) pinhole matrix K in pixels: a point (x, y, z) in the camera's optical frame
        (x right, y down, z along the view) lands at (u, v) = (fx x / z + cx, fy y / z + cy),
        pixel (i, j) spanning u in [i, i + 1) and v in [j, j + 1), row 0 at the top."""
        f = 0.5 * self.height / math.tan(math.radians(self.fovy) / 2)
        return np.array([[f, 0.0, self.width / 2], [0.0, f, self.height / 2], [0.0, 0.0, 1.0]])

    def validate(self) -> CameraConfig:
        """Self, or ValueError naming each value out of its range and the range."""
        bad = []
        if self.view not in VIEWS:
            bad.append(f"view = {self.view!r}: give one of {', '.join(VIEWS)}")
        if self.modality not in MODALITIES:
            bad.append(f"modality = {self.modality!r}: give one of {', '.join(MODALITIES)}")
        for name in ("width", "height"):
            v = getattr(self, name)
            if not (isinstance(v, int) and 8 <= v <= 1024):
                bad.append(f"{name} = {v!r}: give a whole number of pixels in [8, 1024]")
        if not (0.0 < self.fovy < 180.0):
            bad.append(f"fovy = {self.fovy!r}: give degrees in (0, 180)")
        if not (0.0 < self.near < self.far <= 10.0):
            bad.append(f"near = {self.near!r}, far = {self.far!r}: give 0 < near < far <= 10 m")
        if not (math.isfinite(self.depth_noise) and self.depth_noise >= 0.0):
            bad.append(f"depth_noise = {self.depth_noise!r}: give a std >= 0 m")
        if not (0.0 <= self.depth_dropout < 1.0):
            bad.append(f"depth_dropout = {self.depth_dropout!r}: give a share in [0, 1)")
        if not np.all(np.isfinite(self.wrist_offset + self.fixed_position + self.fixed_target)):
            bad.append("wrist_offset, fixed_position and fixed_target: give finite metres")
        elif np.allclose(self.fixed_position, self.fixed_target):
            bad.append("fixed_position = fixed_target: the camera needs a direction to look")
        if bad:
            raise ValueError("CameraConfig: " + "; ".join(bad))
        return self


def parse_camera(text: str) -> CameraConfig:
    """A CameraConfig from the command line's "VIEW[:MODALITY[:WIDTHxHEIGHT]]" (e.g. "wrist",
    "fixed:rgbd:128x96"); ValueError naming what does not parse."""
    parts = text.split(":")
    if not 1 <= len(parts) <= 3 or not parts[0]:
        raise ValueError(
            f"--camera {text!r}: give VIEW[:MODALITY[:WIDTHxHEIGHT]], e.g. wrist:depth:64x64"
        )
    kw: dict = {"view": parts[0]}
    if len(parts) > 1:
        kw["modality"] = parts[1]
    if len(parts) > 2:
        try:
            w, h = (int(x) for x in parts[2].lower().split("x"))
        except ValueError:
            raise ValueError(
                f"--camera {text!r}: the size {parts[2]!r} is not WIDTHxHEIGHT, e.g. 64x64"
            ) from None
        kw.update(width=w, height=h)
    return CameraConfig(**kw).validate()
