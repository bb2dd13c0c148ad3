"""The MJCF physics checks over every module of a dataset, and their worst figures.

    python -m assetgen.physics.report DATASET [--limit N] [--json OUT]

For each module's `peg_in_hole.xml` (assetgen.physics.mjcf_checks):

- drop: the peg, above the entrance, pushed down the hole axis by its weight + 5 N, comes
  to rest on the floor: its frame within 0.2 mm of the bottom frame, penetration < 0.1 mm;
- faces: the peg, held down the axis (HOLD_DOWN), pushed sideways with 5 N towards each
  side face of the hole (the in-plane direction of the face's normal) never passes through
  the wall, moves along the push no further than the clearance + 0.1 mm (the free travel
  towards a face from the seated pose is at most the clearance) and rests < 0.1 mm deep;
- corners and 8 evenly spread directions: the same push never passes through and rests
  < 0.1 mm deep; its move beyond the geometric free travel along its own direction
  (MuJoCo's distance queries on the convex pieces) is reported as `overshoot`.

The peg is held down during the side pushes because the issue allows "a constant push
down the axis", and without it a tapered peg pushed sideways climbs its sloped walls (an
allowed motion of a weightless peg, but not what a wall test measures).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from contextlib import nullcontext
from multiprocessing import get_context
from pathlib import Path

from assetgen.core.atomic_file import write_json
from assetgen.physics.arguments import add_arguments
from assetgen.physics.mjcf_checks import corner_angles, drop_test, side_face_angles, side_push_test

GRAVITY = 9.81
HOLD_DOWN = 3.0
"""N down the hole axis during the side pushes, on top of the peg's weight under GRAVITY
(0.2 kg: 2 N). A frictionless
wall leaning by a (tapered peg, a <= ~17 deg) lifts a peg pushed with F sideways once the
hold-down is below F tan a (1.5 N for 5 N); ~5 N keeps it on the floor with margin."""
SIDE_FORCE = 5.0
"""N across the axis: the issue's "about 5 N"."""
EVEN_DIRECTIONS = 8
SAVE_EVERY = 16
"""With --json, the figures so far are written every this many modules (`complete`: false)."""

LIMITS: dict[str, float] = {
    "drop_rest_error": 0.2e-3,
    "drop_penetration": 0.1e-3,
    "face_move_over_clearance": 0.1e-3,
    "face_penetration_at_rest": 0.1e-3,
    "penetration_at_rest": 0.1e-3,
}
"""The issue's bounds (m) on the figures of `check_module`; each must stay below its limit
(`passed_through` and `unsettled` must be 0). `overshoot` (toward corners) is reported, not
bounded: wedged into a corner of half-angle b, a wall penetration p reads as p / sin b
along the push."""


