"""docs/results/ is what `python -m benchmarks.results_pages` makes of the tracked evaluation
files, and every figure on it was measured on the current physics."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from assetgen.core.mujoco_config import PHYSICS_VERSION
from benchmarks.results_pages import PAGES, RESULTS, ROOT, page_table, readme_table


@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_page_is_generated_from_its_files(page) -> None:
    table = RESULTS / page.name / "table.md"
    assert table.exists(), f"{table} missing: run python -m benchmarks.results_pages"
    assert table.read_text().strip() == page_table(page).strip(), (
        f"{table} is stale: run python -m benchmarks.results_pages"
    )


@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_page_inputs_are_on_the_current_physics(page) -> None:
    files = [f for r in page.run_paths() for f in sorted(r.glob("eval_*.json"))]
    for b in page.baseline_paths():
        files += sorted(b.glob("*.json")) if b.is_dir() else [b]
    assert files, f"page {page.name} has no evaluation file"
    for f in files:
        doc = json.loads(f.read_text())
        assert doc.get("physics_version") == PHYSICS_VERSION, (
            f"{f.relative_to(ROOT)} was measured on physics version "
            f"{doc.get('physics_version', 1)}, not {PHYSICS_VERSION}: evaluate it again"
        )
        assert doc["attempts"] == page.attempts, (
            f"{f.relative_to(ROOT)}: {doc['attempts']} attempts, not the page's {page.attempts}"
        )


def test_readme_table_is_its_page() -> None:
    (page,) = [p for p in PAGES if p.readme]
    assert readme_table() == page_table(page, compact=True).strip(), (
        "README.md's results table is stale: run python -m benchmarks.results_pages"
    )


def test_referee_page_is_generated_from_its_files() -> None:
    from benchmarks.results_pages import REFEREE, referee_table

    table = RESULTS / "referee" / "table.md"
    assert table.exists() and table.read_text() == referee_table(), (
        f"{table} is stale: run python -m benchmarks.results_pages"
    )
    # every PhysX file the page names is a PhysX evaluation on the current physics' splits
    for _agent, split, mujoco, physx in REFEREE:
        for f, engine in ((mujoco, "mujoco"), (physx, "physx")):
            if (ROOT / f).exists():
                doc = json.loads((ROOT / f).read_text())
                assert doc.get("engine", "mujoco") == engine and doc["dataset"] == split, f


def test_assembly_page_is_generated_from_its_files() -> None:
    from benchmarks.results_pages import ASSEMBLY, assembly_table

    table = RESULTS / "assembly" / "table.md"
    assert table.exists() and table.read_text() == assembly_table(), (
        f"{table} is stale: run python -m benchmarks.results_pages"
    )
    files = [ROOT / f for _, f in ASSEMBLY if (ROOT / f).exists()]
    assert files, "the assembly page has no evaluation file"
    for f in files:  # sequences of the current physics, named for their split
        doc = json.loads(f.read_text())
        assert doc["family"] == "profile-bolt" and f.stem.endswith("_" + doc["dataset"]), f
        assert doc.get("physics_version") == PHYSICS_VERSION, f


def test_families_page_is_generated_from_its_files() -> None:
    from benchmarks.results_pages import FAMILIES, FAMILY_SPLITS, families_table

    table = RESULTS / "families" / "table.md"
    assert table.exists() and table.read_text() == families_table(), (
        f"{table} is stale: run python -m benchmarks.results_pages"
    )
    files = sorted((RESULTS / "families").glob("*.json"))
    assert files, "the families page has no evaluation file"
    named = {f"{name}_{split}.json" for _, name in FAMILIES for split in FAMILY_SPLITS}
    named |= {f"stress_{split}.json" for split in FAMILY_SPLITS}  # the contact benchmark's
    for f in files:  # each file is a row: named for its agent and split, the current physics
        doc = json.loads(f.read_text())
        assert f.name in named and f.stem.endswith("_" + Path(doc["dataset"]).name), f
        assert doc.get("physics_version") == PHYSICS_VERSION, f
        assert "summaries" in doc or doc["family"] != "peg-in-hole", f


def test_chamfers_page_is_generated_from_its_files() -> None:
    from benchmarks.results_pages import CHAMFER_AGENTS, CHAMFER_SPLITS, chamfers_table

    table = RESULTS / "chamfers" / "table.md"
    assert table.exists() and table.read_text() == chamfers_table(), (
        f"{table} is stale: run python -m benchmarks.results_pages"
    )
    named = {f"{name}_{split}.json" for _, name in CHAMFER_AGENTS for split, _ in CHAMFER_SPLITS}
    files = sorted((RESULTS / "chamfers").glob("*.json"))
    assert files and {f.name for f in files} <= named
    hashes = {}
    for f in files:  # each file a row, on the current physics; one dataset per split
        doc = json.loads(f.read_text())
        assert f.stem.endswith("_" + Path(doc["dataset"]).name), f
        assert doc.get("physics_version") == PHYSICS_VERSION, f
        assert (
            hashes.setdefault(Path(doc["dataset"]).name, doc["dataset_hash"]) == doc["dataset_hash"]
        ), f


def test_robot_page_is_generated_from_its_files() -> None:
    from benchmarks.results_pages import (
        ROBOT_AGENTS,
        ROBOT_CLEARANCES,
        ROBOT_TRAINED,
        robot_files,
        robot_table,
    )

    table = RESULTS / "robot" / "table.md"
    assert table.exists() and table.read_text() == robot_table(), (
        f"{table} is stale: run python -m benchmarks.results_pages"
    )
    pairs = [
        (*robot_files(a, "panda", suffix), suffix)
        for a in ROBOT_AGENTS
        for _, suffix in ROBOT_CLEARANCES
    ]
    assert any(f.exists() for pair in pairs for f in pair[:2]), "the robot page has no file"
    trained = [
        (f, "panda" if "_panda_" in f.name else None, f.stem.split("test64")[1])
        for _, name in ROBOT_TRAINED
        for f in RESULTS.glob(f"robot/{name}_s*_*_test64*.json")
    ]
    checks = [(f, r, sfx) for free, arm, sfx in pairs for f, r in ((free, None), (arm, "panda"))]
    for f, robot, suffix in checks + trained:  # the current physics; the arm names its settings
        if f.exists():
            doc = json.loads(f.read_text())
            assert doc.get("physics_version") == PHYSICS_VERSION, f
            split = "test" if suffix == "" else "datasets/test64_c025"
            assert doc["dataset"] == split and doc.get("robot") == robot, f
            assert ("arm" in doc) == (robot is not None), f


def test_takeoff_page_is_generated_from_its_runs() -> None:
    from dataclasses import asdict

    from assetgen.core.mujoco_config import physics_for
    from benchmarks.results_pages import filed_runs, takeoff_table

    table = RESULTS / "takeoff" / "table.md"
    assert table.exists() and table.read_text() == takeoff_table(), (
        f"{table} is stale: run python -m benchmarks.results_pages"
    )
    runs = filed_runs("takeoff")
    assert runs, "the take-off page has no run"
    assert "| the recipe | 0 | 0.09 M |" in table.read_text()  # a Table III seed's take-off
    physics = json.loads(json.dumps(asdict(physics_for(0.001))))
    for run in runs:  # the floating peg on the current physics (1 mm, the train split's)
        meta = json.loads((ROOT / run / "config.json").read_text())
        assert meta["physics"] == physics, f"{run}: trained on other physics; train it again"
        assert "robot" not in meta["env_options"], run
