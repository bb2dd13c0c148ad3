"""The layout's contracts: stages import in one direction, no import cycle, every stage says
what it holds, and no file points outside the repository or tells how it came to be."""

from __future__ import annotations

import ast
import re
import sys
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


def _tops(prefix: str) -> set[str]:
    """The packages (first name) that the modules of `prefix` import."""
    return {t.split(".")[0] for t in _imports_of(prefix)}


def test_data_flows_one_way():
    """assetgen never imports the simulator, the agents or the viewer; sim reads datasets
    through the shared numpy-only pieces only; the simulator and the agents never import
    each other, the evaluation or the viewer; the evaluation uses the simulator and the
    agents, never the viewer, the benchmarks or the command line."""
    assert _tops("assetgen") <= {"assetgen"}, _tops("assetgen")
    from_assetgen = {t for t in _imports_of("sim") if t.startswith("assetgen")}
    allowed = ("assetgen.core", "assetgen.dataset.spec", "assetgen.dataset.reader")
    assert all(t.startswith(allowed) for t in from_assetgen), from_assetgen
    assert not _tops("sim") & {"rl", "evaluation", "preview", "benchmarks", "cli"}, _tops("sim")
    assert not _tops("rl") & {"sim", "evaluation", "preview", "benchmarks", "cli"}, _tops("rl")
    assert _tops("evaluation") <= {"assetgen", "sim", "rl", "evaluation"}, _tops("evaluation")
    assert not {t for t in _imports_of("assetgen.core") if not t.startswith("assetgen.core")}


def test_the_one_way_rules_see_lazy_imports():
    """An import inside a function is an import: `rl` importing the simulator lazily would
    break the rule as surely as at the top of the file."""
    assert "rl.runner" in import_graph()["rl.commands"]  # imported in train_main only


def _package(module: str, modules: dict[str, Path]) -> str:
    """A module's package: the folder its file is in (sim.task.expert and sim.task are in
    sim.task; sim.engines.mujoco.batch is in sim.engines.mujoco; cli is in "")."""
    return ".".join(modules[module].relative_to(ROOT).parent.parts)


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _dotted(node: ast.expr, alias: dict[str, str]) -> str | None:
    """`m.x.y` -> "module.x.y" where the name m is bound to a project module; else None."""
    if isinstance(node, ast.Name):
        return alias.get(node.id)
    if isinstance(node, ast.Attribute):
        base = _dotted(node.value, alias)
        return f"{base}.{node.attr}" if base else None
    return None


def private_imports(modules: dict[str, Path] | None = None) -> list[str]:
    """ "importer -> module._name" for every private (underscore, not dunder) name a project
    module takes from a module of another package: `from x.y import _z`, or `x.y._z` (also
    through `import x.y as m` / `from x import y` aliases), at the top or in a function."""
    modules = _modules() if modules is None else modules
    found: set[str] = set()
    for name, path in modules.items():
        tree = ast.parse(path.read_text())
        alias: dict[str, str] = {}  # local name -> the project module it is bound to
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.asname:
                        alias[a.asname] = a.name
                    else:  # `import x.y` binds x
                        alias[a.name.split(".")[0]] = a.name.split(".")[0]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                for a in node.names:
                    if f"{node.module}.{a.name}" in modules:
                        alias[a.asname or a.name] = f"{node.module}.{a.name}"
                    elif (
                        node.module in modules
                        and _private(a.name)
                        and _package(node.module, modules) != _package(name, modules)
                    ):
                        found.add(f"{name} -> {node.module}.{a.name}")
        # a name the file also assigns (`sim = Sim(...)` beside `import sim.env`) is not
        # taken for the module: no false alarm for an object's own private attribute
        for node in ast.walk(tree):
            if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                alias.pop(node.id, None)
            elif isinstance(node, ast.arg):
                alias.pop(node.arg, None)
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr):
                base = _dotted(node.value, alias)
                if base in modules and _package(base, modules) != _package(name, modules):
                    found.add(f"{name} -> {base}.{node.attr}")
    return sorted(found)


def test_no_module_takes_a_private_name_of_another_package():
    """A helper shared across packages is public, documented where it lives."""
    assert private_imports() == []


def test_private_imports_are_found(tmp_path, monkeypatch):
    files = {
        "a/b/m.py": "def _f(): ...\ndef _g(): ...\ndef _h(): ...\ndef __dunder__(): ...\n",
        "a/b/same.py": "from a.b.m import _f\n",  # the same package: its own business
        "a/c/n.py": (
            "import a.b.m\nimport a.b.m as mm\nfrom a.b import m\nfrom a.b.m import __dunder__\n"
            "def f():\n    from a.b.m import _f\n    return a.b.m._g, mm._h, m._g\n"
        ),
        # a local object named like the package: its private attribute is its own
        "a/d/o.py": (
            "import a.b.m\nfrom a.b import m\n"
            "def f(a):\n    return a.b.m._x\ndef g():\n    m = 1\n    return m._y\n"
        ),
    }
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    modules = {_module_name(tmp_path / rel): tmp_path / rel for rel in files}
    assert private_imports(modules) == [
        "a.c.n -> a.b.m._f", "a.c.n -> a.b.m._g", "a.c.n -> a.b.m._h",
    ]  # fmt: skip


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
