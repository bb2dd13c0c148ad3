"""A toy family, kept in the tests: a square peg into a square socket in a block on a plate.

It is one folder and nothing else: parameters, a sampler, and `build`, the pure function
from parameters to an Assembly. Writing, checking, collision pieces, loading in the
simulator and the preview are the assembly layout's, common to every family that builds
one (assetgen.families.interface). tests/test_families.py registers it by name
(assetgen.families.registry.register), generates a dataset of it, checks it and steps the
simulator on it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace

import numpy as np

from assetgen.core.frames import Frame
from assetgen.families.interface import Family
from assetgen.families.parts import Assembly, Part, Step
from assetgen.families.profile_bolt import box
from assetgen.geometry.clearance_hole import clearance_hole
from assetgen.params.module_params import ParamError
from assetgen.params.sampler import config_from_json, config_to_json

PLATE = 0.15
"""Plate side, m; its top face is z = 0."""
FLOOR = 0.005
"""Block material under the socket, m."""
WALL = 0.01
"""Block wall around the socket, m."""


@dataclass(frozen=True)
class CubePegParams:
    """One toy module. SI units (m)."""

    side: float
    """Side of the peg's square section, m (0.01 - 0.03)."""
    depth: float
    """How deep the peg goes into the socket, m (0.01 - 0.03)."""
    clearance: float = 1e-3
    """Peg to socket, m."""

    def validate(self) -> CubePegParams:
        for name, lo, hi in (("side", 0.01, 0.03), ("depth", 0.01, 0.03)):
            if not lo <= getattr(self, name) <= hi:
                raise ParamError(f"{name} = {getattr(self, name):g} is outside [{lo}, {hi}]")
        if not 0 < self.clearance <= 0.005:
            raise ParamError(f"clearance = {self.clearance:g} m must be in (0, 0.005]")
        return self

    def to_json(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_json(d: dict) -> CubePegParams:
        names = {f.name for f in fields(CubePegParams)}
        if set(d) - names:
            raise ParamError(f"unknown cube-peg parameter(s) {sorted(set(d) - names)}")
        return CubePegParams(**d).validate()


@dataclass(frozen=True)
class CubePegSampler:
    """Uniform ranges of the sampled parameters (SI units)."""

    side: tuple[float, float] = (0.015, 0.025)
    """Side of the peg's square section, m."""
    depth: tuple[float, float] = (0.015, 0.025)
    """How deep the peg goes into the socket, m."""
    clearance: float = 1e-3
    """Peg to socket, m (fixed)."""

    @property
    def finest_clearance(self) -> float:
        """The finest clearance of a module, m (its only one)."""
        return self.clearance

    def with_clearance(self, clearance: float) -> CubePegSampler:
        """This config with the peg's clearance set, m."""
        return replace(self, clearance=clearance)

    def validate(self) -> CubePegSampler:
        for corner in (0, 1):
            CubePegParams(self.side[corner], self.depth[corner], self.clearance).validate()
        return self

    def to_json(self) -> dict:
        return config_to_json(self)

    @staticmethod
    def from_json(d: dict) -> CubePegSampler:
        return config_from_json(CubePegSampler, d, "cube-peg sampler").validate()

    def sample(self, seed: int) -> CubePegParams:
        rng = np.random.default_rng(seed)
        side, depth = (float(rng.uniform(*r)) for r in (self.side, self.depth))
        return CubePegParams(side, depth, self.clearance)


def build(p: CubePegParams) -> Assembly:
    """The base (plate and block, the socket cut from it) and the peg, seated."""
    p.validate()
    a, c = p.side / 2, p.clearance
    peg = box([-a, -a, 0.0], [a, a, 2 * p.depth])
    pose = np.eye(4)
    pose[2, 3] = FLOOR + c
    socket = clearance_hole([peg], c, pose, np.array([0.0, 0.0, 1.0]), 0.5)
    half, top = a + c + WALL, FLOOR + c + p.depth
    plate = box([-PLATE / 2, -PLATE / 2, -0.005], [PLATE / 2, PLATE / 2, 0.0])
    base = Part("base", (plate, box([-half, -half, 0.0], [half, half, top])), tuple(socket))
    bottom = np.eye(4)
    bottom[2, 3] = FLOOR
    step = Step(
        "peg", c, Frame((0.0, 0.0, top), (1.0, 0.0, 0.0, 0.0)), Frame.from_matrix(bottom), p.depth
    )
    return Assembly(base, (Part("peg", (peg,), (), pose),), (step,))


FAMILY = Family(
    name="cube-peg",
    summary="a square peg into a square socket (a test's toy)",
    sampler=CubePegSampler,
    params=CubePegParams,
    build=build,
)
