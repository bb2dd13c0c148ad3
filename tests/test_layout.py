"""The layout's contracts: stages import in one direction, no import cycle, every stage says
what it holds, and no file points outside the repository or tells how it came to be."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("assetgen", "sim", "rl", "evaluation", "preview", "benchmarks")
STAGES = (
    "core", "params", "geometry", "families", "checks", "collision", "formats", "dataset",
    "physics",
)  # fmt: skip
"""assetgen's stages in data-flow order: a stage imports only itself and the stages before
it."""


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    found = {"cli": ROOT / "cli.py"}
    for pkg in PACKAGES:
        for path in (ROOT / pkg).rglob("*.py"):
            found[_module_name(path)] = path
    return found


def import_graph() -> dict[str, set[str]]:
    """Project module -> the project modules it imports, lazily (inside functions) or not."""
    modules = _modules()
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        edges = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                # `from pkg import mod` imports the module pkg.mod when there is one
                targets = [
                    f"{node.module}.{a.name}"
                    if f"{node.module}.{a.name}" in modules
                    else node.module
                    for a in node.names
                ]
            else:
                continue
            edges |= {t for t in targets if t in modules and t != name}
        graph[name] = edges
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_cycle_finder_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle():
    assert cycles(import_graph()) == []


def _imports_of(prefix: str) -> set[str]:
    graph = import_graph()
    return {t for m, ts in graph.items() if m == prefix or m.startswith(prefix + ".") for t in ts}


def test_data_flows_one_way():
    """assetgen never imports the simulator, the agents or the viewer; sim reads datasets
    through the shared numpy-only pieces only; rl never imports the simulator."""
    top = {t.split(".")[0] for t in _imports_of("assetgen")}
    assert top <= {"assetgen"}, top
    from_assetgen = {t for t in _imports_of("sim") if t.startswith("assetgen")}
    allowed = ("assetgen.core", "assetgen.dataset.spec", "assetgen.dataset.reader")
    assert all(t.startswith(allowed) for t in from_assetgen), from_assetgen
    assert not {t for t in _imports_of("rl") if t.startswith(("sim", "preview"))}
    assert not {t for t in _imports_of("assetgen.core") if not t.startswith("assetgen.core")}


def _stage(module: str) -> int | None:
    parts = module.split(".")
    if parts[0] != "assetgen" or len(parts) < 2 or parts[1] not in STAGES:
        return None
    return STAGES.index(parts[1])


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    """Imports (at the top or inside functions) from a stage of assetgen to a later one."""
    return [
        f"{m} -> {t}"
        for m, targets in sorted(graph.items())
        for t in sorted(targets)
        if _stage(m) is not None and _stage(t) is not None and _stage(t) > _stage(m)
    ]


def test_stages_only_look_down():
    assert upward_imports(import_graph()) == []


def test_upward_imports_are_found():
    graph = {"assetgen.geometry.polytope": {"assetgen.collision.cell_meshes", "numpy"}}
    assert upward_imports(graph) == ["assetgen.geometry.polytope -> assetgen.collision.cell_meshes"]


@pytest.mark.parametrize("stage", STAGES)
def test_every_stage_says_what_it_holds(stage):
    init = ROOT / "assetgen" / stage / "__init__.py"
    doc = ast.get_docstring(ast.parse(init.read_text()))
    assert doc and len(doc.split()) >= 12, f"{init}: a one-paragraph docstring naming the stage"


# built from parts, so that this file does not match its own pattern
_WORKING_FILES = ("design", "reference")
FORBIDDEN = re.compile(
    "|".join(rf"{name}\.md" for name in _WORKING_FILES)
    + r"|\.\./sha"
    + r"red|[Ii]ss"
    + r"ue #?\d|\bthe le"
    + r"ad\b|\b(this|last) ses"
    + r"sion\b"
    + r"|\bprevious ro"
    + r"und\b"
)


def repository_files(root: Path) -> list[Path]:
    """The files of the checkout at `root` that git tracks or would track (untracked files
    that .gitignore does not ignore), never a virtual environment or a dataset beside them;
    without git, every file outside the folders .gitignore names and `.git`."""
    import subprocess

    try:
        out = subprocess.run(
            ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
            cwd=root, capture_output=True, check=True,
        ).stdout  # fmt: skip
        return sorted(root / p for p in out.decode().split("\0") if p and (root / p).is_file())
    except (OSError, subprocess.CalledProcessError):
        ignored = {".git"}
        gitignore = root / ".gitignore"
        if gitignore.exists():
            ignored |= {
                line.strip().strip("/").rstrip("/*")
                for line in gitignore.read_text().splitlines()
                if line.strip() and not line.startswith("#") and "*" not in line.rstrip("/*")
            }
        return sorted(
            p
            for p in root.rglob("*")
            if p.is_file() and not ignored & set(p.relative_to(root).parts)
        )


def test_no_file_points_outside_the_repository_or_tells_its_history():
    offenders = []
    for path in repository_files(ROOT):
        rel = path.relative_to(ROOT)
        if rel.parts[0] in {"datasets", "runs"}:
            continue
        if path.suffix not in {".py", ".md", ".toml", ".json"} and path.name != "run":
            continue
        for n, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            if FORBIDDEN.search(line):
                offenders.append(f"{rel}:{n}: {line.strip()[:80]}")
    assert not offenders, "\n".join(offenders)


def test_forbidden_pattern_catches_what_it_should():
    md, ses = ".md", "ses" + "sion"
    caught = (
        f"see design{md}",
        f"reference{md}",
        "../sha" + "red/x",
        "Iss" + "ue #3",
        "the le" + "ad said",
        f"in this {ses}",
        f"last {ses}",
        "the previous ro" + "und",
    )
    for text in caught:
        assert FORBIDDEN.search(text), text
    assert not FORBIDDEN.search("designs, references and the leading edge")


@pytest.mark.parametrize("git", [True, False])
def test_a_virtual_environment_in_the_checkout_is_not_read(tmp_path, monkeypatch, git):
    """Nearly everyone makes `python -m venv .venv` in the checkout: the tests read the
    repository's own files, never the packages installed there."""
    import shutil
    import subprocess

    shutil.copy(ROOT / ".gitignore", tmp_path / ".gitignore")
    lines = (ROOT / ".gitignore").read_text().split()
    assert ".venv/" in lines and "venv/" in lines
    (tmp_path / "mod.py").write_text("x = 1\n")
    for env in (".venv", "venv"):
        site = tmp_path / env / "lib" / "python3.11" / "site-packages"
        site.mkdir(parents=True)
        (site / "numpy.py").write_text("# see " + "iss" + "ue #4984\n")
    if git:
        if shutil.which("git") is None:
            pytest.skip("git is not installed")
        subprocess.run(["git", "init", "-q"], cwd=tmp_path, check=True)
    else:
        monkeypatch.setenv("PATH", "")  # no git to ask
    assert [p.name for p in repository_files(tmp_path)] == [".gitignore", "mod.py"]


