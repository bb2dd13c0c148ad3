"""References to code as "module:attribute" strings, resolved on use: what the registries
(engines, families, algorithms) hold, so that listing them imports nothing heavy."""

from __future__ import annotations

import importlib
from typing import Any


def load_reference(reference: str) -> Any:
    """The object a "module:attribute" reference names (importing its module)."""
    module, _, attribute = reference.partition(":")
    return getattr(importlib.import_module(module), attribute)
