"""One step of an assembly module as a ModuleAsset the vector env runs unchanged.

Step k's static pieces are the base's and those of the parts inserted before it, each at
the pose it was left in (its design pose unless `placed` says otherwise); the moving part is
step k's part, colliding as its convex pieces (an assembly's parts are not convex). Frames,
clearance and mass properties come from module.json, meshes from `assembly.xml` (pieces) and
`<part>.stl` (the surface, for the task's height and spawn rules): numpy only, no CAD stack.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from assetgen.core.inline_mesh import ASSEMBLY_MJCF_FILE, part_pieces, read_inline_meshes
from assetgen.core.stl import read_stl_mm
from sim.assets import AssetError, ModuleAsset, _frame, _read


def load_stage(
    module_dir: Path | str, step: int, placed: dict[str, np.ndarray] | None = None
) -> ModuleAsset:
    """Step `step` (0-based) of the assembly in `module_dir` as a ModuleAsset.

    placed : pose (4, 4), module frame, of parts of earlier steps that did not end exactly
             at their design poses (the env passes where an agent left them).
    """
    d = Path(module_dir)
    meta_path = d / "module.json"
    try:
        meta = json.loads(_read(meta_path))
        steps = meta["steps"]
        s = steps[step]
        part = s["part"]
        info = meta["parts"][part]
        mass = float(info["mass_kg"])
        com = np.asarray(info["com_m"], float).reshape(3)
        inertia = np.asarray(info["inertia_kg_m2"], float).reshape(3, 3)
    except (json.JSONDecodeError, KeyError, IndexError, TypeError, ValueError) as e:
        raise AssetError(f"{meta_path}: not an assembly with a step {step} ({e})") from e
    inline = read_inline_meshes(_read(d / ASSEMBLY_MJCF_FILE), str(d / ASSEMBLY_MJCF_FILE))

    statics = list(part_pieces(inline, "base"))
    for earlier in steps[:step]:
        name = earlier["part"]
        pose = (placed or {}).get(name)
        if pose is None:
            pose = _frame(earlier["design_pose"], "design_pose", meta_path)
        statics += [m.transformed(pose) for m in part_pieces(inline, name)]
    return ModuleAsset(
        id=f"{meta.get('id', d.name)}/{part}",
        clearance=float(s["clearance"]),
        entrance=_frame(s["entrance"], "entrance", meta_path),
        bottom=_frame(s["bottom"], "bottom", meta_path),
        peg=read_stl_mm(d / f"{part}.stl"),
        peg_mass=mass,
        peg_com=com,
        peg_inertia=inertia,
        pieces=tuple(statics),
        peg_pieces=tuple(part_pieces(inline, part)),
    )
