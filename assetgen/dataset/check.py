"""`assetgen check`: re-verify a dataset's files and module checks; repair what is broken.

Each module is checked against its manifest line: module.json records the same id, seed,
parameters, checks and file hashes; every file has its hash; a Table I module's module.json
holds the frames, clearance and peg mass properties its MJCF holds; and the geometry checks
pass again on the files. A dataset.json that is lost or corrupt is rebuilt from the spec
that the manifest and the modules identify (recover_spec), byte for byte as generated.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass, field
from pathlib import Path

from assetgen import GENERATOR_VERSION
from assetgen.checks.module_checks import CheckError, verify
from assetgen.core.frames import Frame
from assetgen.core.inline_mesh import MJCF_FILE
from assetgen.core.mjcf_record import meta_mismatch
from assetgen.core.stl import read_stl_mm
from assetgen.dataset.generate import check_formats, generate, write_info
from assetgen.dataset.module_writer import module_id, sha256
from assetgen.dataset.reader import Dataset, manifest_line, read_manifest, record_mismatch
from assetgen.dataset.spec import SPECS_DIR, DatasetError, DatasetSpec
from assetgen.families.registry import DEFAULT_FAMILY, is_assembly


@dataclass
class CheckReport:
    checked: int = 0
    missing: list[str] = field(default_factory=list)
    corrupt: dict[str, str] = field(default_factory=dict)
    stale: list[str] = field(default_factory=list)
    manifest_error: str | None = None
    spec_error: str | None = None
    """What is wrong with dataset.json (lost or corrupt), which repair rewrites."""
    spec: DatasetSpec | None = None
    """The dataset's spec: dataset.json's, or the one recovered from the manifest."""

    @property
    def bad(self) -> list[str]:
        return sorted({*self.missing, *self.corrupt, *self.stale})

    @property
    def ok(self) -> bool:
        return not self.bad and self.manifest_error is None and self.spec_error is None


def _check_module(folder: Path, record: dict, geometry_checks: bool) -> str | None:
    """None if the module is intact, else what is wrong with it."""
    try:
        meta = json.loads((folder / "module.json").read_text())
    except (OSError, json.JSONDecodeError) as e:
        return f"module.json unreadable ({e})"
    problem = record_mismatch(record, meta)
    if problem:
        return problem
    for name, digest in record["files"].items():
        path = folder / name
        if not path.exists():
            return f"{name} is missing"
        if sha256(path) != digest:
            return f"{name} does not match its hash"
    try:
        assembly = is_assembly(meta.get("family", DEFAULT_FAMILY))
    except ValueError as e:
        return f"module.json: {e}"
    if not assembly and MJCF_FILE in record["files"]:
        problem = meta_mismatch(meta, (folder / MJCF_FILE).read_bytes(), MJCF_FILE)
        if problem:
            return problem
    if geometry_checks and assembly:
        return _check_assembly(folder, meta)
    if geometry_checks:
        travel = meta["checks"]["insertion_travel_m"]
        # module.stl is the printed module where a print offset was asked for
        offset = meta.get("printed", {}).get("print_offset_m", 0.0)
        try:
            verify(
                read_stl_mm(folder / "peg.stl"),
                read_stl_mm(folder / "module.stl"),
                Frame.from_json(meta["frames"]["design_pose"]),
                meta["clearance"] + offset,
                travel,
            )
        except CheckError as e:
            return f"fails its checks: {e}"
    return None


def _check_assembly(folder: Path, meta: dict) -> str | None:
    """The step checks again, on the files: the parts' STLs, the moving parts' pieces as
    the MJCF holds them, and the steps and poses rebuilt from the stored parameters."""
    from assetgen.checks.step_checks import check_parts, check_printed, check_steps
    from assetgen.core.inline_mesh import ASSEMBLY_MJCF_FILE, part_pieces, read_inline_meshes
    from assetgen.core.stl import parse_stl_mm, stl_bytes
    from assetgen.dataset.families import family
    from assetgen.families.part_mesh import part_mesh

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
        if "printed" in meta:  # the STLs are printed parts: the steps on the exact surfaces
            check_printed(assembly, meshes, meta["printed"]["print_offset_m"])
            meshes = {
                p.name: parse_stl_mm(stl_bytes(part_mesh(p)), p.name)
                for p in (assembly.base, *assembly.parts)
            }
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
        records = read_manifest(root / "manifest.jsonl")
    except DatasetError as e:
        # A corrupt manifest: judge the modules by their own module.json; repair rewrites it.
        report.manifest_error = str(e)
        records = _records_from_folders(root)
    try:
        spec = Dataset(root).spec if report.manifest_error is None else _spec_of(root)
    except DatasetError as e:
        if not records:  # nothing to recover a spec from: not a dataset (or an empty one)
            raise
        spec = recover_spec(root, records)
        if spec is None:
            raise DatasetError(
                f"{root}/dataset.json is lost or corrupt and no spec matches its manifest "
                f"({len(records)} modules): restore dataset.json from a copy, or regenerate "
                "the dataset with `assetgen sample` as it was made"
            ) from e
        lost = "lost" if not (root / "dataset.json").exists() else "corrupt"
        report.spec_error = (
            f"dataset.json is {lost}; spec {spec.name!r} recovered from the manifest"
        )
    report.spec = spec
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


def _spec_of(root: Path) -> DatasetSpec:
    """dataset.json's spec (a dataset whose manifest is corrupt); DatasetError when the file
    is lost or corrupt too."""
    path = root / "dataset.json"
    try:
        return DatasetSpec.from_json(json.loads(path.read_text())["spec"], str(path))
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise DatasetError(f"{path} is lost or corrupt ({e})") from e


def _files_of(formats: tuple[str, ...]) -> set[str]:
    """The optional files of a Table I module written with `formats`."""
    from assetgen.formats.registry import with_dependencies

    wanted = set(with_dependencies(formats))
    return {n for f, n in (("mjcf", MJCF_FILE), ("usd", "peg_in_hole.usda")) if f in wanted}


def _reproduces(spec: DatasetSpec, records: dict[str, dict], root: Path) -> bool:
    """Whether the modules in `records` can be `spec`'s: same family, seeds in its range,
    the files of its formats, and parameters its config samples again (first modules)."""
    from assetgen.dataset.families import family
    from assetgen.params.sampler import SamplerConfig, sample_params

    seeds = [r["seed"] for r in records.values()]
    if not all(s in spec.seeds for s in seeds):
        return False
    first = [records[m] for m in sorted(records)[:3]]
    metas = []
    for r in first:
        try:
            metas.append(json.loads((root / "modules" / r["id"] / "module.json").read_text()))
        except (OSError, ValueError):
            metas.append({})
    if any(m.get("family", DEFAULT_FAMILY) != spec.family for m in metas):
        return False
    try:
        for r, meta in zip(first, metas, strict=True):
            if isinstance(spec.config, SamplerConfig):
                if {n for n in r["files"] if n.startswith("peg_in_hole.")} - {
                    "peg_in_hole.3mf"
                } != _files_of(spec.formats):
                    return False
                params = sample_params(spec.config, r["seed"], meta.get("draw", 0)).to_json()
            else:
                params = spec.config.sample(r["seed"]).to_json()
                family(spec.family)  # a known family
            if params != r["params"]:
                return False
    except (ValueError, KeyError, TypeError, AttributeError):
        return False
    return True


def recover_spec(root: Path, records: dict[str, dict]) -> DatasetSpec | None:
    """The spec of a dataset whose dataset.json is lost, from its manifest `records` and
    module folders. Candidates: the specs of datasets/, and the spec `assetgen sample --n
    --seed --out` gives (named after the folder, seeds from the lowest to the highest, the
    formats its files show, the default config or the modules' clearance). A candidate
    reproduces the modules when its family, seed range, formats (files) and config
    (parameters sampled again) fit them; recognition is by content, not by the folder's
    name, which only breaks ties (see the order below). None when none reproduces them."""
    from dataclasses import replace

    from assetgen.dataset.families import family
    from assetgen.formats.registry import available_formats
    from assetgen.params.sampler import SamplerConfig

    candidates = []
    for path in sorted(SPECS_DIR.glob("*.json")):
        try:
            candidates.append(DatasetSpec.from_json(json.loads(path.read_text()), str(path)))
        except (DatasetError, ValueError, OSError):
            continue
    n_named = len(candidates)
    seeds = sorted(r["seed"] for r in records.values())
    first = records[min(records)]
    try:
        meta = json.loads((root / "modules" / first["id"] / "module.json").read_text())
        fam = family(meta.get("family", DEFAULT_FAMILY))
    except (OSError, ValueError):
        fam = None
    if fam is not None:
        files = set(first["files"])
        if {MJCF_FILE, "peg_in_hole.usda"} <= files or not isinstance(fam.sampler(), SamplerConfig):
            formats = available_formats()
        else:
            formats = tuple(f for f, n in (("mjcf", MJCF_FILE), ("usd", "peg_in_hole.usda"))
                            if n in files)  # fmt: skip
        config = fam.sampler()
        configs = [config]
        if isinstance(config, SamplerConfig) and "clearance" in first["params"]:
            configs.append(replace(config, clearance=first["params"]["clearance"]))
        for c in configs:
            try:
                candidates.append(
                    DatasetSpec(root.name, seeds[0], seeds[-1] - seeds[0] + 1, c, formats, fam.name)
                )
            except DatasetError:
                continue
    # the first that reproduces them of: a spec of datasets/ named as the folder (a partial
    # dataset too), then a spec whose seeds are exactly the modules' (datasets/ first), then
    # a spec of datasets/ holding them (a partial dataset in a renamed folder)
    exact = [c for c in candidates if c.seed_start == seeds[0] and c.seeds[-1] == seeds[-1]]
    ordered = (
        [c for c in candidates[:n_named] if c.name == root.name] + exact + candidates[:n_named]
    )
    for spec in ordered:
        if _reproduces(spec, records, root):
            return spec
    return None


def repair(root: Path, report: CheckReport, *, workers: int | None = None, progress: bool = True):
    """Delete the broken modules and their manifest lines, then regenerate just those (and
    write dataset.json again from the spec recovered when it was lost or corrupt). A spec that
    cannot be regenerated, e.g. of unknown formats, is refused first: DatasetError."""
    spec = report.spec if report.spec is not None else _spec_of(root)
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
    if report.spec_error is not None:
        write_info(root, spec)  # generate writes the finished dataset.json from it
    return generate(root, spec, workers=workers, progress=progress)
