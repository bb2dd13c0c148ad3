"""Draw ModuleParams from a config whose defaults are the paper's Table I.

Each module has its own integer seed; its parameters depend on that seed and the config only
(numpy's PCG64 stream, drawn in a fixed order), so the same seed gives the same module on
every machine and independently of how many modules a run makes.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace

import numpy as np

from assetgen.params.module_params import ModuleParams, ParamError

DEG = math.pi / 180


class ChamferRanges:
    """What a sampler config with chamfer ranges (fields peg_chamfer, peg_chamfer_angle,
    hole_chamfer, hole_chamfer_angle: (low, high), m and rad) shares."""

    @property
    def chamfered(self) -> bool:
        """Whether the pegs get a chamfer (a range other than (0, 0))."""
        return self.peg_chamfer != (0.0, 0.0)  # type: ignore[attr-defined]

    @property
    def hole_chamfered(self) -> bool:
        """Whether the holes' entrances get a chamfer (a range other than (0, 0))."""
        return self.hole_chamfer != (0.0, 0.0)  # type: ignore[attr-defined]

    def without_unused_chamfers(self, out: dict) -> dict:
        """The config's JSON `out` without the chamfers it does not draw (at their default
        angle), so configs from before chamfers keep their form."""
        for on, length, angle in (
            (self.chamfered, "peg_chamfer", "peg_chamfer_angle"),
            (self.hole_chamfered, "hole_chamfer", "hole_chamfer_angle"),
        ):
            if not on and out[angle] == [45 * DEG, 45 * DEG]:
                del out[length], out[angle]
        return out


@dataclass(frozen=True)
class SamplerConfig(ChamferRanges):
    """Uniform ranges of every sampled parameter (SI units). Defaults: paper Table I."""

    polygon_probability: float = 0.75
    """Probability of an n-gon with n uniform in `polygon_vertices`; otherwise a circle."""
    polygon_vertices: tuple[int, int] = (3, 8)
    """Inclusive range of n for the n-gon branch."""
    circle_vertices: int = 32
    """Vertex count of the "circle" branch."""
    circumradius: tuple[float, float] = (0.01, 0.03)
    """Cross-section circumradius, m."""
    aspect_ratio: tuple[float, float] = (0.25, 1.0)
    """Cross-section aspect ratio."""
    peg_height: tuple[float, float] = (0.025, 0.15)
    """Peg height, m."""
    taper: tuple[float, float] = (0.0, 0.25)
    """Tapering toward the bottom, fraction."""
    hole_depth_fraction: tuple[float, float] = (0.4, 0.8)
    """Hole depth as a fraction of the peg height."""
    hole_position: tuple[float, float] = (-0.025, 0.025)
    """Hole entrance x and y (each), m."""
    hole_tilt: tuple[float, float] = (-15 * DEG, 15 * DEG)
    """Tilt of the hole axis about the module x and y axes (each), rad."""
    hole_yaw: tuple[float, float] = (-math.pi, math.pi)
    """Yaw of the hole about its axis, rad."""
    clearance: float = 0.001
    """Clearance, m (fixed, not sampled: 1 mm for training)."""
    peg_chamfer: tuple[float, float] = (0.0, 0.0)
    """Length of the chamfer on the peg's tip, m (Table I: none). Drawn after every other
    parameter, and only where the range is not (0, 0), so the other parameters of a seed stay
    as without it. A draw too long for its peg's bottom face is drawn again, as a footprint
    refusal is (assetgen.geometry.solids.ChamferError)."""
    peg_chamfer_angle: tuple[float, float] = (45 * DEG, 45 * DEG)
    """Angle of the chamfer's faces from the side faces, rad."""
    hole_chamfer: tuple[float, float] = (0.0, 0.0)
    """Depth of the chamfer around the hole's entrance, m (Table I: none); drawn after the
    peg's chamfer, and only where the range is not (0, 0)."""
    hole_chamfer_angle: tuple[float, float] = (45 * DEG, 45 * DEG)
    """Angle of the entrance chamfer's faces from the hole's side faces, rad."""

    @property
    def finest_clearance(self) -> float:
        """The finest clearance of a module, m (its only one): it sets the physics' timestep."""
        return self.clearance

    def with_clearance(self, clearance: float) -> SamplerConfig:
        """This config with the module's clearance set, m (`sample --clearance-mm`)."""
        return replace(self, clearance=clearance)

    def validate(self) -> SamplerConfig:
        if not 0.0 <= self.polygon_probability <= 1.0:
            raise ParamError(f"polygon_probability = {self.polygon_probability} must be in [0, 1]")
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, tuple):
                lo, hi = v
                if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
                    raise ParamError(
                        f"sampler range {f.name} = {v} must be two finite numbers with low <= high"
                    )
        # The corners of the ranges must be buildable: validate them as module params.
        lo = self.sample_corner(low=True)
        hi = self.sample_corner(low=False)
        for p in (lo, hi):
            try:
                p.validate()
            except ParamError as e:
                raise ParamError(f"sampler config range reaches an unbuildable module: {e}") from e
        return self

    def sample_corner(self, *, low: bool) -> ModuleParams:
        i = 0 if low else 1
        n = self.polygon_vertices[i] if self.polygon_probability > 0 else self.circle_vertices
        return ModuleParams(
            n_vertices=int(n),
            circumradius=self.circumradius[i],
            aspect_ratio=self.aspect_ratio[i],
            squash_angle=0.0,
            peg_height=self.peg_height[i],
            taper=self.taper[i],
            hole_depth_fraction=self.hole_depth_fraction[i],
            hole_x=self.hole_position[i],
            hole_y=self.hole_position[i],
            hole_tilt_x=self.hole_tilt[i],
            hole_tilt_y=self.hole_tilt[i],
            hole_yaw=self.hole_yaw[i],
            clearance=self.clearance,
            peg_chamfer=self.peg_chamfer[i],
            peg_chamfer_angle=self.peg_chamfer_angle[i],
            hole_chamfer=self.hole_chamfer[i],
            hole_chamfer_angle=self.hole_chamfer_angle[i],
        )

    def sample(self, seed: int, draw: int = 0) -> ModuleParams:
        """The module parameters of `seed` under this config (sample_params)."""
        return sample_params(self, seed, draw)

    def to_json(self) -> dict:
        return self.without_unused_chamfers(config_to_json(self))

    @staticmethod
    def from_json(d: dict) -> SamplerConfig:
        return config_from_json(SamplerConfig, d, "sampler config").validate()


