"""What the simulator reads from a dataset: module.json and peg_in_hole.xml, nothing else.

sim/ never calls the geometry code: a module is its frames, its peg's mass properties (from
module.json), the peg mesh and the convex collision pieces (inline in the MJCF), all as
written on disk. Every file is checked here, before any simulation, so a missing or corrupt
dataset fails with one clear message naming the file.

Verification: a dataset loaded for simulation (load_dataset) has the files the simulator
reads checked against its manifest once per process: the MJCF's hash, module.json's
manifest fields (id, seed, params, checks, file hashes) and its frames, clearance and peg
mass properties against the verified MJCF's (assetgen.core.mjcf_record). The PhysX engine
verifies the USD it reads (verify_module_files), an assembly's evaluation its assembly.xml
and part STLs. A file changed after generation thus fails with one line naming the module,
the file and `assetgen check DATASET --repair`, instead of being simulated under the
dataset's unchanged content hash. `load_dataset(..., verify=False)` or the environment
variable ASSETGEN_SKIP_VERIFY=1 skips it.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from assetgen.core.inline_mesh import MJCF_FILE, module_meshes
from assetgen.core.mesh import Mesh
from assetgen.core.mjcf_record import meta_mismatch
from assetgen.core.rotations import quat_to_matrix


class AssetError(ValueError):
    """A dataset or module the simulator cannot use; the message names the file and the fix.

    A ValueError: the env factories' contract (rl.commands.MakeEnv) for bad input."""


@dataclass(frozen=True)
class ModuleAsset:
    """One module as the simulator sees it (every array in SI units, module frame)."""

    id: str
    """Module id (folder name)."""
    clearance: float
    """Gap between peg and hole on every face in the design pose, metres."""
    entrance: np.ndarray
    """(4, 4) entrance frame in the module frame."""
    bottom: np.ndarray
    """(4, 4) bottom frame (a seated peg's frame) in the module frame."""
    peg: Mesh
    """Peg surface in the peg frame (origin at the bottom-face centre, z along the axis)."""
    peg_mass: float
    """Peg mass, kg."""
    peg_com: np.ndarray
    """(3,) peg centre of mass in the peg frame, metres."""
    peg_inertia: np.ndarray
    """(3, 3) peg inertia about its centre of mass in the peg frame, kg m^2."""
    pieces: tuple[Mesh, ...]
    """Convex collision pieces in the module frame; their union is the module."""
    peg_pieces: tuple[Mesh, ...] = ()
    """Convex pieces whose union is the peg (peg frame), for a part that is not convex (an
    assembly's profile or bolt): one geom each. Empty: the peg is convex and is its geom."""
    folder: Path | None = None
    """The module's folder (its files: the USD a second engine reads); None for a module
    built in memory."""


def read_meshes(data: bytes, name: str) -> tuple[Mesh, tuple[Mesh, ...]]:
    """The peg and the collision pieces held inline in a module's MJCF bytes; AssetError
    naming the file."""
    try:
        return module_meshes(data, name)
    except ValueError as e:
        raise AssetError(f"{e}; regenerate the module (`assetgen check DATASET --repair`)") from e


def frame_matrix(d: dict, name: str, where: Path) -> np.ndarray:
    """The (4, 4) matrix of the frame `d` ({"pos": 3, "quat": 4 (w, x, y, z)}) as
    module.json records it; AssetError naming the frame `name` and the file `where` when it
    is malformed or not finite."""
    try:
        pos = np.asarray(d["pos"], dtype=float)
        quat = np.asarray(d["quat"], dtype=float)
    except (KeyError, TypeError, ValueError) as e:
        raise AssetError(f"{where}: frame {name!r} is malformed ({e})") from e
    if pos.shape != (3,) or quat.shape != (4,) or not np.isfinite([*pos, *quat]).all():
        raise AssetError(f"{where}: frame {name!r} needs pos (3) and quat (4), finite")
    m = np.eye(4)
    m[:3, :3] = quat_to_matrix(quat)
    m[:3, 3] = pos
    return m


def read_module_file(path: Path) -> bytes:
    """The bytes of one of a module's files; AssetError with advice when it cannot be read."""
    try:
        return path.read_bytes()
    except OSError as e:
        raise AssetError(
            f"{path}: cannot read ({e.strerror}); run `assetgen check` on the dataset"
        ) from e


