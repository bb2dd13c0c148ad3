"""Resumable, parallel generation of a dataset (layout: see assetgen.dataset.reader).

A module folder appears only by an atomic rename of a complete temporary folder, and the
manifest only lists modules whose folder exists, so a run killed at any moment (SIGKILL too)
leaves a dataset that the next run completes to the same content hash.

The plan streams: the seeds still to make are drawn from the spec's range as the workers take
them, never listed, so the memory a run needs before its first module does not grow with the
spec's count (what grows is the manifest lines of the modules made, which the sorted
manifest and the content hash need).
"""

from __future__ import annotations

import importlib
import json
import os
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import TYPE_CHECKING

from assetgen import GENERATOR_VERSION
from assetgen.core.atomic_file import write_dataset_json as write_json
from assetgen.core.mujoco_config import physics_for, physics_record
from assetgen.core.timing import StepTimes, add_times
from assetgen.dataset.reader import content_hash, manifest_line, read_manifest
from assetgen.dataset.spec import DatasetError, DatasetSpec
from assetgen.families.registry import DEFAULT_FAMILY
from assetgen.families.registry import get as get_family

if TYPE_CHECKING:
    from assetgen.dataset.module_writer import ModuleFailure

# The writing half imports the generator (manifold3d, python-fcl, ...) when it runs, so that
# reading a dataset (the simulator, the agents) needs none of the CAD stack.


@dataclass
class RunSummary:
    total: int
    cached: int
    generated: int
    failures: list[ModuleFailure]
    seconds: float
    content_hash: str
    clearance_min_m: float
    clearance_max_m: float
    step_seconds: StepTimes = field(default_factory=dict)
    """Wall seconds of each pipeline step summed over the generated modules (all workers)."""


Result = tuple[int, dict | None, str | None, StepTimes]
"""(seed, manifest line or None, failure reason or None, step times) of one module."""


CRASH_ONCE_ENV = "ASSETGEN_CRASH_ONCE"
"""Fault injection for the tests: `SEED:FILE` makes the worker that starts module SEED die
abruptly (os._exit) once, mid-module, if FILE does not exist yet (it creates it first)."""


def _worker(args: tuple[int, dict, str, tuple[str, ...], str, float]) -> Result:
    from assetgen.dataset.families import family
    from assetgen.dataset.module_writer import ModuleFailure

    seed, config, modules_dir, formats, family_name, print_offset = args
    fam = family(family_name)
    crash = os.environ.get(CRASH_ONCE_ENV)
    if crash and crash.split(":", 1)[0] == str(seed):
        marker = Path(crash.split(":", 1)[1])
        if not marker.exists():
            marker.touch()
            temp = Path(modules_dir) / f".tmp-{seed:06d}-{os.getpid()}"
            temp.mkdir(exist_ok=True)
            (temp / "peg.stl").write_bytes(b"half")  # a half-written module, then gone
            os._exit(1)
    times: StepTimes = {}
    try:
        config = fam.sampler.from_json(config)
        rec = fam.write(seed, config, Path(modules_dir), formats, times, print_offset)
        return seed, manifest_line(rec), None, times
    except ModuleFailure as e:
        return seed, None, e.reason, times


def _prepare(root: Path, spec: DatasetSpec, overwrite: bool) -> None:
    info_file = root / "dataset.json"
    if info_file.exists():
        old = json.loads(info_file.read_text())
        same = old.get("spec") == spec.to_json()
        same_version = old.get("generator_version") == GENERATOR_VERSION
        if not (same and same_version) and not overwrite:
            what = "spec" if not same else f"generator version ({old.get('generator_version')})"
            raise DatasetError(
                f"{root} holds a dataset with a different {what}; use a new name/folder, or "
                "pass --overwrite to delete its modules and regenerate"
            )
        if not (same and same_version):
            _clear(root)
    elif root.exists() and any(root.iterdir()):
        foreign = sorted(p.name for p in root.iterdir())[:5]
        raise DatasetError(
            f"{root} is not empty and holds no dataset.json (found {foreign}); "
            "choose an empty or new folder"
        )
    (root / "modules").mkdir(parents=True, exist_ok=True)
    write_json(info_file, _info(spec, None))


