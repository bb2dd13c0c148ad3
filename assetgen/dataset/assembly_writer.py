"""One assembly from parameters to a finished folder, as module_writer does for a Table I
module: build, write each part's STL, read them back, check every step on what was written,
export, rename into place.

A folder `<id>/` holds `module.json`, one `<part>.stl` per part (the base included),
`assembly.3mf` (every part laid out for printing), `assembly.xml` (MJCF: the base's pieces
static, each moving part a free body) and `assembly.usda` (the same for Isaac Sim).
Everything is written into a temporary sibling folder and renamed only once every check has
passed, so a module that fails is never written.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from assetgen import GENERATOR_VERSION
from assetgen.checks.step_checks import check_parts, check_printed, check_steps
from assetgen.collision.carve import carve_part
from assetgen.core.inline_mesh import ASSEMBLY_MJCF_FILE as MJCF_FILE
from assetgen.core.inline_mesh import stored
from assetgen.core.stl import parse_stl_mm, stl_bytes
from assetgen.core.timing import StepTimes, step
from assetgen.dataset.module_writer import PEG_MASS, module_id, round_measures, staged, write_json
from assetgen.families.part_mesh import part_mesh, printed_part
from assetgen.families.parts import Assembly
from assetgen.formats.assembly_3mf import assembly_3mf_bytes
from assetgen.formats.assembly_mjcf import assembly_mjcf
from assetgen.geometry.mass import mass_properties

THREEMF_FILE = "assembly.3mf"
USD_FILE = "assembly.usda"


def _frame_json(matrix) -> dict:
    from assetgen.core.frames import Frame

    return Frame.from_matrix(matrix).to_json()


def write_assembly(
    family: str,
    params,
    assembly: Assembly,
    seed: int,
    modules_dir: Path,
    times: StepTimes | None = None,
    print_offset: float = 0.0,
) -> dict:
    """Check and write `assembly` (built from `params` of `family`) into
    `modules_dir/<id>/`; return its module.json. Raises ModuleFailure, leaving nothing
    behind, when a check fails.

    print_offset (m, DatasetSpec's): the STL files and the 3MF carry every part's holes with
    their faces moved out by this much more (part_mesh.printed_part); each step's gap is measured on
    them and recorded under `printed`. The checks, the MJCF and the USD are the simulation's
    geometry's, as without it."""
    mid = module_id(seed)
    final = modules_dir / mid
    parts = (assembly.base, *assembly.parts)
    with staged(modules_dir, seed) as tmp:
        tmp.mkdir(parents=True)
        hashes: dict[str, str] = {}

        def write(name: str, data: bytes) -> bytes:
            (tmp / name).write_bytes(data)
            hashes[name] = hashlib.sha256(data).hexdigest()
            return data

        meshes, printed = {}, {}
        with step(times, "stl"):
            for p in parts:
                name = f"{p.name}.stl"
                data = stl_bytes(part_mesh(p))
                meshes[p.name] = parse_stl_mm(data if print_offset else write(name, data), name)
                if print_offset:  # the printed part is the file; the checks keep the exact one
                    if p.holes:  # a part without holes prints as it simulates
                        data = stl_bytes(part_mesh(printed_part(p, print_offset)))
                    printed[p.name] = parse_stl_mm(write(name, data), name)
        with step(times, "collision: decompose"):
            pieces = {p.name: stored(carve_part(p.solids, p.holes)) for p in parts}
        with step(times, "checks"):
            checks = {
                "parts": check_parts(meshes),
                "steps": check_steps(assembly, meshes, pieces),
            }
            if print_offset:
                printed_checks = check_printed(assembly, printed, print_offset)
        with step(times, "mass"):
            mass = {}
            for p in assembly.parts:
                _, com, inertia = mass_properties(meshes[p.name], PEG_MASS)
                mass[p.name] = (PEG_MASS, com, inertia)
        with step(times, "3mf"):
            write(
                THREEMF_FILE,
                assembly_3mf_bytes(
                    [(p.name, (printed or meshes)[p.name], p.print_turn) for p in parts]
                ),
            )
        with step(times, "mjcf"):
            write(MJCF_FILE, assembly_mjcf(assembly, pieces, mass, name=MJCF_FILE))
        with step(times, "usd"):
            from assetgen.formats.assembly_usd import assembly_usda

            write(USD_FILE, assembly_usda(assembly, meshes, pieces, mass).encode())
        record = {
            "id": mid,
            "seed": seed,
            "family": family,
            "generator_version": GENERATOR_VERSION,
            "params": params.to_json(),
            "steps": [
                {
                    "part": s.part,
                    "clearance": s.clearance,
                    "entrance": s.entrance.to_json(),
                    "bottom": s.bottom.to_json(),
                    "design_pose": _frame_json(assembly.part(s.part).pose),
                    "travel_m": s.travel,
                }
                for s in assembly.steps
            ],
            "parts": {
                p.name: {
                    "pieces": len(pieces[p.name]),
                    **(
                        {
                            "mass_kg": mass[p.name][0],
                            "com_m": [float(v) for v in mass[p.name][1]],
                            "inertia_kg_m2": mass[p.name][2].tolist(),
                        }
                        if p.name in mass
                        else {}
                    ),
                }
                for p in parts
            },
            "checks": checks,
            **({"printed": printed_checks} if print_offset else {}),
            "files": dict(sorted(hashes.items())),
        }
        with step(times, "module.json"):
            write_json(tmp / "module.json", round_measures(record))
        os.replace(tmp, final)
        return record
