"""How long the simulator takes to read a dataset's modules, and what the alternatives cost.

The simulator reads each module's meshes from its self-contained MJCF (inline meshes). This
measures that against the two other ways it could read them, on the same modules:
- `packed`: module.json and one binary file a module (`.npz`, uncompressed: every mesh's
  vertices in one array, faces in another, and the counts), split back into meshes: the
  fastest plausible binary form, which the layout would need as a seventh file;
- `mjspec`: MuJoCo's own parser (`MjSpec.from_file`) and the meshes from the spec.
It also times the simulator's own read with the files checked against the manifest
(`verified_ms`; a run checks each module once per process), and the share that costs.

    assetgen bench load [--dataset test] [--n 256] [--json]
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import numpy as np

from assetgen.core.mesh import Mesh
from sim.assets.loading import MJCF_FILE, load_module


def _per_module_ms(fn, items, rounds: int) -> float:
    """Best of `rounds` passes (a busy neighbour only adds time), ms per item."""
    best = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        for it in items:
            fn(it)
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best / max(len(items), 1)


def bench_load(dataset: str | Path, n: int = 256, rounds: int = 3) -> dict:
    """ms per module to load `n` modules of `dataset` three ways (see the module docstring),
    each best of `rounds` warm passes (the files in the page cache, as in a training run
    after the first)."""
    import mujoco

    from assetgen.dataset.reader import Dataset

    ds = Dataset(dataset)
    dirs = [ds.module_dir(m) for m in ds.ids[:n]]
    assets = [load_module(d) for d in dirs]  # warms the cache, and checks every module
    with tempfile.TemporaryDirectory(prefix=".bench-load-", dir=Path(dataset)) as tmp:
        packed = []
        for i, a in enumerate(assets):
            path = Path(tmp) / f"{i}.npz"
            meshes = [a.peg, *a.pieces]
            np.savez(
                path,
                v=np.vstack([m.vertices for m in meshes]),
                f=np.vstack([m.faces for m in meshes]),
                nv=[len(m.vertices) for m in meshes],
                nf=[len(m.faces) for m in meshes],
            )
            packed.append((dirs[i], path))

        def read_packed(item: tuple[Path, Path]) -> None:
            d, path = item
            json.loads((d / "module.json").read_bytes())  # the frames and mass, as load_module
            with np.load(path) as z:
                v, f, nv, nf = z["v"], z["f"], z["nv"], z["nf"]
            vs = np.split(v, np.cumsum(nv)[:-1])
            fs = np.split(f, np.cumsum(nf)[:-1])
            [Mesh(a, b) for a, b in zip(vs, fs, strict=True)]

        def read_mjspec(d: Path) -> None:
            spec = mujoco.MjSpec.from_file(str(d / MJCF_FILE))
            [(np.asarray(m.uservert), np.asarray(m.userface)) for m in spec.meshes]

        mjcf = _per_module_ms(load_module, dirs, rounds)
        # the same with the files checked against the manifest (once per process in a run)
        verified = _per_module_ms(
            lambda mid: load_module(ds.module_dir(mid), ds.records[mid]), ds.ids[:n], rounds
        )
        npz = _per_module_ms(read_packed, packed, rounds)
        mjspec = _per_module_ms(read_mjspec, dirs, rounds)
    return {
        "modules": len(dirs),
        "mjcf_ms": mjcf,
        "packed_ms": npz,
        "mjspec_ms": mjspec,
        "mjcf_over_packed": mjcf / npz,
        "verified_ms": verified,
        "verify_share": (verified - mjcf) / verified,
        "dataset_load_s_mjcf": mjcf * len(ds) / 1e3,
        "dataset_load_s_packed": npz * len(ds) / 1e3,
        "dataset_verify_s": (verified - mjcf) * len(ds) / 1e3,
    }
