"""One step of an assembly module as a ModuleAsset the vector env runs unchanged.

Step k's static pieces are the base's and those of the parts inserted before it, each at
the pose it was left in (its design pose unless `placed` says otherwise); the moving part is
step k's part, colliding as its convex pieces (an assembly's parts are not convex). Frames,
clearance and mass properties come from module.json, meshes from `assembly.xml` (pieces) and
`<part>.stl` (the surface, for the task's height and spawn rules): numpy only, no CAD stack.
In a dataset, those files are checked against its manifest first (once per process; see
sim.assets.loading).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from assetgen.core.inline_mesh import ASSEMBLY_MJCF_FILE, part_pieces, read_inline_meshes
from assetgen.core.mesh import StoredMesh
from assetgen.core.stl import read_stl_mm
from sim.assets.loading import (
    AssetError,
    ModuleAsset,
    frame_matrix,
    read_module_file,
    verify_module_files,
)


class AssemblyStages:
    """The steps of the assembly in `module_dir` as ModuleAssets, its files read once (a
    sequence evaluation builds step k once per attempt, each with the earlier parts where
    that attempt left them)."""

    def __init__(self, module_dir: Path | str) -> None:
        d = Path(module_dir)
        self.dir = d
        self._meta_path = d / "module.json"
        try:
            self.meta = json.loads(read_module_file(self._meta_path))
            self.steps: list[dict] = list(self.meta["steps"])
            self.parts: list[str] = [s["part"] for s in self.steps]
        except (json.JSONDecodeError, KeyError, TypeError) as e:
            raise AssetError(f"{self._meta_path}: not an assembly module ({e})") from e
        # what it reads, checked against the dataset's manifest (once per process)
        stls = sorted({f"{part}.stl" for part in self.parts})
        verify_module_files([d], ("module.json", ASSEMBLY_MJCF_FILE, *stls))
        self._inline = read_inline_meshes(
            read_module_file(d / ASSEMBLY_MJCF_FILE), str(d / ASSEMBLY_MJCF_FILE)
        )
        self._base = tuple(part_pieces(self._inline, "base"))
        self._surface: dict[str, StoredMesh] = {}

    def design_pose(self, step: int) -> np.ndarray:
        """(4, 4) pose of step `step`'s part where the design seats it (module frame)."""
        return frame_matrix(self._step(step)["design_pose"], "design_pose", self._meta_path)

    def insertion_axis(self, step: int) -> np.ndarray:
        """(3,) unit direction step `step`'s part moves in to seat: entrance to bottom."""
        s = self._step(step)
        e = frame_matrix(s["entrance"], "entrance", self._meta_path)[:3, 3]
        b = frame_matrix(s["bottom"], "bottom", self._meta_path)[:3, 3]
        return (b - e) / np.linalg.norm(b - e)

    def _step(self, step: int) -> dict:
        if not 0 <= step < len(self.steps):
            raise AssetError(
                f"{self._meta_path}: step {step} does not exist; the assembly has steps "
                f"0..{len(self.steps) - 1} ({', '.join(self.parts)})"
            )
        return self.steps[step]

    def stage(self, step: int, placed: dict[str, np.ndarray] | None = None) -> ModuleAsset:
        """Step `step` (0-based) as a ModuleAsset.

        placed : pose (4, 4), module frame, of parts of earlier steps that did not end
                 exactly at their design poses (where an agent left them).
        """
        s = self._step(step)
        try:
            part = s["part"]
            info = self.meta["parts"][part]
            mass = float(info["mass_kg"])
            com = np.asarray(info["com_m"], float).reshape(3)
            inertia = np.asarray(info["inertia_kg_m2"], float).reshape(3, 3)
        except (KeyError, TypeError, ValueError) as e:
            raise AssetError(f"{self._meta_path}: step {step} lacks its part's data ({e})") from e
        statics = list(self._base)
        for k in range(step):
            name = self.parts[k]
            pose = (placed or {}).get(name)
            if pose is None:
                pose = self.design_pose(k)
            statics += [m.transformed(pose) for m in part_pieces(self._inline, name)]
        if part not in self._surface:
            self._surface[part] = read_stl_mm(self.dir / f"{part}.stl")
        return ModuleAsset(
            id=f"{self.meta.get('id', self.dir.name)}/{part}",
            clearance=float(s["clearance"]),
            entrance=frame_matrix(s["entrance"], "entrance", self._meta_path),
            bottom=frame_matrix(s["bottom"], "bottom", self._meta_path),
            peg=self._surface[part],
            peg_mass=mass,
            peg_com=com,
            peg_inertia=inertia,
            pieces=tuple(statics),
            peg_pieces=tuple(part_pieces(self._inline, part)),
        )


def load_stage(
    module_dir: Path | str, step: int, placed: dict[str, np.ndarray] | None = None
) -> ModuleAsset:
    """Step `step` (0-based) of the assembly in `module_dir` as a ModuleAsset (see
    AssemblyStages.stage)."""
    return AssemblyStages(module_dir).stage(step, placed)