def write_info(root: Path, spec: DatasetSpec) -> None:
    """Write dataset.json as a run starts it (no summary yet): `assetgen check --repair`
    puts back a lost one this way, and the run it starts writes the finished one."""
    write_json(root / "dataset.json", _info(spec, None))


def _clear(root: Path) -> None:
    import shutil

    shutil.rmtree(root / "modules", ignore_errors=True)
    for name in ("manifest.jsonl", "dataset.json"):
        (root / name).unlink(missing_ok=True)


def _info(spec: DatasetSpec, summary: dict | None) -> dict:
    return {
        "generator_version": GENERATOR_VERSION,
        "spec": spec.to_json(),
        "clearance_m": spec.config.clearance,
        # the physics its MJCF files carry (the finest clearance's), and its version
        "physics": physics_record(physics_for(spec.config.finest_clearance)),
        "seeds": [spec.seed_start, spec.seed_start + spec.count - 1],
        "summary": summary,
    }


def _remove_temporaries(root: Path) -> None:
    import shutil

    for d in (root / "modules").glob(".tmp-*"):
        shutil.rmtree(d, ignore_errors=True)


def _adopt_orphans(root: Path, records: dict[str, dict], wanted: Callable[[str], bool]) -> None:
    """Folders renamed into place by a run killed before its manifest line: take them in
    (`wanted`: whether a folder name is a module of the spec).

    Leftover temporary folders of killed runs are removed.
    """
    import shutil

    _remove_temporaries(root)
    for d in (root / "modules").iterdir():
        if wanted(d.name) and d.name not in records:
            try:
                rec = json.loads((d / "module.json").read_text())
                records[d.name] = manifest_line(rec)
            except (OSError, json.JSONDecodeError, KeyError):
                shutil.rmtree(d, ignore_errors=True)


def check_formats(formats: tuple[str, ...]) -> None:
    """DatasetError unless every name of `formats` is a registered exporter
    (assetgen.formats.registry; an assembly's writer takes the same names)."""
    from assetgen.formats.registry import EXPORTERS

    unknown = [f for f in formats if f not in EXPORTERS]
    if unknown:
        raise DatasetError(
            f"formats {list(formats)}: unknown export format(s) {unknown}; valid: "
            f"{sorted(EXPORTERS)} (--formats, comma-separated, or leave it out for all)"
        )


def generate(
    root: Path,
    spec: DatasetSpec,
    *,
    workers: int | None = None,
    overwrite: bool = False,
    progress: bool = True,
    ray: str | None = None,
) -> RunSummary:
    """Generate every module of `spec` not yet in `root`; return a summary.

    ray: None runs the modules in a local process pool of `workers`; an address (HOST:PORT,
    ray://HOST:PORT or auto) runs them as tasks on that Ray cluster, and "" on a local Ray
    instance of `workers` CPUs (see assetgen.dataset.ray_backend). An unreachable address is
    refused before anything is written.
    """
    # the generator's libraries load here, in this process: a missing one fails at once
    import assetgen.dataset.module_writer  # noqa: F401

    spec.validate()
    check_formats(spec.formats)  # before anything is written: a worker would refuse them
    t0 = time.perf_counter()
    cluster = None
    if ray is not None:
        from assetgen.dataset.ray_backend import connect

        cluster = connect(ray, workers)
    try:
        return _generate(root, spec, workers, overwrite, progress, cluster, t0)
    finally:
        if cluster is not None:
            cluster.shutdown()


