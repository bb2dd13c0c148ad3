"""The contact stress benchmark on MuJoCo Warp (sim/contact_stress_warp.py), run on Warp's CPU
device (float32, the GPU's kernels): the runs of MuJoCo on the CPU give the same figures, but
for the impacts onto the hole's floor, where MuJoCo Warp finds one contact where MuJoCo's
multiccd finds four (its figures are then MuJoCo's with multiccd off)."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

pytest.importorskip("warp", reason="the warp extra: pip install -e '.[warp]'")
pytest.importorskip("mujoco_warp", reason="the warp extra: pip install -e '.[warp]'")

from assetgen.core.mujoco_config import physics_for  # noqa: E402
from sim.assets import load_dataset  # noqa: E402
from sim.config import TaskConfig  # noqa: E402
from sim.contact_stress import StressConfig, stress  # noqa: E402
from sim.contact_stress_warp import stress_warp  # noqa: E402
from tests.test_warp import _dataset  # noqa: E402

# every case family, few directions, pushes of 0.6 s: 13 runs of one module
SMALL = StressConfig(max_faces=2, even=0, twists=(False,), doubles=(False,), rim_directions=1,
                     push_time=0.6)  # fmt: skip


def test_the_runs_give_mujocos_figures_but_on_the_floor() -> None:
    mods = load_dataset(_dataset())[:1]
    physics = physics_for(mods[0].clearance)
    warp = stress_warp(mods, SMALL, TaskConfig(physics=physics), device="cpu")
    cpu = stress(mods, physics, SMALL, nthread=1)
    single = stress(mods, replace(physics, multiccd=False), SMALL, nthread=1)
    assert [r["label"] for r in warp] == [r["label"] for r in cpu]
    kinds = {r["kind"] for r in warp}
    assert kinds == {"push", "impact", "friction", "rebound"}, kinds
    for w, c, s in zip(warp, cpu, single, strict=True):
        label = (w["kind"], w["label"])
        if w["kind"] == "push":  # against the walls: as deep, and at rest
            assert w["penetration"] == pytest.approx(c["penetration"], rel=0.05), label
            assert not w["moving"] and not c["moving"], label
            assert not w["passed_through"], label
        elif w["kind"] == "friction":
            assert w["slide_speed"] == pytest.approx(c["slide_speed"], rel=0.02), label
        elif w["kind"] == "rebound":
            assert w["restitution"] <= 0.1 and c["restitution"] <= 0.1, label
        elif w["label"] in ("floor", "tilted 0"):
            # resting on the floor: one contact, as MuJoCo without multiccd, 0.2 mm deep
            assert w["rest_depth"] == pytest.approx(s["rest_depth"], rel=0.05), label
            assert w["rest_depth"] > 10 * c["rest_depth"], label
        else:  # the rim: caught by the plate's edge, as on the CPU
            assert w["penetration"] == pytest.approx(c["penetration"], rel=0.3), label


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
