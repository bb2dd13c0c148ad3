"""Reading a dataset folder: its spec, manifest and module files (numpy-free, no CAD stack).

Layout:
    <root>/dataset.json     the spec (generator version, config, seeds, formats) and counts
    <root>/manifest.jsonl   one line per finished module, sorted by id once a run completes
    <root>/modules/<id>/    module.json and the files of every format
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from assetgen.core.inline_mesh import MJCF_FILE
from assetgen.dataset.spec import DatasetError, DatasetSpec


class Dataset:
    """A finished (or partly finished) dataset folder, for the simulator and the tools."""

    def __init__(self, root: Path | str):
        self.root = Path(root)
        spec_file = self.root / "dataset.json"
        if not spec_file.exists():
            raise DatasetError(
                f"{self.root} is not a dataset (no dataset.json); "
                "create one with `assetgen sample --dataset NAME` or `--out DIR`"
            )
        try:
            self.info = json.loads(spec_file.read_text())
            self.spec = DatasetSpec.from_json(self.info["spec"], str(spec_file))
        except (json.JSONDecodeError, KeyError) as e:
            raise DatasetError(f"{spec_file} is corrupt ({e}); regenerate the dataset") from e
        self.records = read_manifest(self.root / "manifest.jsonl")

    @property
    def ids(self) -> list[str]:
        return sorted(self.records)

    def __len__(self) -> int:
        return len(self.records)

    def module_dir(self, mid: str) -> Path:
        if mid not in self.records:
            raise DatasetError(
                f"module {mid!r} is not in {self.root} ({len(self)} modules, "
                f"ids {self.ids[0] if self.ids else '-'} .. {self.ids[-1] if self.ids else '-'})"
            )
        return self.root / "modules" / mid

    def module_json(self, mid: str) -> dict:
        return json.loads((self.module_dir(mid) / "module.json").read_text())

    def paths(self, mid: str) -> dict[str, Path]:
        """Files of module `mid` by role: module_json, peg_stl, module_stl, 3mf, usd, mjcf."""
        d = self.module_dir(mid)
        return {
            "module_json": d / "module.json",
            "peg_stl": d / "peg.stl",
            "module_stl": d / "module.stl",
            "3mf": d / "peg_in_hole.3mf",
            "usd": d / "peg_in_hole.usda",
            "mjcf": d / MJCF_FILE,
        }


def read_manifest(path: Path) -> dict[str, dict]:
    """Records by id; a corrupt line raises DatasetError naming the line."""
    records: dict[str, dict] = {}
    if not path.exists():
        return records
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
            records[rec["id"]] = rec
        except (json.JSONDecodeError, KeyError, TypeError) as e:
            raise DatasetError(
                f"{path}:{n} is not a valid manifest line ({e}); run `assetgen check "
                f"{path.parent} --repair` to rebuild the manifest from the module folders"
            ) from e
    return records


def manifest_line(record: dict) -> dict:
    keys = ("id", "seed", "params", "checks", "files")
    return {k: record[k] for k in keys}


def content_hash(records: dict[str, dict]) -> str:
    """Hash of every module's id and file hashes: equal datasets have equal hashes."""
    h = hashlib.sha256()
    for mid in sorted(records):
        for name, digest in sorted(records[mid]["files"].items()):
            h.update(f"{mid}/{name}:{digest}\n".encode())
    return h.hexdigest()
