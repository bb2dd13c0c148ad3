"""The engine registry: every engine behind one interface, found by name, loaded lazily, and
no engine name compared anywhere else."""

from __future__ import annotations

import argparse
import ast
import subprocess
import sys
from pathlib import Path

import pytest

from sim.engines.base import EngineSim
from sim.engines.registry import (
    DEFAULT_ENGINE,
    ENGINES,
    REFERENCE_FIELDS,
    add_engine_argument,
    engine_names,
    get_engine,
)
from tests.test_layout import ROOT, repository_files

REGISTRY = ROOT / "sim" / "engines" / "registry.py"


def test_importing_the_registry_loads_no_engine() -> None:
    code = (
        "import sys, sim.engines.registry\n"
        "heavy = [m for m in ('mujoco', 'sapien', 'warp', 'mujoco_warp', 'torch', 'numba', "
        "'sim.env') if m in sys.modules]\n"
        "print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, check=True).stdout.strip()  # fmt: skip
    assert out == "", f"importing the registry loaded {out}"


def test_every_entry_names_what_exists() -> None:
    """Each "module:attribute" of every engine resolves (where its extra is installed), and
    its simulation class fills in the one interface."""
    assert engine_names()[0] == DEFAULT_ENGINE
    for spec in ENGINES.values():
        for field in REFERENCE_FIELDS:
            ref = getattr(spec, field)
            if ref is None:
                continue
            module, _, attr = ref.partition(":")
            assert (ROOT / (module.replace(".", "/") + ".py")).is_file(), (spec.name, ref)
            source = (ROOT / (module.replace(".", "/") + ".py")).read_text()
            assert f"def {attr}(" in source or f"class {attr}" in source, (spec.name, ref)
    cls = get_engine(DEFAULT_ENGINE).load("sim")
    assert issubclass(cls, EngineSim)
    assert cls.saves_state == get_engine(DEFAULT_ENGINE).saves_state


@pytest.mark.parametrize("name", list(ENGINES))
def test_the_flags_of_the_class_match_the_registry(name: str) -> None:
    spec = get_engine(name)
    try:
        cls = spec.load("sim")
    except ImportError as e:  # an optional extra not installed
        pytest.skip(f"{name}: {e}")
    assert issubclass(cls, EngineSim)
    assert cls.saves_state == spec.saves_state
    assert cls.parks_idle == spec.parks_idle
    assert cls.rotates_modules == (not spec.one_env_per_module)


def test_an_unknown_engine_lists_the_valid_ones() -> None:
    with pytest.raises(ValueError, match="valid engines: mujoco, physx, mujoco-warp"):
        get_engine("bullet")
    from sim.env import PegInHoleVecEnv

    with pytest.raises(ValueError, match="engine 'bullet' is not registered"):
        PegInHoleVecEnv([object()], 1, engine="bullet")  # type: ignore[list-item]


def test_the_engine_flag_leaves_options_for_code_that_never_imports_the_simulator() -> None:
    p = argparse.ArgumentParser()
    add_engine_argument(p, "engine")
    assert p.parse_args([]).engine_options == {}
    assert p.parse_args(["--sim", DEFAULT_ENGINE]).engine_options == {}
    other = engine_names()[1]
    args = p.parse_args(["--sim", other])
    assert args.sim == other and args.engine_options == {"engine": other}
    with pytest.raises(SystemExit):
        p.parse_args(["--sim", "bullet"])


def engine_name_literals(source: str, names: set[str]) -> list[int]:
    """Lines where an engine's name is compared (==, !=, in, not in, a match case) or keys a
    literal table by engine (a dict whose keys are all engine names): the places where a
    registry's field belongs."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        parts: list[ast.AST] = []
        if isinstance(node, ast.Compare):
            parts = [node.left, *node.comparators]
        elif isinstance(node, ast.Dict):
            keys = [k for k in node.keys if k is not None]
            if keys and all(isinstance(k, ast.Constant) and k.value in names for k in keys):
                parts = keys
        elif isinstance(node, ast.MatchValue):
            parts = [node.value]
        for part in parts:
            for sub in ast.walk(part):
                if isinstance(sub, ast.Constant) and sub.value in names:
                    lines.append(part.lineno)
    return sorted(set(lines))


def test_no_engine_name_is_compared_outside_the_registry() -> None:
    names = set(ENGINES)
    offenders = []
    for path in repository_files(ROOT):
        if path.suffix != ".py" or path == REGISTRY or path.parts[len(ROOT.parts)] == "tests":
            continue
        for line in engine_name_literals(path.read_text(), names):
            offenders.append(f"{path.relative_to(ROOT)}:{line}")
    assert not offenders, offenders


def test_the_finder_finds_comparisons_and_tables() -> None:
    names = {"physx", "mujoco"}
    src = (
        "if engine == 'physx':\n    pass\n"
        "x = engine in ('mujoco', 'other')\n"
        "LABELS = {'physx': 'PhysX'}\n"
        "ok = run(engine='physx')\n"
        "fields = {'physx': 1, 'timestep': 2}\n"
        "EXTRAS = {'sapien': ('physx',)}\n"
    )
    assert engine_name_literals(src, names) == [1, 3, 4]


def test_every_engine_has_a_folder(tmp_path: Path) -> None:
    """A new engine is a folder under sim/engines/ and an entry here."""
    for spec in ENGINES.values():
        folder = spec.sim.split(":")[0].rsplit(".", 1)[0]
        assert folder.startswith("sim.engines."), spec.sim
        assert (ROOT / folder.replace(".", "/") / "__init__.py").is_file()
