"""The contact stress benchmark on MuJoCo Warp (sim/bench/stress/warp.py), run on Warp's CPU
device (float32, the GPU's kernels): the runs give MuJoCo's figures on the CPU, and every mesh
a world can take has the face polygons multiccd needs."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("warp", reason="the warp extra: pip install -e '.[warp]'")
pytest.importorskip("mujoco_warp", reason="the warp extra: pip install -e '.[warp]'")

from assetgen.core.mujoco_config import physics_for
from sim.assets.loading import load_dataset
from sim.bench.stress.cases import StressConfig
from sim.bench.stress.mujoco import stress
from sim.bench.stress.warp import stress_warp
from sim.task.config import TaskConfig
from tests.test_warp import _dataset

# every case family, few directions, pushes of 0.6 s: 13 runs of one module
SMALL = StressConfig(max_faces=2, even=0, twists=(False,), doubles=(False,), rim_directions=1,
                     push_time=0.6)  # fmt: skip


def test_the_runs_give_mujocos_figures() -> None:
    """Pushes into the walls as deep as on the CPU and at rest, friction runs at the CPU's
    sliding speed, no rebound; impacts (onto the floor, the rim, tilted) at rest as deep as
    on the CPU and within the contact targets, their transient depth within the targets."""
    mods = load_dataset(_dataset())[:1]
    physics = physics_for(mods[0].clearance)
    warp = stress_warp(mods, SMALL, TaskConfig(physics=physics), device="cpu")
    cpu = stress(mods, physics, SMALL, nthread=1)
    assert [r["label"] for r in warp] == [r["label"] for r in cpu]
    kinds = {r["kind"] for r in warp}
    assert kinds == {"push", "impact", "friction", "rebound"}, kinds
    clearance = mods[0].clearance
    for w, c in zip(warp, cpu, strict=True):
        label = (w["kind"], w["label"])
        if w["kind"] == "push":
            assert w["penetration"] == pytest.approx(c["penetration"], rel=0.05), label
            assert not w["moving"] and not c["moving"], label
            assert not w["passed_through"], label
        elif w["kind"] == "friction":
            assert w["slide_speed"] == pytest.approx(c["slide_speed"], rel=0.02), label
        elif w["kind"] == "rebound":
            assert w["restitution"] <= 0.1 and c["restitution"] <= 0.1, label
        else:
            assert not w["moving"] and not w["passed_through"], label
            assert w["rest_depth"] == pytest.approx(c["rest_depth"], abs=1e-6), label
            assert w["rest_depth"] <= 0.05 * clearance, label
            assert w["penetration"] <= 0.25 * clearance, label


def test_every_mesh_a_world_can_take_has_polygons() -> None:
    """MuJoCo builds face polygons only for meshes a geom collides with or whose inertia
    comes from the hull; the worlds take their meshes by id, and without polygons MuJoCo
    Warp's multiccd keeps one contact: a peg pressed flat onto the hole's floor sank
    0.23 mm, where MuJoCo's four contacts hold it within 0.001 mm."""
    from sim.engines.warp.batch import WarpBatchSim

    mods = load_dataset(_dataset())
    sim = WarpBatchSim(mods[:1], TaskConfig(physics=physics_for(0.001)), spare_assets=mods[1:],
                       device="cpu")  # fmt: skip
    taken = np.unique(np.concatenate([v for v in sim._dataid.values()]))
    names = [sim.mjm.mesh(int(j)).name for j in taken]
    polygons = sim.mjm.mesh_polynum[taken]
    assert all(polygons[k] > 0 for k, name in enumerate(names) if name != "park"), dict(
        zip(names, polygons.tolist(), strict=True)
    )
    assert len(names) > 3 * 30


def test_bench_contacts_runs_on_warp(tmp_path, capsys) -> None:
    from cli import main

    out = tmp_path / "stress.json"
    argv = ["bench", "contacts", str(_dataset()), "--sim", "mujoco-warp", "--allow-cpu",
            "--limit", "1", "--cases", "rebound", "--json", str(out)]  # fmt: skip
    assert main(argv) == 0
    assert "MuJoCo Warp" in capsys.readouterr().out
    doc = json.loads(out.read_text())
    assert doc["engine"] == "mujoco-warp" and len(doc["runs"]) >= 3
    assert doc["summaries"][0]["targets"]["rebound e <= 0.1"]
    assert main([*argv[:-2], "--source", "mjcf"]) != 0  # the exported files: MuJoCo's own