def check_module(xml_path: Path) -> dict[str, float]:
    """Run the drop and side-push checks on one MJCF; return its figures (m unless said).

    drop_rest_error           |peg frame - bottom frame| at rest after the drop
    drop_penetration          floor penetration at rest after the drop
    face_move_over_clearance  largest move along the push towards a face, at rest, minus
                              the clearance (<= 0: never beyond the clearance)
    face_move_over_free       the same minus the seated free travel towards that face
    face_move_transient_over_clearance  the same at any step (the impact, reported only:
                              the issue bounds where the peg ends, `passed_through` bounds
                              every step)
    seated_free_over_clearance  largest seated free travel towards a face minus the
                              clearance (geometry: <= 0 up to the STL's float32 rounding)
    face_penetration_at_rest  deepest wall/floor overlap at rest, face pushes
    overshoot                 largest move beyond the free travel along its own direction,
                              at rest, over every push (faces, corners, even directions)
    penetration_at_rest       deepest overlap at rest, every push
    penetration_transient     deepest overlap at any step, every push (drop included)
    passed_through            1 if any push or the drop went through a wall, else 0
    unsettled                 number of runs that did not come to rest
    pushes                    side pushes run; seconds: wall time
    """
    t0 = time.perf_counter()
    drop = drop_test(xml_path)
    faces = side_face_angles(xml_path)
    # corners of a 32-gon ("circle") are 169 deg wide: the 8 even directions cover them
    others = corner_angles(faces) if len(faces) <= 8 else []
    others += [2 * 3.141592653589793 * k / EVEN_DIRECTIONS for k in range(EVEN_DIRECTIONS)]
    kw = {"force": SIDE_FORCE, "axial_force": HOLD_DOWN, "gravity": GRAVITY}
    face = side_push_test(xml_path, directions=faces, **kw)
    other = side_push_test(xml_path, directions=others, **kw)
    c = face["clearance"]
    along, free = face["along_at_rest"], face["seated_free_travel"]
    over_free = [a - f for a, f in zip(along, free, strict=True)]
    return {
        "drop_rest_error": drop["rest_distance"],
        "drop_penetration": drop["max_penetration"],
        "face_move_over_clearance": max(along) - c,
        "face_move_over_free": max(over_free),
        "face_move_transient_over_clearance": max(face["along"]) - c,
        "seated_free_over_clearance": max(face["seated_free_travel"]) - c,
        "face_penetration_at_rest": face["max_penetration_at_rest"],
        "overshoot": max(face["max_overshoot"], other["max_overshoot"]),
        "penetration_at_rest": max(
            face["max_penetration_at_rest"], other["max_penetration_at_rest"]
        ),
        "penetration_transient": max(
            face["max_penetration"], other["max_penetration"], drop["max_penetration_transient"]
        ),
        "passed_through": float(face["passed_through"] or other["passed_through"]),
        "unsettled": float(
            (not drop["reached_floor"]) + (not face["settled"]) + (not other["settled"])
        ),
        "pushes": float(len(faces) + len(others)),
        "seconds": time.perf_counter() - t0,
    }


ASSEMBLY_LIMITS: dict[str, float] = {
    "drop_rest_error": 0.2e-3,
    "drop_penetration": 0.1e-3,
    "move_over_free": 0.1e-3,
    "penetration_at_rest": 0.1e-3,
}
"""The bounds (m) on an assembly step's figures (`check_assembly_step`); `passed_through`
must be 0. Settling is reported, not bounded: see `jitter`."""


def check_assembly_step(job: tuple[Path, str, float | None]) -> dict[str, float]:
    """The drop and the side pushes of one step of an assembly: job = (assembly.xml, the
    step's part, a physics step finer than the file's or None). The part moves; the parts
    of earlier steps are fixed where they were inserted; later ones are absent. The side
    pushes go in 8 even directions across the axis (faces and corners of a square profile),
    held down the axis as Table I's are. Figures (m unless said):

    drop_rest_error, drop_penetration, penetration_transient, passed_through: as
        `check_module`'s
    move_over_free       largest move along a push at rest beyond the free travel from the
                         seated pose in that direction (MuJoCo's distances on the pieces)
    overshoot, penetration_at_rest: as `check_module`'s
    jitter               largest box the part's origin moved in over a push's last 0.2 s
                         (chatter where a push does not come to rest)
    unsettled            runs that did not come to rest (the drop and the 8 pushes)
    clearance, timestep (s), seconds
    """
    t0 = time.perf_counter()
    xml, part, timestep = job
    drop = drop_test(xml, part=part, timestep=timestep, gravity=GRAVITY)
    push = side_push_test(
        xml, part=part, timestep=timestep, directions=EVEN_DIRECTIONS, force=SIDE_FORCE,
        axial_force=HOLD_DOWN, gravity=GRAVITY,
    )  # fmt: skip
    along, free = push["along_at_rest"], push["seated_free_travel"]
    over_free = [a - f for a, f in zip(along, free, strict=True)]
    return {
        "drop_rest_error": drop["rest_distance"],
        "drop_penetration": drop["max_penetration"],
        "move_over_free": max(over_free),
        "overshoot": push["max_overshoot"],
        "penetration_at_rest": push["max_penetration_at_rest"],
        "penetration_transient": max(push["max_penetration"], drop["max_penetration_transient"]),
        "jitter": max(push["jitter"]),
        "passed_through": float(push["passed_through"]),
        "unsettled": float((not drop["reached_floor"]) + (not push["settled"])),
        "clearance": push["clearance"],
        "seconds": time.perf_counter() - t0,
    }


