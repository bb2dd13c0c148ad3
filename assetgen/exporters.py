"""Registers the simulation-format exporters (MJCF, USD) with the module writer."""

from __future__ import annotations

from assetgen.module_writer import EXPORTERS


def available_formats() -> tuple[str, ...]:
    """Names of the registered simulation formats, in the order they are written."""
    return tuple(EXPORTERS)
