"""The families by name, each loaded only when asked for.

A family is found by its folder: every package `assetgen/families/<folder>/` is the family
`<folder>` with `_` written `-` (`profile_bolt/` is `profile-bolt`), and its `__init__.py`
defines `FAMILY` (an assetgen.families.interface.Family of that name). Listing the names
imports nothing; `get(name)` imports that one folder. Adding a family is adding its folder:
no line to add here, and no name to keep in step with the folder.

A family kept elsewhere (a test's, a user's) joins with `register(name, module)`, the module
defining FAMILY as a folder's `__init__.py` does; `unregister(name)` removes it again.
Registrations live in the process (and in the workers it forks).
"""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

from assetgen.families.interface import ASSEMBLY, Family

DEFAULT_FAMILY = "peg-in-hole"
"""The family of a dataset that names none (every Table I dataset)."""

_PACKAGE = "assetgen.families"
_FOLDER = Path(__file__).resolve().parent
_registered: dict[str, str] = {}


def discovered() -> dict[str, str]:
    """Family name -> its module, for every family folder in assetgen/families/."""
    return {
        m.name.replace("_", "-"): f"{_PACKAGE}.{m.name}"
        for m in pkgutil.iter_modules([str(_FOLDER)])
        if m.ispkg
    }


def modules() -> dict[str, str]:
    """Family name -> the module defining its FAMILY: the folders', then the registered."""
    return {**discovered(), **_registered}


def names() -> list[str]:
    """Every family's name, sorted (imports no family)."""
    return sorted(modules())


def register(name: str, module: str) -> None:
    """Add the family `name`, whose FAMILY `module` (a dotted module name) defines; it is
    imported when the family is first asked for. ValueError if the name is taken."""
    if name in modules():
        raise ValueError(f"family {name!r} exists already ({modules()[name]})")
    _registered[name] = module


def unregister(name: str) -> None:
    """Remove a family added by register (the folders' families stay)."""
    _registered.pop(name, None)


def get(name: str) -> Family:
    """The family called `name`; ValueError listing the valid names otherwise."""
    found = modules()
    if name not in found:
        raise ValueError(f"unknown family {name!r}; valid families: {sorted(found)}")
    family = importlib.import_module(found[name]).FAMILY
    if not isinstance(family, Family) or family.name != name:
        raise TypeError(f"{found[name]}.FAMILY must be a Family named {name!r}, not {family!r}")
    return family


def is_assembly(name: str) -> bool:
    """Whether the family `name` builds assemblies (the ASSEMBLY layout: parts inserted step
    by step, checked, simulated and shown as such), not Table I modules; ValueError for an
    unknown name."""
    return get(name).layout is ASSEMBLY


def describe() -> list[dict]:
    """Every family as JSON data (`assetgen families`): name, summary, layout, and its
    sampler's parameters (name, default, the documentation under the field)."""
    from assetgen.families.interface import parameters

    out = []
    for name in names():
        family = get(name)
        params = [
            {
                "name": p.name,
                "default": list(p.default) if isinstance(p.default, tuple) else p.default,
                "doc": p.doc,
            }
            for p in parameters(family)
        ]
        out.append(
            {
                "name": name,
                "summary": family.summary,
                "layout": family.layout.name,
                "parameters": params,
            }
        )
    return out
