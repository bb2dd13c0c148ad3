"""`assetgen check`: re-verify a dataset's files and module checks; repair what is broken."""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass, field
from pathlib import Path

from assetgen import GENERATOR_VERSION
from assetgen.checks.module_checks import CheckError, verify
from assetgen.core.frames import Frame
from assetgen.core.stl import read_stl_mm
from assetgen.dataset.generate import check_formats, generate
from assetgen.dataset.module_writer import module_id, sha256
from assetgen.dataset.reader import Dataset, manifest_line, read_manifest
from assetgen.dataset.spec import DatasetError, DatasetSpec


@dataclass
class CheckReport:
    checked: int = 0
    missing: list[str] = field(default_factory=list)
    corrupt: dict[str, str] = field(default_factory=dict)
    stale: list[str] = field(default_factory=list)
    manifest_error: str | None = None

    @property
    def bad(self) -> list[str]:
        return sorted({*self.missing, *self.corrupt, *self.stale})

    @property
    def ok(self) -> bool:
        return not self.bad and self.manifest_error is None


def _check_module(folder: Path, record: dict, geometry_checks: bool) -> str | None:
    """None if the module is intact, else what is wrong with it."""
    try:
        meta = json.loads((folder / "module.json").read_text())
    except (OSError, json.JSONDecodeError) as e:
        return f"module.json unreadable ({e})"
    if meta.get("files") != record.get("files"):
        return "module.json and the manifest disagree on the file hashes"
    for name, digest in record["files"].items():
        path = folder / name
        if not path.exists():
            return f"{name} is missing"
        if sha256(path) != digest:
            return f"{name} does not match its hash"
    if geometry_checks and meta.get("family", "peg-in-hole") != "peg-in-hole":
        return _check_assembly(folder, meta)
    if geometry_checks:
        travel = meta["checks"]["insertion_travel_m"]
        try:
            verify(
                read_stl_mm(folder / "peg.stl"),
                read_stl_mm(folder / "module.stl"),
                Frame.from_json(meta["frames"]["design_pose"]),
                meta["clearance"],
                travel,
            )
        except CheckError as e:
            return f"fails its checks: {e}"
    return None


def _check_assembly(folder: Path, meta: dict) -> str | None:
    """The step checks again, on the files: the parts' STLs, the moving parts' pieces as
    the MJCF holds them, and the steps and poses rebuilt from the stored parameters."""
    from assetgen.checks.step_checks import check_parts, check_steps
    from assetgen.core.inline_mesh import ASSEMBLY_MJCF_FILE, part_pieces, read_inline_meshes
    from assetgen.dataset.families import family

    try:
        rebuild = family(meta["family"]).rebuild
        if rebuild is None:
            raise ValueError(f"family {meta['family']!r} has no assemblies to rebuild")
        assembly = rebuild(meta["params"])
        names = [p.name for p in (assembly.base, *assembly.parts)]
        meshes = {n: read_stl_mm(folder / f"{n}.stl") for n in names}
        mjcf = folder / ASSEMBLY_MJCF_FILE
        inline = read_inline_meshes(mjcf.read_bytes(), ASSEMBLY_MJCF_FILE)
        pieces = {n: part_pieces(inline, n) for n in names}
        check_parts(meshes)
        check_steps(assembly, meshes, pieces)
    except (CheckError, ValueError, KeyError) as e:
        return f"fails its checks: {e}"
    return None


def _records_from_folders(root: Path) -> dict[str, dict]:
    records = {}
    for d in sorted((root / "modules").glob("[0-9]*")):
        try:
            records[d.name] = manifest_line(json.loads((d / "module.json").read_text()))
        except (OSError, json.JSONDecodeError, KeyError):
            continue
    return records


def check_dataset(root: Path, *, geometry_checks: bool = True) -> CheckReport:
    """Compare every module of the spec against its manifest line, hashes and checks."""
    report = CheckReport()
    try:
        ds = Dataset(root)
        spec, records = ds.spec, ds.records
    except DatasetError as e:
        if "manifest" not in str(e):
            raise
        # A corrupt manifest: judge the modules by their own module.json; repair rewrites it.
        report.manifest_error = str(e)
        spec = DatasetSpec.from_json(json.loads((root / "dataset.json").read_text())["spec"])
        records = _records_from_folders(root)
    for seed in spec.seeds:
        mid = module_id(seed)
        report.checked += 1
        folder = root / "modules" / mid
        rec = records.get(mid)
        if rec is None or not folder.exists():
            report.missing.append(mid)
            continue
        try:
            version = json.loads((folder / "module.json").read_text()).get("generator_version")
        except (OSError, json.JSONDecodeError):
            version = None
        if version is not None and version != GENERATOR_VERSION:
            report.stale.append(mid)
            continue
        problem = _check_module(folder, rec, geometry_checks)
        if problem:
            report.corrupt[mid] = problem
    return report


def repair(root: Path, report: CheckReport, *, workers: int | None = None, progress: bool = True):
    """Delete the broken modules and their manifest lines, then regenerate just those (a
    spec that cannot be regenerated, e.g. of unknown formats, is refused first: DatasetError)."""
    spec = DatasetSpec.from_json(json.loads((root / "dataset.json").read_text())["spec"])
    check_formats(spec.formats)
    bad = set(report.bad)
    for mid in bad:
        shutil.rmtree(root / "modules" / mid, ignore_errors=True)
    manifest = root / "manifest.jsonl"
    try:
        records = read_manifest(manifest)
    except DatasetError:  # a corrupt manifest is rebuilt from the module folders
        records = _records_from_folders(root)
    kept = {m: r for m, r in records.items() if m not in bad}
    tmp = manifest.with_name("manifest.jsonl.tmp")
    tmp.write_text("".join(json.dumps(kept[m], sort_keys=True) + "\n" for m in sorted(kept)))
    tmp.replace(manifest)
    return generate(root, spec, workers=workers, progress=progress)
