"""Registers the simulation-format exporters with the module writer.

`collision` (the convex pieces in collision/) runs before any format that needs it.
"""

from __future__ import annotations

from assetgen.collision import write_collision
from assetgen.module_writer import EXPORTERS, ExportContext, insertion_travel

NEEDS_COLLISION = {"mjcf", "usd"}


def _collision(ctx: ExportContext) -> None:
    ctx.record["collision"] = write_collision(ctx, insertion_travel(ctx.geometry))


EXPORTERS["collision"] = _collision


def available_formats() -> tuple[str, ...]:
    """Names of the registered formats, in the order they are written."""
    return tuple(EXPORTERS)


def with_dependencies(formats: tuple[str, ...]) -> tuple[str, ...]:
    """`formats` in writing order, with `collision` added where a format needs it."""
    wanted = set(formats)
    if wanted & NEEDS_COLLISION:
        wanted.add("collision")
    return tuple(f for f in EXPORTERS if f in wanted) + tuple(
        f for f in formats if f not in EXPORTERS
    )
