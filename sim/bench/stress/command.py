"""The contact stress benchmark's command, on any registered engine (its runner is the one
sim/engines/registry.py names): the runs of every module, a summary a clearance, the targets
each meets, and the JSON record.

    assetgen bench contacts DATASET [--limit N] [--set FIELD=VALUE ...] [--source sim|mjcf]
"""

from __future__ import annotations

import time
from dataclasses import asdict

from assetgen.core.mujoco_config import LEGACY_PHYSICS, PHYSICS_VERSION, physics_for
from assetgen.core.recorded_path import recorded_path
from sim.bench.stress.cases import StressConfig
from sim.bench.stress.figures import format_summary, summarize, targets
from sim.engines.registry import get_engine
from sim.task.config import PhysicsConfig, TaskConfig

ROBOT_CASES = ("push", "impact")
"""The cases a robot holding the peg runs. The friction runs infer the contact's forces from
the actuators' gain, which leaves out the arm's own joint forces, and the rebound runs let go
of the peg, which an arm does not: both measure the contact model, which the arm leaves as it
is (the same geoms and parameters), so the floating peg's figures stand for them."""


def main(args) -> int:
    """`assetgen bench contacts DATASET`: args.dataset, args.limit, args.physics_version (an
    earlier version's settings; default: the project's for the dataset's clearance), args.set
    (overrides of the engine's settings: PhysicsConfig, or the engine's own), args.source (sim
    or mjcf), args.cases, args.threads, args.json (a file), args.sim (a registered engine,
    whose runner sim/engines/registry.py names)."""
    import sys
    from dataclasses import replace

    from assetgen.core.atomic_file import write_json
    from assetgen.core.overrides import parse_overrides
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import resolve
    from sim.assets.task_modules import load_modules

    root, _ = resolve(args.dataset)
    ds_spec = Dataset(root).spec
    config = ds_spec.config
    if ds_spec.assembly and (args.source == "mjcf" or getattr(args, "robot", None)):
        raise ValueError(
            f"{args.dataset}: a {ds_spec.family} dataset runs in the simulator's models of its "
            "one step, floating: drop --source mjcf and --robot"
        )
    if getattr(config, "hole_chamfered", False):
        raise ValueError(
            f"{args.dataset}: its holes' entrances are chamfered, and the benchmark's pushes "
            "and impacts aim at the unchamfered entrance's edges: run it on a dataset "
            "without --hole-chamfer"
        )
    ids = Dataset(root).ids
    if args.limit is not None:
        if args.limit < 1:
            raise ValueError(f"--limit {args.limit}: give at least 1 module")
        ids = ids[: args.limit]
    version = getattr(args, "physics_version", None)
    if version is None or version == PHYSICS_VERSION:
        base = None
    elif version in LEGACY_PHYSICS:
        base = replace(PhysicsConfig(), **LEGACY_PHYSICS[version])
    else:
        known = sorted([*LEGACY_PHYSICS, PHYSICS_VERSION])
        raise ValueError(f"--physics-version {version}: the versions are {known}")
    from sim.robots.registry import check_robot

    robot = check_robot(getattr(args, "robot", None), get_engine(getattr(args, "sim", None)).name)
    cfg = StressConfig()
    if args.cases:
        cases = tuple(args.cases.split(","))
        bad = sorted(set(cases) - set(cfg.cases))
        if bad:
            raise ValueError(f"--cases: unknown {bad}; valid: {','.join(cfg.cases)}")
        if robot is not None and set(cases) - set(ROBOT_CASES):
            raise ValueError(f"--cases {args.cases} with --robot: a robot runs "
                             f"{','.join(ROBOT_CASES)} only (see ROBOT_CASES)")  # fmt: skip
        cfg = replace(cfg, cases=cases)
    elif robot is not None:
        cfg = replace(cfg, cases=ROBOT_CASES)
    push_time = getattr(args, "push_time", None)
    if push_time is not None:
        if not push_time > 2 * cfg.window:
            raise ValueError(f"--push-time {push_time}: give more than {2 * cfg.window} s")
        cfg = replace(cfg, push_time=push_time)
    assets = load_modules(root, ids)  # Table I's modules, or a one-step family's step
    refused: dict[str, str] = {}
    if robot is not None:
        if args.source == "mjcf" or version is not None or args.set:
            raise ValueError(f"--robot {robot.name} runs the simulator's models at the "
                             "project's physics: drop --source mjcf, --physics-version and "
                             "--set")  # fmt: skip
        refuses = robot.load("refuses")
        refused = {a.id: why for a in assets if (why := refuses(a)) is not None}
        assets = [a for a in assets if a.id not in refused]
        if not assets:
            raise ValueError(next(iter(refused.values())))
    # the dataset's clearance sets the step (physics_for), unless an older version is asked
    base = base or physics_for(min(a.clearance for a in assets))
    spec = get_engine(getattr(args, "sim", None))
    settings_class = spec.load("settings")
    on_physics = settings_class is PhysicsConfig  # else the engine has settings of its own
    # --set: the engine's settings (PhysicsConfig, or the engine's own)
    on_mujoco = (args.set or []) if on_physics else []
    physics = replace(base, **parse_overrides(PhysicsConfig, on_mujoco)).validate()
    mjcf = None
    if args.source == "mjcf":
        ds = Dataset(root)
        mjcf = [str(ds.module_dir(i) / "peg_in_hole.xml") for i in ids]

    def progress(done: int, total: int) -> None:
        print(f"\r{done}/{total} modules", end="", file=sys.stderr, flush=True)

    if not on_physics and (mjcf is not None or version is not None):
        raise ValueError(f"--sim {spec.name} takes its settings from {settings_class.__name__} "
                         "(--set FIELD=VALUE): drop --source and --physics-version")  # fmt: skip
    if mjcf is not None and not spec.reads_mjcf:
        raise ValueError(f"--sim {spec.name} runs the simulator's models: drop --source mjcf")
    settings = (
        physics if on_physics else settings_class(**parse_overrides(settings_class, args.set or []))
    )
    files = {"mjcf": mjcf, "nthread": args.threads} if spec.reads_mjcf else {}
    t0 = time.perf_counter()
    if robot is not None:
        records = robot.load("stress")(assets, cfg, TaskConfig(physics=physics),
                                       progress=progress, nthread=args.threads)  # fmt: skip
    else:
        records = spec.load("stress")(assets, cfg, TaskConfig(physics=physics), settings,
                                      progress=progress, **files)  # fmt: skip
    print(file=sys.stderr)
    seconds = time.perf_counter() - t0
    clearances = sorted({a.clearance for a in assets})
    by = {a.id: a.clearance for a in assets}
    summaries = [summarize([r for r in records if by[r["module"]] == c], c) for c in clearances]
    for s in summaries:
        print(
            f"{root}: {s['modules']} modules, clearance {s['clearance'] * 1e3:g} mm, "
            f"{'exported files' if mjcf else 'simulator models' if spec.reads_mjcf else spec.label}"
            f"{f', held by the {robot.label}' if robot else ''}, {seconds:.0f} s"
        )
        if refused:
            print(f"  refused by the {robot.label}: {', '.join(sorted(refused))}")
        unstarted = sum(r.get("arm_unstarted", 0) for r in records)
        if robot is not None:
            print(f"  runs the arm could not start: {unstarted}")
        rows = format_summary(s)
        width = max(len(k) for k, _ in rows)
        for k, v in rows:
            print(f"  {k:<{width}}  {v}")
        for name, ok in targets(s).items():
            print(f"  [{'met' if ok else 'MISSED'}] {name}")
    if args.json:
        write_json(
            args.json,
            {
                "dataset": recorded_path(root),
                "source": args.source,
                "engine": spec.name,
                **({"robot": robot.name, "refused_modules": sorted(refused)} if robot else {}),
                "physics": asdict(settings) if mjcf is None else "the exported files'",
                "physics_version": version or PHYSICS_VERSION,
                "stress": asdict(cfg),
                "seconds": seconds,
                "summaries": [s | {"targets": targets(s)} for s in summaries],
                "runs": records,
            },
        )
    return 0