def config_to_json(config) -> dict:
    """A sampler config dataclass as JSON: its (low, high) ranges as lists."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(config).items()}


def config_from_json(cls: type, d: dict, what: str):
    """`cls` (a sampler config dataclass) from JSON, lists back to tuples; ParamError naming
    `what` and the valid keys for an unknown key. The caller validates."""
    names = {f.name for f in fields(cls)}
    unknown = sorted(set(d) - names)
    if unknown:
        raise ParamError(f"unknown {what} key(s) {unknown}; valid keys: {sorted(names)}")
    return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in d.items()})


def sample_params(config: SamplerConfig, seed: int, draw: int = 0) -> ModuleParams:
    """The module parameters of `seed` under `config` (same on every machine). `draw` > 0
    gives the seed's further draws, from a stream of their own (numpy's seed sequence of
    (seed, draw)), for a seed whose first draw the generator refuses by design (a sleeve
    leaning out of its plate): draw 0 is the only one most seeds ever use, so redraws
    change no other module."""
    if not isinstance(seed, int | np.integer) or seed < 0:
        raise ParamError(f"seed = {seed!r} must be a non-negative integer")
    if not isinstance(draw, int | np.integer) or draw < 0:
        raise ParamError(f"draw = {draw!r} must be a non-negative integer")
    rng = np.random.default_rng(int(seed) if draw == 0 else [int(seed), int(draw)])

    def u(r: tuple[float, float]) -> float:
        return float(rng.uniform(r[0], r[1]))

    # Fixed draw order: changing it changes every dataset (bump GENERATOR_VERSION if you do).
    is_polygon = bool(rng.random() < config.polygon_probability)
    n_poly = int(rng.integers(config.polygon_vertices[0], config.polygon_vertices[1] + 1))
    params = ModuleParams(
        n_vertices=n_poly if is_polygon else config.circle_vertices,
        circumradius=u(config.circumradius),
        aspect_ratio=u(config.aspect_ratio),
        squash_angle=u((0.0, math.pi)),
        peg_height=u(config.peg_height),
        taper=u(config.taper),
        hole_depth_fraction=u(config.hole_depth_fraction),
        hole_x=u(config.hole_position),
        hole_y=u(config.hole_position),
        hole_tilt_x=u(config.hole_tilt),
        hole_tilt_y=u(config.hole_tilt),
        hole_yaw=u(config.hole_yaw),
        clearance=config.clearance,
    )
    if config.chamfered:  # drawn last, and only when asked: no other parameter moves
        params = replace(params, peg_chamfer=u(config.peg_chamfer),
                         peg_chamfer_angle=u(config.peg_chamfer_angle))  # fmt: skip
    if config.hole_chamfered:
        params = replace(params, hole_chamfer=u(config.hole_chamfer),
                         hole_chamfer_angle=u(config.hole_chamfer_angle))  # fmt: skip
    return params


def check_ranges(config, skip: tuple[str, ...] = ()) -> None:
    """ParamError naming the first (low, high) field of a sampler config (a dataclass) that is
    not two finite numbers, low <= high; fields named in `skip` are not ranges."""
    for f in fields(config):
        v = getattr(config, f.name)
        if (
            f.name not in skip
            and isinstance(v, tuple)
            and not (len(v) == 2 and all(math.isfinite(x) for x in v) and v[0] <= v[1])
        ):
            raise ParamError(
                f"sampler range {f.name} = {v} must be two finite numbers, low <= high"
            )


class OneClearance:
    """What a family's sampler config (a frozen dataclass with a `clearance` field, m) whose
    modules have one clearance shares: finest_clearance, with_clearance, to_json and
    from_json (the subclass names itself in WHAT, for the errors)."""

    WHAT = "sampler"

    @property
    def finest_clearance(self) -> float:
        """The finest clearance of a module, m (its only one)."""
        return self.clearance

    def with_clearance(self, clearance: float):
        """This config with the clearance set, m."""
        return replace(self, clearance=clearance)

    def to_json(self) -> dict:
        return config_to_json(self)

    @classmethod
    def from_json(cls, d: dict):
        return config_from_json(cls, d, cls.WHAT).validate()
