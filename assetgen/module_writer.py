"""One module from seed to a finished folder: build, write, read back, check, export, rename.

Everything is written into a temporary sibling folder and renamed into place only once every
check has passed and every file exists, so a folder named `<id>` is always complete and a
module that fails a check is never written.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from assetgen import GENERATOR_VERSION, atomic_file
from assetgen.checks import CheckError, verify
from assetgen.geometry import ModuleGeometry, build_module
from assetgen.params import ModuleParams, ParamError
from assetgen.sampler import SamplerConfig, sample_params
from assetgen.stl import parse_stl_mm, stl_bytes
from assetgen.threemf import threemf_bytes
from assetgen.timing import StepTimes, step

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


@dataclass
class ExportContext:
    """What an exporter sees: the folder being written and everything known so far."""

    folder: Path
    geometry: ModuleGeometry
    record: dict
    """module.json being assembled; exporters add their own sections."""
    hashes: dict[str, str] = field(default_factory=dict)
    """sha256 of every file written so far, by path relative to the folder."""
    data: dict[str, bytes] = field(default_factory=dict)
    """The bytes of every file written with `write`, by the same path: later checks use
    exactly what is on disk without reading it back."""
    parsed: dict[str, np.ndarray] = field(default_factory=dict)
    """Triangles (m, 3, 3) in metres of written STL files parsed back so far, by path: a
    later step that checks them again does not parse them again."""
    pieces: list | None = None
    """The convex collision pieces (module frame, m) once the `collision` step has run."""
    times: StepTimes | None = None
    """Where steps add their wall times (see assetgen.timing), or None: not timed."""
    _dirs: set[str] = field(default_factory=set)
    """Sub-folders of `folder` made so far."""

    def write(self, name: str, data: bytes) -> bytes:
        """Write `data` to folder/name and record its hash; return the bytes written.

        Checks parse these returned bytes, exactly what is on disk, rather than reading the
        file again: on this kind of file system an open costs as much as a whole piece.
        """
        parent = os.path.dirname(name)
        if parent and parent not in self._dirs:  # one mkdir per folder, not one per file
            os.makedirs(self.folder / parent, exist_ok=True)
            self._dirs.add(parent)
        with open(self.folder / name, "wb") as f:
            f.write(data)
        self.hashes[name] = hashlib.sha256(data).hexdigest()
        self.data[name] = data
        return data

    def add_file(self, name: str, data: bytes | None = None) -> None:
        """Record the hash of a file an exporter wrote itself: of `data`, the bytes it wrote
        (no second open of the file), or else read back from the folder."""
        self.hashes[name] = (
            hashlib.sha256(data).hexdigest() if data is not None else sha256(self.folder / name)
        )


Exporter = Callable[[ExportContext], None]
EXPORTERS: dict[str, Exporter] = {}
"""Simulation-format exporters keyed by format name, run after the printable files."""


def module_id(seed: int) -> str:
    return f"{seed:06d}"


def _round(x):
    if isinstance(x, dict):
        return {k: _round(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_round(v) for v in x]
    if isinstance(x, float):
        return round(x, MEASURE_DIGITS)
    return x


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def peg_mass_properties(geom: ModuleGeometry) -> dict:
    """Mass, centre of mass (peg frame, m) and inertia about the COM (kg m^2) of the peg."""
    tm = trimesh.Trimesh(geom.peg.vertices, geom.peg.faces, process=False)
    volume = float(tm.volume)
    tm.density = PEG_MASS / volume
    return {
        "mass_kg": PEG_MASS,
        "volume_m3": volume,
        "com_m": [float(v) for v in tm.center_mass],
        "inertia_kg_m2": np.asarray(tm.moment_inertia).tolist(),
    }


def insertion_travel(geom: ModuleGeometry) -> float:
    """How far above the design pose the checked straight insertion starts (m): enough for
    the peg's bottom face to be above the mounting surface at any tilt."""
    p = geom.params
    return p.hole_depth + p.circumradius + 0.01


write_json = atomic_file.write_dataset_json
"""module.json's writer (a module attribute: tests replace it to fill the disk)."""


def generate_module(
    seed: int,
    config: SamplerConfig,
    modules_dir: Path,
    formats: tuple[str, ...] = (),
    times: StepTimes | None = None,
) -> dict:
    """Sample module `seed` under `config` and write it (see write_module)."""
    try:
        with step(times, "sample"):
            params = sample_params(config, seed)
    except ParamError as e:
        raise ModuleFailure(seed, str(e)) from e
    return write_module(params, seed, modules_dir, formats, times)


def write_module(
    params: ModuleParams,
    seed: int,
    modules_dir: Path,
    formats: tuple[str, ...] = (),
    times: StepTimes | None = None,
) -> dict:
    """Build, check and write a module into `modules_dir/<id>/`; return its module.json.

    Raises ModuleFailure (never leaving files behind) if the module cannot be built or fails a
    check; `formats` names entries of EXPORTERS to run in addition to STL and 3MF. Each step
    adds its wall time to `times` when given (see assetgen.timing).
    """
    from assetgen.exporters import with_dependencies

    formats = with_dependencies(formats)
    unknown = [f for f in formats if f not in EXPORTERS]
    if unknown:
        raise ValueError(f"unknown export format(s) {unknown}; valid: {sorted(EXPORTERS)}")
    mid = module_id(seed)
    final = modules_dir / mid
    tmp = modules_dir / f".tmp-{mid}-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    try:
        with step(times, "build"):
            geom = build_module(params)
        tmp.mkdir(parents=True)
        ctx = ExportContext(tmp, geom, {}, times=times)
        with step(times, "stl+checks"):
            checks = verify(
                parse_stl_mm(ctx.write("peg.stl", stl_bytes(geom.peg))),
                parse_stl_mm(ctx.write("module.stl", stl_bytes(geom.module))),
                geom.design_pose,
                params.clearance,
                insertion_travel(geom),
            )
        with step(times, "3mf"):
            ctx.write("peg_in_hole.3mf", threemf_bytes(geom.peg, geom.module))
        with step(times, "mass"):
            peg = peg_mass_properties(geom)
        ctx.record.update(
            {
                "id": mid,
                "seed": seed,
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
            }
        )
        for f in formats:
            EXPORTERS[f](ctx)
        record = ctx.record
        record["files"] = dict(sorted(ctx.hashes.items()))
        with step(times, "module.json"):
            write_json(tmp / "module.json", _round(record))
        with step(times, "rename"):
            os.replace(tmp, final)
        return record
    except (ParamError, CheckError, ValueError) as e:
        # ValueError: an exporter refused the generated geometry (e.g. a collision piece
        # that is not a closed convex solid); the module is reported, never written.
        shutil.rmtree(tmp, ignore_errors=True)
        raise ModuleFailure(seed, str(e)) from e
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
