"""`FIELD=VALUE` strings -> typed replacements for a frozen config dataclass (the CLI's
`--set`), each value parsed as the field's default is typed."""

from __future__ import annotations

from dataclasses import MISSING, fields
from typing import Any


def parse_overrides(cls: type, items: list[str], flag: str = "--set") -> dict[str, Any]:
    """{field: value} for the dataclass `cls`; ValueError naming the item, the field's type or
    the valid fields."""
    known = {f.name: f for f in fields(cls)}
    out: dict[str, Any] = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or name not in known:
            raise ValueError(
                f"{flag} {item!r}: give FIELD=VALUE with FIELD one of {cls.__name__}'s "
                f"fields: {sorted(known)}"
            )
        f = known[name]
        default = f.default if f.default is not MISSING else f.default_factory()  # type: ignore[misc]
        try:
            if isinstance(default, bool):
                if text.lower() not in ("true", "false", "1", "0"):
                    raise ValueError
                value: Any = text.lower() in ("true", "1")
            elif isinstance(default, tuple):
                value = tuple(type(default[0])(x) for x in text.split(","))
            elif default is None:
                value = None if text.lower() == "none" else float(text)
            else:
                value = type(default)(float(text) if isinstance(default, int) else text)
                if isinstance(default, int) and value != float(text):
                    raise ValueError
        except ValueError:
            kind = {"int": "an integer", "float": "a number", "bool": "true or false"}.get(
                type(default).__name__, f"a {type(default).__name__}"
            )
            raise ValueError(f"{flag} {item!r}: {name} takes {kind}") from None
        out[name] = value
    return out