SKIP_VERIFY_ENV = "ASSETGEN_SKIP_VERIFY"
"""Set to 1 to skip checking a dataset's files against its manifest when loading it for
simulation (see the module doc)."""

_verified: dict[tuple, set[tuple[str, str]]] = {}
"""(dataset folder, manifest inode, mtime and size) -> the (module id, file) pairs this
process has verified: each dataset is checked once per process while its manifest stands."""


def verify_skipped(verify: bool = True) -> bool:
    """Whether verification is off: `verify` False or ASSETGEN_SKIP_VERIFY set (not 0)."""
    return not verify or os.environ.get(SKIP_VERIFY_ENV, "").strip() not in ("", "0")


def _verified_set(ds) -> set[tuple[str, str]]:
    """The pairs verified so far of dataset `ds` (an assetgen.dataset.reader.Dataset)."""
    try:
        st = (ds.root / "manifest.jsonl").stat()
        key = (str(ds.root.resolve()), st.st_ino, st.st_mtime_ns, st.st_size)
    except OSError:
        key = (str(ds.root.resolve()), None, None, None)
    return _verified.setdefault(key, set())


def tampered(root: Path | str, mid: str, problem: str) -> AssetError:
    """The one-line error of module `mid` of dataset `root` whose file is not as generated."""
    return AssetError(
        f"{root}: module {mid}: {problem} (changed after generation); "
        f"run `assetgen check {root} --repair` to regenerate it"
    )


def verify_module_files(module_dirs: Iterable[Path | str], names: Iterable[str]) -> None:
    """Check files `names` of each module folder (modules/<id>/ of a dataset) against the
    hashes its dataset's manifest records (module.json: the fields the manifest records of
    it), once per process; AssetError naming the module,
    the file and `assetgen check --repair` for the first that differs. A folder outside a
    dataset (no dataset.json two levels up) is not checked; nor is anything when
    ASSETGEN_SKIP_VERIFY is set."""
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import DatasetError

    if verify_skipped():
        return
    names = tuple(names)
    datasets: dict[Path, object] = {}
    for d in map(Path, module_dirs):
        root = d.parent.parent
        if not (root / "dataset.json").exists():
            continue
        if root not in datasets:
            try:
                datasets[root] = Dataset(root)
            except DatasetError as e:
                raise AssetError(str(e)) from e
        ds = datasets[root]
        done = _verified_set(ds)
        for name in names:
            if (d.name, name) in done:
                continue
            if d.name not in ds.records:
                raise tampered(root, d.name, "the manifest does not list this module")
            if name == "module.json":  # no hash: what the manifest records of it
                problem = _meta_problem(ds.records[d.name], d / name)
            else:
                problem = ds.file_problem(d.name, name)
            if problem:
                raise tampered(root, d.name, problem)
            done.add((d.name, name))


def load_module(module_dir: Path | str, record: dict | None = None) -> ModuleAsset:
    """Read one module folder (module.json, and the meshes in peg_in_hole.xml) and check it.

    record: the module's manifest line; given, the files read are verified against it (see
    the module doc) and AssetError names the first that is not as generated."""
    d = Path(module_dir)
    meta_path = d / "module.json"
    try:
        meta = json.loads(read_module_file(meta_path))
        frames = meta["frames"]
        peg = meta["peg"]
        clearance = float(meta["clearance"])
        mass = float(peg["mass_kg"])
        com = np.asarray(peg["com_m"], dtype=float).reshape(3)
        inertia = np.asarray(peg["inertia_kg_m2"], dtype=float).reshape(3, 3)
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise AssetError(f"{meta_path}: not valid JSON ({e}); regenerate the module") from e
    except (KeyError, TypeError, ValueError) as e:
        raise AssetError(
            f"{meta_path}: missing or malformed {e}; the simulator needs frames, peg and clearance"
        ) from e
    if mass <= 0 or not np.all(np.isfinite(inertia)) or np.linalg.eigvalsh(inertia).min() <= 0:
        raise AssetError(f"{meta_path}: peg mass/inertia not positive")
    mjcf = d / MJCF_FILE
    if not mjcf.exists():
        raise AssetError(
            f"{mjcf}: missing; the simulator reads the meshes from the MJCF (generate the "
            "dataset with the `mjcf` format, the default)"
        )
    data = read_module_file(mjcf)
    if record is not None:
        _verify_read(d, meta, data, record)
    peg_mesh, pieces = read_meshes(data, str(mjcf))
    return ModuleAsset(
        id=str(meta.get("id", d.name)),
        clearance=clearance,
        entrance=frame_matrix(frames.get("entrance", {}), "entrance", meta_path),
        bottom=frame_matrix(frames.get("bottom", {}), "bottom", meta_path),
        peg=peg_mesh,
        peg_mass=mass,
        peg_com=com,
        peg_inertia=inertia,
        pieces=pieces,
        folder=d,
    )


