"""The families the generator knows, by name: each a sampler config (a frozen dataclass
with validate / to_json / from_json) and a function writing one module of a seed.

`peg-in-hole` is the paper's Table I (assetgen.dataset.module_writer: its bytes are the
ones every earlier dataset holds); `profile-bolt` is the assembly sequence
(assetgen.families.profile_bolt, written by assetgen.dataset.assembly_writer).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from assetgen.core.timing import StepTimes

if TYPE_CHECKING:
    from assetgen.families.parts import Assembly

DEFAULT_FAMILY = "peg-in-hole"


@dataclass(frozen=True)
class Family:
    """name: as in `--family`; sampler: its config class; write(seed, config, modules_dir,
    formats, times) -> module.json, raising ModuleFailure; gaps(record): the measured
    clearances of a written module (m); rebuild(params JSON) -> the Assembly a module was
    made from (`assetgen check` compares the files with it), None for Table I modules,
    which are checked by their own rules."""

    name: str
    sampler: type
    write: Callable[[int, object, Path, tuple[str, ...], StepTimes | None], dict]
    gaps: Callable[[dict], list[float]]
    rebuild: Callable[[dict], Assembly] | None = None


def _write_peg_in_hole(seed, config, modules_dir, formats, times) -> dict:
    from assetgen.dataset.module_writer import generate_module

    return generate_module(seed, config, modules_dir, formats, times)


def _write_profile_bolt(seed, config, modules_dir, formats, times) -> dict:
    from assetgen.dataset.assembly_writer import write_assembly
    from assetgen.dataset.module_writer import ModuleFailure
    from assetgen.families.profile_bolt import build_profile_bolt
    from assetgen.params.module_params import ParamError

    try:
        params = config.sample(seed)
        assembly = build_profile_bolt(params)
    except ParamError as e:
        raise ModuleFailure(seed, str(e)) from e
    return write_assembly("profile-bolt", params, assembly, seed, modules_dir, times)


def _rebuild_profile_bolt(params: dict) -> Assembly:
    from assetgen.families.profile_bolt import ProfileBoltParams, build_profile_bolt

    return build_profile_bolt(ProfileBoltParams.from_json(params))


def _peg_sampler():
    from assetgen.params.sampler import SamplerConfig

    return SamplerConfig


def _profile_bolt_sampler():
    from assetgen.families.profile_bolt import ProfileBoltSampler

    return ProfileBoltSampler


FAMILIES: dict[str, Callable[[], Family]] = {
    "peg-in-hole": lambda: Family(
        "peg-in-hole",
        _peg_sampler(),
        _write_peg_in_hole,
        lambda r: [r["checks"]["clearance_m"]],
    ),
    "profile-bolt": lambda: Family(
        "profile-bolt",
        _profile_bolt_sampler(),
        _write_profile_bolt,
        lambda r: [s["clearance_m"] for s in r["checks"]["steps"]],
        _rebuild_profile_bolt,
    ),
}
"""Family constructors by name (a function each, so naming a family imports only its own
libraries)."""


def family(name: str) -> Family:
    """The family called `name`; ValueError listing the valid names otherwise."""
    if name not in FAMILIES:
        raise ValueError(f"unknown family {name!r}; valid families: {sorted(FAMILIES)}")
    return FAMILIES[name]()
