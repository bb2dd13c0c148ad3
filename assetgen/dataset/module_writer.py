"""One module from seed to a finished folder: build, write, read back, check, export, rename.

Everything is written into a temporary sibling folder and renamed into place only once every
check has passed and every file exists, so a folder named `<id>` is always complete and a
module that fails a check is never written.
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from assetgen import GENERATOR_VERSION
from assetgen.checks.module_checks import CheckError, verify
from assetgen.core import atomic_file
from assetgen.core.stl import parse_stl_mm, stl_bytes
from assetgen.core.timing import StepTimes, step
from assetgen.formats.context import ExportContext
from assetgen.formats.registry import EXPORTERS, with_dependencies
from assetgen.formats.threemf import threemf_bytes
from assetgen.geometry.mass import mass_properties
from assetgen.geometry.solids import (
    FootprintError,
    ModuleGeometry,
    build_module,
    chamfer_inset,
    insertion_travel,
    printed_module,
)
from assetgen.params.module_params import ModuleParams, ParamError
from assetgen.params.sampler import SamplerConfig, sample_params

PEG_MASS = 0.2
"""Peg mass, kg (paper)."""
MEASURE_DIGITS = 12
"""Measured values are rounded to 1e-12 (SI) so files do not depend on the last float bit."""


class ModuleFailure(RuntimeError):
    """A module that could not be built or failed a check; carries its seed and reason."""

    def __init__(self, seed: int, reason: str):
        super().__init__(f"module seed {seed}: {reason}")
        self.seed = seed
        self.reason = reason


def module_id(seed: int) -> str:
    return f"{seed:06d}"


def round_measures(x):
    """`x` (JSON data: dicts, lists, numbers) with every float rounded to MEASURE_DIGITS
    places, as module.json is written (an assembly's module.json too)."""
    if isinstance(x, dict):
        return {k: round_measures(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [round_measures(v) for v in x]
    if isinstance(x, float):
        return round(x, MEASURE_DIGITS)
    return x


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def peg_mass_properties(geom: ModuleGeometry) -> dict:
    """Mass, centre of mass (peg frame, m) and inertia about the COM (kg m^2) of the peg."""
    volume, com, inertia = mass_properties(geom.peg, PEG_MASS)
    return {
        "mass_kg": PEG_MASS,
        "volume_m3": volume,
        "com_m": [float(v) for v in com],
        "inertia_kg_m2": inertia.tolist(),
    }


MAX_DRAWS = 16
"""Draws of one seed before a footprint refusal fails the module (each draw is refused
with probability about 7e-4, so a 16th is never needed in practice)."""

write_json = atomic_file.write_dataset_json
"""module.json's writer (a module attribute: tests replace it to fill the disk)."""


def generate_module(
    seed: int,
    config: SamplerConfig,
    modules_dir: Path,
    formats: tuple[str, ...] = (),
    times: StepTimes | None = None,
    print_offset: float = 0.0,
) -> dict:
    """Sample module `seed` under `config` and write it (see write_module). A draw that the
    footprint rule refuses (FootprintError: the sleeve under a deep, tilted hole near the
    plate's edge would lean out of the plate; about 0.07 % of Table I draws) is drawn again
    from the seed's next stream, up to MAX_DRAWS times; module.json records `draw` when it
    is not the first."""
    for draw in range(MAX_DRAWS):
        try:
            with step(times, "sample"):
                params = sample_params(config, seed, draw)
        except ParamError as e:
            raise ModuleFailure(seed, str(e)) from e
        try:
            return write_module(params, seed, modules_dir, formats, times, draw, print_offset)
        except ModuleFailure as e:
            if not isinstance(e.__cause__, FootprintError) or draw == MAX_DRAWS - 1:
                raise
    raise AssertionError("unreachable")


@contextmanager
def staged(modules_dir: Path, seed: int) -> Iterator[Path]:
    """The temporary sibling folder module `seed` is written into (the caller makes it, and
    renames it into place when done). If the block raises, the folder is removed; a failed
    check or a refused geometry (ParamError, CheckError, ValueError) becomes ModuleFailure."""
    tmp = modules_dir / f".tmp-{module_id(seed)}-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    try:
        yield tmp
    except (ParamError, CheckError, ValueError) as e:
        # ValueError: an exporter refused the generated geometry (e.g. a collision piece
        # that is not a closed convex solid); the module is reported, never written.
        shutil.rmtree(tmp, ignore_errors=True)
        raise ModuleFailure(seed, str(e)) from e
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def write_module(
    params: ModuleParams,
    seed: int,
    modules_dir: Path,
    formats: tuple[str, ...] = (),
    times: StepTimes | None = None,
    draw: int = 0,
    print_offset: float = 0.0,
) -> dict:
    """Build, check and write a module into `modules_dir/<id>/`; return its module.json
    (`draw`: which of the seed's draws `params` is, recorded when not the first).

    print_offset (m, DatasetSpec's): module.stl and the 3MF carry the hole with its faces
    moved out by this much more (solids.printed_module), checked at clearance + offset and
    recorded under `printed`; the checks of the simulation's geometry, and its files, are as
    without it.

    Raises ModuleFailure (never leaving files behind) if the module cannot be built or fails a
    check; `formats` names entries of EXPORTERS to run in addition to STL and 3MF. Each step
    adds its wall time to `times` when given (see assetgen.core.timing).
    """
    formats = with_dependencies(formats)
    unknown = [f for f in formats if f not in EXPORTERS]
    if unknown:
        raise ValueError(f"unknown export format(s) {unknown}; valid: {sorted(EXPORTERS)}")
    mid = module_id(seed)
    final = modules_dir / mid
    with staged(modules_dir, seed) as tmp:
        with step(times, "build"):
            geom = build_module(params)
        tmp.mkdir(parents=True)
        ctx = ExportContext(tmp, geom, {}, times=times)
        with step(times, "stl+checks"):
            printed = printed_module(geom, print_offset) if print_offset else None
            for name, mesh in (("peg.stl", geom.peg), ("module.stl", geom.module)):
                data = stl_bytes(mesh)
                if printed is None or name == "peg.stl":
                    ctx.write(name, data)
                ctx.meshes[name] = parse_stl_mm(data, name)
            checks = verify(
                ctx.meshes["peg.stl"],
                ctx.meshes["module.stl"],
                geom.design_pose,
                params.clearance,
                insertion_travel(geom),
            )
            if params.peg_chamfer:  # where the side faces, and the exact clearance, start
                checks["peg_chamfer"] = {
                    "sides_start_m": params.peg_chamfer,
                    "bottom_inset_m": chamfer_inset(params),
                }
            if params.hole_chamfer:  # where the entrance's chamfer meets the exact faces
                checks["hole_chamfer"] = {
                    "depth_m": params.hole_chamfer,
                    "width_m": params.hole_chamfer * math.tan(params.hole_chamfer_angle),
                }
            if printed is not None:  # the printed hole, written in the simulation's place
                data = ctx.write("module.stl", stl_bytes(printed))
                printed_checks = verify(
                    ctx.meshes["peg.stl"],
                    parse_stl_mm(data, "module.stl"),
                    geom.design_pose,
                    params.clearance + print_offset,
                    insertion_travel(geom),
                )
        with step(times, "3mf"):
            plate = geom.module if printed is None else printed
            ctx.write("peg_in_hole.3mf", threemf_bytes(geom.peg, plate))
        with step(times, "mass"):
            peg = peg_mass_properties(geom)
        ctx.record.update(
            {
                "id": mid,
                "seed": seed,
                **({"draw": draw} if draw else {}),
                "generator_version": GENERATOR_VERSION,
                "params": params.to_json(),
                "clearance": params.clearance,
                "frames": {
                    "entrance": geom.entrance.to_json(),
                    "bottom": geom.bottom.to_json(),
                    "design_pose": geom.design_pose.to_json(),
                },
                "peg": peg,
                "checks": checks,
                **(
                    {}
                    if printed is None
                    else {"printed": {"print_offset_m": print_offset, **printed_checks}}
                ),
            }
        )
        for f in formats:
            EXPORTERS[f](ctx)
        record = ctx.record
        record["files"] = dict(sorted(ctx.hashes.items()))
        with step(times, "module.json"):
            write_json(tmp / "module.json", round_measures(record))
        with step(times, "rename"):
            os.replace(tmp, final)
        return record