def test_the_package_version_is_the_generators():
    """One version: the package's (pyproject.toml) is the generator's, which every dataset
    records."""
    import tomllib

    from assetgen import GENERATOR_VERSION

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["version"] == GENERATOR_VERSION
    # torch's exact version is a constraint (constraints.txt), not a requirement, so a GPU
    # machine keeps its CUDA build
    assert not any(r.startswith("torch==") for r in project["optional-dependencies"]["rl"])
    assert "torch==2.13.0" in (ROOT / "constraints.txt").read_text().split()


def private_imports_across_packages(root: Path) -> list[str]:
    """`from a.b.mod import _name` in a module of another package than a.b (tests aside):
    a helper shared across packages is public, documented where it lives."""
    found = []
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            here = ".".join(parts[:-1])  # the package the module is in (itself for __init__)
            for node in ast.walk(ast.parse(path.read_text())):
                if not (isinstance(node, ast.ImportFrom) and node.module and node.level == 0):
                    continue
                package = node.module.rsplit(".", 1)[0]
                for a in node.names:
                    private = a.name.startswith("_") and not a.name.startswith("__")
                    if private and package != here and node.module != here:
                        found.append(f"{path.relative_to(root)}: {node.module}.{a.name}")
    return found


def test_no_private_name_is_imported_across_packages():
    assert private_imports_across_packages(ROOT) == []


def test_private_imports_across_packages_are_found(tmp_path):
    (tmp_path / "sim" / "assets").mkdir(parents=True)
    (tmp_path / "sim" / "assets" / "a.py").write_text("from sim.engines.x import _y\n")
    (tmp_path / "sim" / "assets" / "b.py").write_text("from sim.assets.a import _z\n")
    for pkg in PACKAGES:
        (tmp_path / pkg).mkdir(exist_ok=True)
    assert private_imports_across_packages(tmp_path) == ["sim/assets/a.py: sim.engines.x._y"]
