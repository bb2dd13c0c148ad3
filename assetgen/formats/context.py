"""What a format exporter sees while one module is being written (see assetgen.formats.registry)."""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from assetgen.core.mesh import Mesh
from assetgen.core.timing import StepTimes
from assetgen.geometry.solids import ModuleGeometry


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
    meshes: dict[str, Mesh] = field(default_factory=dict)
    """Written STL files as parsed back from their bytes, by path: a later step that uses
    them again does not parse them again."""
    pieces: list[Mesh] | None = None
    """The convex collision pieces (module frame, m) once the `collision` step has run,
    rounded as the files store them (assetgen.core.inline_mesh.stored) and checked."""
    times: StepTimes | None = None
    """Where steps add their wall times (see assetgen.core.timing), or None: not timed."""

    def write(self, name: str, data: bytes) -> bytes:
        """Write `data` to folder/name (a module folder is flat: six files, no sub-folders) and
        record its hash; return the bytes written.

        Checks parse these returned bytes, exactly what is on disk, rather than reading the
        file again.
        """
        with open(self.folder / name, "wb") as f:
            f.write(data)
        self.hashes[name] = hashlib.sha256(data).hexdigest()
        self.data[name] = data
        return data


Exporter = Callable[[ExportContext], None]
