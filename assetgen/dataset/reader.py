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
        if not spec_file.exists() and (self.root / "manifest.jsonl").exists():
            raise DatasetError(
                f"{spec_file} is lost; rebuild it from the manifest with "
                f"`assetgen check {self.root} --repair`"
            )
        if not spec_file.exists():
            raise DatasetError(
                f"{self.root} is not a dataset (no dataset.json); "
                "create one with `assetgen sample --dataset NAME` or `--out DIR`"
            )
        try:
            self.info = json.loads(spec_file.read_text())
            self.spec = DatasetSpec.from_json(self.info["spec"], str(spec_file))
        except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError) as e:
            raise DatasetError(
                f"{spec_file} is corrupt ({e}); rebuild it from the manifest with "
                f"`assetgen check {self.root} --repair`"
            ) from e
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

    def file_problem(self, mid: str, name: str, data: bytes | None = None) -> str | None:
        """None when file `name` of module `mid` (its bytes `data` when already read) has
        the hash the manifest records for it; else what is wrong, e.g. `peg_in_hole.xml
        does not match the hash the manifest records`."""
        digest = self.records[mid].get("files", {}).get(name)
        if digest is None:
            return f"{name} has no hash in the manifest"
        if data is None:
            try:
                data = (self.module_dir(mid) / name).read_bytes()
            except OSError as e:
                return f"{name} cannot be read ({e.strerror})"
        if hashlib.sha256(data).hexdigest() != digest:
            return f"{name} does not match the hash the manifest records"
        return None


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


MANIFEST_KEYS = ("id", "seed", "params", "checks", "files")
"""What a manifest line records of a module's module.json."""
MEASURE_DIGITS = 12
"""module.json's floats are rounded to this many places (assetgen.dataset.module_writer's
MEASURE_DIGITS, which a test keeps equal: the writer imports the CAD stack, the reader
must not); the manifest keeps the measured values."""


def manifest_line(record: dict) -> dict:
    return {k: record[k] for k in MANIFEST_KEYS}


def record_mismatch(record: dict, meta: dict) -> str | None:
    """None when a module's module.json (`meta`) holds what its manifest line (`record`)
    records: id, seed, params, checks and file hashes (floats compared as module.json
    rounds them); else which field differs, e.g. `module.json and the manifest disagree on
    params.clearance`."""
    for key in MANIFEST_KEYS:
        where = _first_difference(record.get(key), meta.get(key), key)
        if where is not None:
            return f"module.json and the manifest disagree on {where}"
    return None


def _first_difference(recorded, stored, where: str) -> str | None:
    """The path of the first value where `stored` is not `recorded` as module.json writes it."""
    if isinstance(recorded, dict):
        if not isinstance(stored, dict) or set(recorded) != set(stored):
            return where
        for k in sorted(recorded):
            found = _first_difference(recorded[k], stored[k], f"{where}.{k}")
            if found is not None:
                return found
        return None
    if isinstance(recorded, list | tuple):
        if not isinstance(stored, list) or len(recorded) != len(stored):
            return where
        for i, (a, b) in enumerate(zip(recorded, stored, strict=True)):
            found = _first_difference(a, b, f"{where}[{i}]")
            if found is not None:
                return found
        return None
    if isinstance(recorded, float) and not isinstance(stored, bool):
        same = isinstance(stored, int | float) and round(recorded, MEASURE_DIGITS) == stored
        return None if same else where
    return None if recorded == stored and type(recorded) is type(stored) else where


def content_hash(records: dict[str, dict]) -> str:
    """Hash of every module's id and file hashes: equal datasets have equal hashes."""
    h = hashlib.sha256()
    for mid in sorted(records):
        for name, digest in sorted(records[mid]["files"].items()):
            h.update(f"{mid}/{name}:{digest}\n".encode())
    return h.hexdigest()
