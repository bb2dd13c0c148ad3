"""The contact stress benchmark (sim/bench/stress/): the project's physics meets the
contact targets on test-split modules, the benchmark sees soft contacts where they are, and
the exported file behaves as the simulator's model does."""

from __future__ import annotations

from dataclasses import replace

import pytest

from assetgen.core.mujoco_config import PhysicsConfig, physics_for, physics_from_record
from sim.bench.stress.cases import HoleGeometry, StressConfig
from sim.bench.stress.figures import format_summary, summarize, targets
from sim.bench.stress.mujoco import stress
from tests.test_sim_common import modules, sim_dataset

# two modules of the test split (a squashed polygon and a taller peg); every case family
FAST = StressConfig(max_faces=4, even=4, rim_directions=2)


@pytest.fixture(scope="module")
def project() -> list[dict]:
    mods = list(modules()[:2])
    return stress(mods, physics_for(mods[0].clearance), FAST, nthread=1)


def test_project_physics_meets_the_contact_targets(project) -> None:
    s = summarize(project, modules()[0].clearance)
    print(s)
    assert s["pushes"] > 0 and s["impacts"] > 0
    assert s["passed_through"] == 0
    assert s["penetration_p99"] <= 0.25 * s["clearance"]
    assert s["penetration_worst"] <= 0.5 * s["clearance"]
    assert s["rest_depth_worst"] <= 0.05 * s["clearance"]


def test_pressed_pegs_come_to_rest(project) -> None:
    """Pushed from the design pose into every face and corner at full command and at twice
    its force, no peg chatters over the last 0.25 s of 1.5 s. A peg still moving then is
    settling one way: the velocity controller holds no orientation, so the contact's torque
    tilts the peg slowly until a second wall stops it. Pushed for 4 s, every straight push
    has come to rest."""
    s = summarize(project, modules()[0].clearance)
    assert s["straight_chattering"] == 0 and s["twisting_chattering"] == 0
    drifting = [r for r in project if r["kind"] == "push" and r["moving"]]
    assert all(r["rest_speed"] < 0.5e-3 for r in drifting), drifting
    mods = list(modules()[1:2])  # the module whose pegs tilt longest
    cfg = replace(FAST, cases=("push",), push_time=4.0, twists=(False,))
    long = summarize(stress(mods, physics_for(mods[0].clearance), cfg, nthread=1), 1e-3)
    assert long["straight_not_at_rest"] == 0, long


def test_sliding_friction_is_the_configured_coefficient(project) -> None:
    runs = [r for r in project if r["kind"] == "friction"]
    assert sorted({r["mu"] for r in runs}) == [0.1, 0.5, 1.0]
    for r in runs:
        assert r["slide_speed"] > 0.01, r  # it slides: the figure is kinetic friction
        assert r["mu_effective"] == pytest.approx(r["mu"], rel=0.05), r


def test_no_rebound_with_the_actuators_off(project) -> None:
    e = [r["restitution"] for r in project if r["kind"] == "rebound"]
    assert len(e) >= 3 and max(e) <= 0.1, e


def test_one_case_family_gets_its_own_figures_and_targets(project) -> None:
    """`--cases impact` alone: the impacts' penetration rows and targets, none of the pushes'
    or of a family not run."""
    impacts = [r for r in project if r["kind"] == "impact"]
    s = summarize(impacts, modules()[0].clearance)
    rows = dict(format_summary(s))
    assert "transient penetration, worst" in rows and "  impacts: worst / p99" in rows
    assert "straight pushes not at rest" not in rows
    assert "rebound e (actuators off), worst" not in rows
    names = set(targets(s))
    assert "no pass-through" in names and "every straight push at rest" not in names
    assert "friction within 5 %" not in names


def test_the_benchmark_sees_soft_contacts() -> None:
    """Under the 5 ms physics of version 1 the same pushes sink several times deeper: the
    figures measure the contacts, not the benchmark's own limits."""
    old = physics_from_record(None)[1]
    mods = list(modules()[:1])
    cfg = replace(FAST, cases=("push", "impact"))
    s = summarize(stress(mods, old, cfg, nthread=1), mods[0].clearance)
    assert s["penetration_p99"] > 0.5 * s["clearance"]
    assert not targets(s)["penetration p99 <= 25 % (1, 0.5 mm) / 50 % (0.25 mm) of the clearance"]


def test_exported_file_and_simulator_model_agree() -> None:
    """The module's peg_in_hole.xml, stepped as it is, gives the simulator model's figures."""
    mods = list(modules()[:1])
    cfg = replace(FAST, cases=("push",), max_faces=2, even=2, twists=(False,), doubles=(False,))
    mjcf = [str(sim_dataset() / "modules" / mods[0].id / "peg_in_hole.xml")]
    a = stress(mods, physics_for(mods[0].clearance), cfg, nthread=1)
    b = stress(mods, physics_for(mods[0].clearance), cfg, mjcf=mjcf, nthread=1)
    assert [r["label"] for r in a] == [r["label"] for r in b]
    for x, y in zip(a, b, strict=True):
        assert x["penetration"] == pytest.approx(y["penetration"], abs=2e-6), (x, y)
        assert x["passed_through"] == y["passed_through"]


def test_hole_geometry_tells_inside_from_outside() -> None:
    a = modules()[0]
    geo = HoleGeometry.of(a, 8)
    design = geo.design_pose()[:3]
    beyond, below = geo.outside(design)
    assert beyond < -1e-3 and below == pytest.approx(-a.clearance)
    # a millimetre across the face plane the hole reaches toward a face; just short of it
    angle = geo.faces[0]
    edge = geo.edge(design, angle)
    assert 0 < geo.outside(design + (edge + 1e-3) * geo.direction(angle))[0] < 1e-3
    assert -1e-3 < geo.outside(design + (edge - 1e-3) * geo.direction(angle))[0] < 0
    assert geo.outside(design - 0.004 * geo.axis)[1] == pytest.approx(0.003)