def _generate(root, spec, workers, overwrite, progress, cluster, t0) -> RunSummary:
    from assetgen.dataset.module_writer import ModuleFailure, module_id

    _prepare(root, spec, overwrite)
    manifest = root / "manifest.jsonl"
    records = read_manifest(manifest)
    seeds = spec.seeds

    def wanted(name: str) -> bool:
        """Whether `name` is the module id of a seed of the spec (no table of them)."""
        if not (name.isascii() and name.isdigit()):
            return False
        seed = int(name)
        return seed in seeds and module_id(seed) == name

    _adopt_orphans(root, records, wanted)
    done = {mid for mid in records if wanted(mid)}
    cached = len(done)
    todo = len(seeds) - cached
    failures: list[ModuleFailure] = []
    step_seconds: StepTimes = {}
    if todo:
        plan = (s for s in seeds if module_id(s) not in done)  # in seed order, as drawn
        try:
            with manifest.open("a") as out:
                results = _run(root, spec, plan, workers, progress, cluster, total=todo)
                for seed, line, reason, times in results:
                    add_times(step_seconds, times)
                    if line is None:
                        failures.append(ModuleFailure(seed, reason or "unknown"))
                        continue
                    records[line["id"]] = line
                    out.write(json.dumps(line, sort_keys=True) + "\n")
                    out.flush()
        except OSError as e:
            # a full disk, a vanished folder: the modules finished so far are complete and
            # listed (or adopted from their folders next time); half-written ones were removed
            raise DatasetError(
                f"writing {root} stopped after {len(records)} of {len(seeds)} modules: {e}. "
                "The finished modules are kept; fix the cause (e.g. free disk space) and run "
                "the same command again to resume."
            ) from e
    _remove_temporaries(root)  # of workers killed mid-module (Ray re-ran their modules)
    # Sorted and complete: the manifest of a finished dataset does not depend on run order.
    tmp = manifest.with_name("manifest.jsonl.tmp")
    tmp.write_text("".join(json.dumps(records[m], sort_keys=True) + "\n" for m in sorted(records)))
    os.replace(tmp, manifest)
    from assetgen.dataset.families import family

    gaps = [g for r in records.values() for g in family(spec.family).gaps(r)]
    summary = RunSummary(
        total=len(seeds),
        cached=cached,
        generated=todo - len(failures),
        failures=failures,
        seconds=time.perf_counter() - t0,
        content_hash=content_hash(records),
        clearance_min_m=min(gaps) if gaps else float("nan"),
        clearance_max_m=max(gaps) if gaps else float("nan"),
        step_seconds=step_seconds,
    )
    write_json(
        root / "dataset.json",
        _info(
            spec,
            {
                "modules": len(records),
                "failed_seeds": sorted(f.seed for f in failures),
                "content_hash": summary.content_hash,
            },
        ),
    )
    return summary


def _import_exporters(formats: tuple[str, ...], family: str = DEFAULT_FAMILY) -> None:
    """Import what the exporters import lazily (MuJoCo, USD) and load the compiled kernels
    of the build and the decomposition (numba: ~0.3 s to import, ~0.3 s to load) before
    forking, so the workers share them instead of each paying for them on its first
    module."""
    import assetgen.formats.registry  # registers the formats
    from assetgen.checks import module_checks as checks
    from assetgen.collision.cell_meshes import warm_up

    # the family's writer (an assembly's brings its decomposition and MJCF)
    importlib.import_module(get_family(family).layout.writer.partition(":")[0])
    warm_up()  # every module's build enumerates vertices, and most decompose
    checks.warm_up()  # every module's files are checked

    if "mjcf" in formats:
        import assetgen.formats.mjcf
    if "usd" in formats:
        import assetgen.formats.usd  # noqa: F401


def _ignore_sigint() -> None:
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run(
    root: Path,
    spec: DatasetSpec,
    seeds: Iterable[int],
    workers: int | None,
    progress: bool,
    cluster=None,
    *,
    total: int,
) -> Iterator[Result]:
    """The results of the modules of `seeds` (`total` of them), as they finish; the jobs are
    made as the workers take them (a pool's task feeder blocks on its full pipe, Ray keeps
    a window in flight), so memory is bounded by the work in flight."""
    workers = workers or os.cpu_count() or 1
    jobs = (
        (
            s,
            spec.config.to_json(),
            str(root / "modules"),
            spec.formats,
            spec.family,
            spec.print_offset,
        )
        for s in seeds
    )
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    bar = Progress(
        "[progress.description]{task.description}",
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        disable=not progress,
        transient=True,
    )
    with bar:
        task = bar.add_task("modules", total=total)
        if cluster is not None:
            from assetgen.dataset.ray_backend import run_tasks

            for r in run_tasks(cluster, _worker, jobs):
                bar.advance(task)
                yield r
            return
        if workers == 1:
            results = map(_worker, jobs)
            for r in results:
                bar.advance(task)
                yield r
            return
        _import_exporters(spec.formats, spec.family)
        # Ctrl-C reaches the whole process group: the workers leave it to this process,
        # which stops them (a module cut mid-write is removed or adopted on the next run)
        with get_context("fork").Pool(workers, initializer=_ignore_sigint) as pool:
            for r in pool.imap_unordered(_worker, jobs, chunksize=4):
                bar.advance(task)
                yield r
