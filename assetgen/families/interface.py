"""The family interface: what every family of modules fills in, with the same shape.

A family is one folder, `assetgen/families/<name>/` (its `__init__.py` defines `FAMILY`, a
`Family`), found by assetgen.families.registry. It gives:

- **parameters**: `sampler`, a frozen dataclass whose fields are the ranges of the sampled
  parameters, each documented by the string under it (`assetgen families` prints them), with
  `sample(seed) -> params`, `validate()`, `to_json()` and `from_json(d)` (a dataset's
  dataset.json stores it), `clearance` and `finest_clearance` (m: the first step's and the
  finest step's) and `with_clearance(m)` (the config with the first step's clearance set:
  `sample --clearance-mm`); and `params`, the frozen dataclass of one draw, with
  `validate()`, `to_json()` and `from_json(d)` (module.json stores it).
- **build**: `build(params)`, the pure function from one draw to its parts: solids and
  frames. For the `assembly` layout it returns an `Assembly` (assetgen.families.parts:
  parts made of convex solids and holes, and the steps that insert them); for the `module`
  layout (Table I) a ModuleGeometry (assetgen.geometry.solids).
- **the later stages**, through its `layout`: how its modules are checked, cut into collision
  pieces, written, loaded in the simulator and shown in the viewer. A layout names each of them
  as "module:attribute". Families stage code may not import the later stages
  (tests/test_layout.py), so they are references, resolved where they are used
  (assetgen.core.references.load_reference). Two layouts exist: MODULE (Table I, one peg and a
  plate; its files are the paper's) and ASSEMBLY (any `Assembly`: its writer, checks, collision
  pieces, simulator loading and preview are common to every family that builds one). A new
  family that builds an Assembly needs nothing beyond its folder.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import textwrap
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Layout:
    """The later stages a family's modules go through, each a "module:attribute" reference
    (assetgen.core.references.load_reference imports it).

    name      : "module" or "assembly"; recorded nowhere in the files (a dataset records its
                family, and the family its layout).
    checks    : the checks run on the files as written.
    collision : the convex pieces a simulator collides, from the parts.
    writer    : params and parts to a finished module folder (module.json and its files).
    simulator : a module folder to what the simulator runs (sim.assets).
    preview   : a module folder to what the viewer shows (preview).
    """

    name: str
    checks: str
    collision: str
    writer: str
    simulator: str
    preview: str

    def references(self) -> dict[str, str]:
        """Stage -> its "module:attribute" reference."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)[1:]}


MODULE = Layout(
    name="module",
    checks="assetgen.checks.module_checks:verify",
    collision="assetgen.collision.pieces:collision_pieces",
    writer="assetgen.dataset.module_writer:generate_module",
    simulator="sim.assets.loading:load_module",
    preview="preview.scene:ModuleView",
)
"""Table I's stages: one peg and one plate per module (module.json with `frames` and `peg`,
`peg.stl`, `module.stl`, `peg_in_hole.*`)."""

ASSEMBLY = Layout(
    name="assembly",
    checks="assetgen.checks.step_checks:check_steps",
    collision="assetgen.collision.carve:carve_part",
    writer="assetgen.dataset.assembly_writer:write_assembly",
    simulator="sim.assets.assembly:AssemblyStages",
    preview="preview.assembly:AssemblyView",
)
"""The stages of every family whose build returns an Assembly: module.json with `steps` and
`parts`, one `<part>.stl` per part, `assembly.3mf`, `assembly.xml`, `assembly.usda`."""


@dataclass(frozen=True)
class Family:
    """One family of modules (see the module docstring).

    name    : as `assetgen sample --family` takes it (the folder's name, `_` as `-`).
    summary : one line: what a module of the family is.
    sampler : the parameters' ranges: a frozen dataclass, every field documented, with
              sample(seed) -> params, validate, to_json, from_json; its defaults are the
              family's standard dataset.
    params  : one draw: a frozen dataclass with validate, to_json, from_json.
    build   : params -> the parts (an Assembly, or a ModuleGeometry for the module layout).
    layout  : the stages after build (ASSEMBLY unless the family writes Table I's files).
    """

    name: str
    summary: str
    sampler: type
    params: type
    build: Callable[[Any], Any]
    layout: Layout = ASSEMBLY


@dataclass(frozen=True)
class Parameter:
    """One field of a sampler config: its name, its default and the documentation under it."""

    name: str
    default: Any
    doc: str


def field_docs(cls: type) -> dict[str, str]:
    """The string under each field of a dataclass (`x: float = 1.0` then `\"\"\"...\"\"\"`),
    read from its source; one line each (whitespace collapsed). Fields without one: ""."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body
    docs = {}
    for node, after in zip(body, [*body[1:], None], strict=True):
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            doc = ""
            if (
                isinstance(after, ast.Expr)
                and isinstance(after.value, ast.Constant)
                and isinstance(after.value.value, str)
            ):
                doc = " ".join(after.value.value.split())
            docs[node.target.id] = doc
    return docs


def parameters(family: Family) -> list[Parameter]:
    """The family's sampler fields in order, with their defaults and documentation."""
    docs = field_docs(family.sampler)
    out = []
    for f in dataclasses.fields(family.sampler):
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        out.append(Parameter(f.name, default, docs.get(f.name, "")))
    return out