def failures(figures: dict[str, float]) -> list[str]:
    """The bounds a module's (or an assembly step's) figures break, as readable strings
    (empty: it passes)."""
    assembly = "move_over_free" in figures
    limits = ASSEMBLY_LIMITS if assembly else LIMITS
    bad = [
        f"{k} {figures[k] * 1e3:.4f} mm >= {v * 1e3:g} mm"
        for k, v in limits.items()
        if not figures[k] < v
    ]
    flags = ("passed_through",) if assembly else ("passed_through", "unsettled")
    bad += [k for k in flags if figures[k]]
    return bad


def main(argv: list[str] | None = None) -> int:
    from assetgen.dataset.spec import resolve

    ap = argparse.ArgumentParser(
        prog="python -m assetgen.physics.report",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_arguments(ap)
    args = ap.parse_args(argv)
    return report(resolve(args.dataset)[0], args.limit, args.json, args.workers, args.timestep)


def report(
    root: Path,
    limit: int | None = None,
    json_out: Path | None = None,
    workers: int | None = None,
    timestep: float | None = None,
) -> int:
    """Check the first `limit` (default: all) modules of the dataset at `root` in `workers`
    processes (default: all cores), print the worst figures and the failing modules,
    optionally write per-module figures to `json_out`; exit code 0 when every module
    passes, else 1. Each module is checked alone, so the figures do not depend on `workers`."""
    from assetgen.dataset.reader import Dataset

    ds = Dataset(root)
    ids = list(ds.ids)[:limit]
    from assetgen.families.registry import is_assembly

    if not is_assembly(ds.spec.family):
        if timestep is not None:
            raise ValueError("--timestep is for assembly datasets (Table I: docs/physics.md)")
        jobs: list = [ds.paths(mid)["mjcf"] for mid in ids]
        check = check_module
    else:
        # one row per assembly and step: "<id>/<part>"
        from assetgen.core.inline_mesh import ASSEMBLY_MJCF_FILE

        steps = {mid: [st["part"] for st in ds.module_json(mid)["steps"]] for mid in ids}
        ids = [f"{mid}/{part}" for mid in ids for part in steps[mid]]
        jobs = [(ds.module_dir(r.split("/")[0]) / ASSEMBLY_MJCF_FILE, r.split("/")[1], timestep)
                for r in ids]  # fmt: skip
        check = check_assembly_step
    rows: dict[str, dict[str, float]] = {}
    failed: dict[str, list[str]] = {}
    workers = max(1, min(workers or os.cpu_count() or 1, len(ids)))
    with get_context("fork").Pool(workers) if workers > 1 else nullcontext() as pool:
        results = pool.imap(check, jobs) if pool else map(check, jobs)
        for i, (mid, figures) in enumerate(zip(ids, results, strict=True), 1):
            rows[mid] = figures
            if bad := failures(figures):
                failed[mid] = bad
            print(f"\r{i}/{len(ids)} modules, {len(failed)} failing", end="", file=sys.stderr)
            if json_out and i % SAVE_EVERY == 0 and i < len(ids):
                # an hours-long report stopped part-way keeps the modules it checked
                write_json(json_out, {"modules": rows, "failed": failed, "complete": False},
                           indent=1)  # fmt: skip
    print(file=sys.stderr)
    print(f"{'figure':28s} {'max':>12s}  {'limit':>8s}  module")
    for key in next(iter(rows.values())):
        worst = max(rows, key=lambda m: rows[m][key])
        v = rows[worst][key]
        bounds = ASSEMBLY_LIMITS if "move_over_free" in rows[worst] else LIMITS
        limit = f"{bounds[key] * 1e3:g} mm" if key in bounds else ""
        shown = (
            f"{v * 1e3:9.4f} mm"
            if key not in ("passed_through", "unsettled", "pushes", "seconds", "timestep")
            else f"{v:12.3f}"
        )
        print(f"{key:28s} {shown:>12s}  {limit:>8s}  {worst}")
    for mid, bad in failed.items():
        print(f"FAIL {mid}: " + "; ".join(bad))
    what = "modules" if check is check_module else "assembly steps"
    print(f"{len(ids) - len(failed)}/{len(ids)} {what} pass")
    if json_out:
        # atomically: a report interrupted mid-write never replaces a finished one
        write_json(json_out, {"modules": rows, "failed": failed, "complete": True}, indent=1)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
