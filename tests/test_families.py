"""The family interface and its registry: both families fill in the same Family, the
registry finds them by folder, `assetgen families` lists their parameters, and a third
family (tests/toy_family/, one folder) plugs in by name: generated, checked, loaded by the
simulator and stepped."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

from assetgen.core.references import load_reference
from assetgen.families import registry
from assetgen.families.interface import ASSEMBLY, MODULE, Family, parameters

ROOT = Path(__file__).resolve().parent.parent


def test_the_folders_are_the_families():
    assert registry.names() == ["multi-peg", "peg-in-hole", "profile", "profile-bolt"]
    for name in registry.names():
        fam = registry.get(name)
        assert isinstance(fam, Family) and fam.name == name and fam.summary
    assert registry.get("peg-in-hole").layout is MODULE
    assert registry.get("profile-bolt").layout is ASSEMBLY


def test_every_layout_reference_resolves():
    pytest.importorskip("viser")
    for layout in (MODULE, ASSEMBLY):
        for stage, ref in layout.references().items():
            assert callable(load_reference(ref)), (layout.name, stage, ref)


def test_every_sampler_field_is_documented():
    for name in registry.names():
        fam = registry.get(name)
        params = parameters(fam)
        assert [p.name for p in params] == [f.name for f in fields(fam.sampler)]
        assert all(p.doc for p in params), [p.name for p in params if not p.doc]
        config = fam.sampler()
        assert isinstance(config.sample(3), fam.params)


def test_an_unknown_family_is_refused_with_the_valid_ones():
    with pytest.raises(ValueError, match=r"unknown family 'nope'; valid families: \['multi-peg"):
        registry.get("nope")
    p = subprocess.run(
        [sys.executable, "cli.py", "sample", "--family", "nope", "--n", "1", "--out", "x"],
        cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    valid = "valid families: ['multi-peg', 'peg-in-hole', 'profile', 'profile-bolt']"
    assert len(lines) == 1 and valid in lines[0]


def test_the_families_command_lists_them():
    p = subprocess.run(
        [sys.executable, "cli.py", "families", "--json"], cwd=ROOT, capture_output=True, text=True
    )
    assert p.returncode == 0, p.stderr
    listed = {f["name"]: f for f in json.loads(p.stdout)}
    assert sorted(listed) == ["multi-peg", "peg-in-hole", "profile", "profile-bolt"]
    bolt = {q["name"]: q for q in listed["profile-bolt"]["parameters"]}
    assert bolt["profile_clearance"]["default"] == 0.25e-3
    assert "socket" in bolt["profile_clearance"]["doc"]
    assert listed["peg-in-hole"]["layout"] == "module"
    table = subprocess.run(
        [sys.executable, "cli.py", "families"], cwd=ROOT, capture_output=True, text=True
    )
    assert table.returncode == 0 and "hole_tilt" in table.stdout and "bolt_diameter" in table.stdout
    assert "star_inner" in table.stdout and "spline" in table.stdout  # names shown as they are


@pytest.fixture
def toy():
    registry.register("cube-peg", "tests.toy_family")
    yield registry.get("cube-peg")
    registry.unregister("cube-peg")


def test_a_family_plugs_in_as_one_folder(toy, tmp_path):
    """Registered by name, the toy family is generated, checked, loaded and stepped."""
    from assetgen.dataset.check import check_dataset
    from assetgen.dataset.generate import generate
    from assetgen.dataset.reader import Dataset
    from assetgen.dataset.spec import DatasetSpec

    assert "cube-peg" in registry.names()
    with pytest.raises(ValueError, match="exists already"):
        registry.register("cube-peg", "tests.toy_family")
    spec = DatasetSpec("toy", 0, 2, toy.sampler(), family="cube-peg")
    s = generate(tmp_path / "toy", spec, workers=1, progress=False)
    assert s.generated == 2 and not s.failures
    assert s.clearance_min_m == pytest.approx(1e-3, abs=1e-6)
    ds = Dataset(tmp_path / "toy")
    assert ds.spec.family == "cube-peg"
    assert sorted(ds.module_json("000000")["files"]) == [
        "assembly.3mf", "assembly.usda", "assembly.xml", "base.stl", "peg.stl"
    ]  # fmt: skip
    assert check_dataset(tmp_path / "toy").ok

    from sim.assets.assembly import load_stage
    from sim.env import PegInHoleVecEnv
    from sim.task.config import EVAL_CONFIG

    stages = [load_stage(ds.module_dir(mid), 0) for mid in ds.ids]
    assert [st.clearance for st in stages] == pytest.approx([1e-3, 1e-3])
    env = PegInHoleVecEnv(stages, num_envs=2, config=EVAL_CONFIG)
    obs = env.reset(seed=0)
    for _ in range(5):
        obs, reward, *_ = env.step(np.zeros((2, 6), np.float32))
    assert np.isfinite(obs).all() and np.isfinite(reward).all()

    pytest.importorskip("viser")
    from preview.assembly import AssemblyView

    view = AssemblyView.load(ds, "000001")
    assert view.parts == ["peg"] and set(view.surfaces) == {"base", "peg"}


def test_the_layout_not_the_name_says_what_a_family_builds(toy, tmp_path, capsys):
    """A family is an assembly by its layout: the toy one is, Table I is not; and `sample
    --clearance-mm` sets any family's first clearance through its sampler."""
    import cli
    from assetgen.dataset.reader import Dataset

    assert registry.is_assembly("cube-peg") and registry.is_assembly("profile-bolt")
    assert not registry.is_assembly(registry.DEFAULT_FAMILY)
    with pytest.raises(ValueError, match="unknown family 'nope'"):
        registry.is_assembly("nope")
    out = tmp_path / "toy"
    argv = ["sample", "--family", "cube-peg", "--n", "1", "--clearance-mm", "0.5",
            "--workers", "1", "--out", str(out)]  # fmt: skip
    assert cli.main(argv) == 0, capsys.readouterr().err
    assert Dataset(out).spec.config.clearance == pytest.approx(0.5e-3)
    assert Dataset(out).module_json("000000")["params"]["clearance"] == pytest.approx(0.5e-3)


def test_registry_after_the_toy_is_gone():
    assert "cube-peg" not in registry.names()


def test_bench_assets_times_any_family(tmp_path) -> None:
    from assetgen.bench import bench_assets

    result = bench_assets(2, 1, tmp_path, "multi-peg")
    assert result["family"] == "multi-peg" and result["failed"] == 0
    assert result["modules_per_s"] > 0 and "checks" in result["step_ms"]