def _meta_problem(record: dict, path: Path) -> str | None:
    from assetgen.dataset.reader import record_mismatch

    try:
        return record_mismatch(record, json.loads(path.read_bytes()))
    except (OSError, ValueError) as e:
        return f"module.json cannot be read ({e})"


def _verify_read(d: Path, meta: dict, mjcf: bytes, record: dict) -> None:
    """The checks of `load_module(d, record)` on the bytes it read."""
    import hashlib

    from assetgen.dataset.reader import record_mismatch

    digest = record.get("files", {}).get(MJCF_FILE)
    problem = (
        f"{MJCF_FILE} has no hash in the manifest"
        if digest is None
        else f"{MJCF_FILE} does not match the hash the manifest records"
        if hashlib.sha256(mjcf).hexdigest() != digest
        else record_mismatch(record, meta) or meta_mismatch(meta, mjcf, MJCF_FILE)
    )
    if problem:
        raise tampered(d.parent.parent, d.name, problem)


def check_physics(root: Path | str, keep: bool = False):
    """The physics to simulate the dataset at `root` with: None (the project's: the dataset
    records the current PHYSICS_VERSION), or with `keep` the PhysicsConfig its dataset.json
    records (a dataset older than the record: version 1). A dataset of another version
    without `keep` raises AssetError naming both versions, how to regenerate the dataset and
    how to keep its physics."""
    from assetgen.core.mujoco_config import PHYSICS_VERSION, describe, physics_from_record
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import DatasetError

    try:
        info = Dataset(root).info
        version, physics = physics_from_record(info.get("physics"))
    except DatasetError as e:
        raise AssetError(str(e)) from e
    except ValueError as e:
        raise AssetError(f"{root}/dataset.json: {e}") from e
    if version == PHYSICS_VERSION:
        return physics if keep else None
    if keep:
        return physics
    name = Path(root).name
    raise AssetError(
        f"{root} was written for physics version {version} ({describe(physics)}); this "
        f"simulator runs version {PHYSICS_VERSION}: regenerate it (`assetgen sample --dataset "
        f"{name} --overwrite`, or `--out {root} --overwrite` with its --n/--seed), or keep the "
        "physics its files carry (keep_physics=True)"
    )


def dataset_root(dataset: str | Path) -> Path:
    """A dataset spec name (`train`, `test`) or a folder -> the folder; ValueError naming
    the specs there are for an unknown name."""
    from assetgen.dataset.spec import DatasetError, resolve

    try:
        return resolve(str(dataset))[0]
    except DatasetError as e:
        raise ValueError(str(e)) from e


def load_dataset(
    root: Path | str, ids: list[str] | None = None, *, verify: bool = True
) -> list[ModuleAsset]:
    """Every module of a dataset folder (or the listed ids), checked before simulation.

    verify: check the files read against the manifest, once per process (see the module
    doc); False, or the environment variable ASSETGEN_SKIP_VERIFY=1, skips it."""
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import DatasetError

    try:
        ds = Dataset(root)
        wanted = ds.ids if ids is None else ids
        dirs = [ds.module_dir(mid) for mid in wanted]
    except DatasetError as e:
        raise AssetError(str(e)) from e
    if not dirs:
        raise AssetError(
            f"{root} holds no finished modules; generate some with "
            "`assetgen sample --n N --out DIR`"
        )
    if verify_skipped(verify):
        return [load_module(p) for p in dirs]
    done = _verified_set(ds)
    out = []
    for mid, d in zip(wanted, dirs, strict=True):
        fresh = (mid, "module.json") not in done
        out.append(load_module(d, ds.records[mid] if fresh else None))
        done.update({(mid, "module.json"), (mid, MJCF_FILE)})
    return out