def test_physics_for_finer_clearances_steps_finer() -> None:
    coarse, fine = physics_for(1e-3), physics_for(0.25e-3)
    assert fine.timestep < coarse.timestep
    for p in (coarse, fine):
        assert p.timestep * p.substeps == pytest.approx(0.02)  # 50 Hz control either way
        assert p.contact_timeconst >= p.timestep
        p.validate()
    assert PhysicsConfig() == coarse


def test_contact_table_puts_runs_side_by_side(project) -> None:
    """benchmarks/contact_table.py: one column per run, each target met or missed; a run
    without a case (pushes only) shows '–' for its figures instead of failing."""
    from benchmarks.contact_table import table

    full = summarize(project, modules()[0].clearance)
    pushes = summarize([r for r in project if r["kind"] == "push"], modules()[0].clearance)
    docs = [{"summaries": [s], "seconds": 1.0} for s in (full, pushes)]
    lines = table(docs, ["all", "pushes"]).splitlines()
    assert lines[0] == "| figure | all | pushes |"
    friction = next(line for line in lines if line.startswith("| sliding friction"))
    assert friction.endswith("| – |") and friction.split("|")[2].strip()[0].isdigit()
    assert "| target: no pass-through | met | met |" in lines


def test_a_pass_through_is_a_peg_inside_the_module() -> None:
    """The figures count a peg beyond the hole's sides below the surface, inside the module's
    footprint, or below the floor inside the hole, as passed through; a peg that climbed out
    of its hole and left over the plate's edge (below the surface's level, and below the
    far reach of a tilted floor's plane) as having left the hole, not as passed through."""
    import numpy as np

    from sim.bench.stress.cases import Run
    from sim.bench.stress.figures import run_figures

    asset = modules()[0]
    geo = HoleGeometry.of(asset, 4)
    axis, down = geo.rot[:, 2], -geo.rot[:, 2]
    side = geo.direction(float(geo.faces[0]))
    start = geo.pos + 0.002 * axis
    n = 200
    t = np.linspace(0.0, 1.0, n)[:, None]
    edge = np.array([geo.footprint + 0.05, 0.0, 0.0])
    paths = {
        "into the plate": start + t * 0.06 * side + t * 0.002 * down,  # beyond, below: inside
        "through the floor": start + t * 0.01 * down,
        # up out of the hole, over the surface past the plate's edge, then below its level
        "out and over the edge": np.where(
            t < 0.5, start + t * 0.12 * axis, edge + np.where(t < 0.75, 0.01, -0.02) * [0, 0, 1]
        ),
    }
    runs = [Run("push", k, "base", np.zeros(7), np.zeros(6), lambda x: x, 1.0) for k in paths]
    pos = np.stack(list(paths.values()))
    quat = np.tile([1.0, 0, 0, 0], (3, n, 1))
    zeros = np.zeros((3, n, 3))
    recs = run_figures(runs, pos, quat, zeros, zeros, np.zeros((3, n, 2)), geo,
                       StressConfig(), 0.005, 1.0)  # fmt: skip
    got = {r["label"]: (r["passed_through"], r["left_hole"]) for r in recs}
    assert got == {
        "into the plate": (True, False),
        "through the floor": (True, False),
        "out and over the edge": (False, True),
    }, got


def _one_step(tmp_path, name: str, seed: int):
    """A family's module written to tmp_path, as the simulator takes its one step, and its
    params."""
    from assetgen.dataset.families import family
    from sim.assets.assembly import AssemblyStages

    fam = family(name)
    record = fam.write(seed, fam.sampler(), tmp_path, ("mjcf",), None, 0.0)
    return AssemblyStages(tmp_path / f"{seed:06d}").stage(0), record["params"]


def test_hole_geometry_of_a_carrier_is_its_reference_pegs(tmp_path) -> None:
    """On a multi-peg carrier the benchmark aims at the reference peg's hole: its n sides,
    each the clearance out from the peg."""
    import numpy as np

    asset, params = _one_step(tmp_path, "multi-peg", 1)
    _, _, n, r, _ = params["pegs"][0]
    geo = HoleGeometry.of(asset, 64)
    assert len(geo.normals) == n
    assert np.allclose(geo.offsets, r * np.cos(np.pi / n) + asset.clearance, atol=1e-6)
    # inside the reference hole, beyond it at the next peg's place
    x, y = params["pegs"][1][:2]
    beyond, _ = geo.outside(geo.pos + np.array([[0.0, 0.0, 0.0], [x, y, 0.0]]) @ geo.rot.T)
    assert beyond[0] < 0 < beyond[1]


def test_hole_geometry_of_a_non_convex_peg_is_its_sections_hull(tmp_path) -> None:
    import numpy as np
    from scipy.spatial import ConvexHull

    asset, _ = _one_step(tmp_path, "profile", 0)
    geo = HoleGeometry.of(asset, 64)
    corners = asset.peg.vertices[np.abs(asset.peg.vertices[:, 2]) < 1e-9, :2]
    hull = corners[ConvexHull(corners).vertices]
    assert len(geo.normals) == len(hull)
    # every hull corner lies the clearance inside the outline's planes, on at least two
    gap = geo.offsets[None, :] - hull @ geo.normals[:, :2].T
    assert gap.min() > asset.clearance - 1e-6
    assert (np.isclose(gap, asset.clearance, atol=1e-6).sum(axis=1) >= 2).all()
