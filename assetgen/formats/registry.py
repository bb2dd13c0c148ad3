"""The simulation-format exporters, keyed by format name, in writing order.

`collision` (the module's convex pieces, decomposed and checked; it writes no file of its own)
runs before the formats that store them inline, MJCF and USD. The printable files (STL, 3MF)
are written by every module; these are the optional ones.
"""

from __future__ import annotations

import numpy as np

from assetgen.collision.pieces import collision_pieces
from assetgen.core.inline_mesh import MJCF_FILE
from assetgen.core.timing import step
from assetgen.formats.context import ExportContext, Exporter
from assetgen.geometry.solids import insertion_travel

NEEDS_COLLISION = {"mjcf", "usd"}
USD_FILE = "peg_in_hole.usda"


def _collision(ctx: ExportContext) -> None:
    travel = insertion_travel(ctx.geometry)
    ctx.pieces, ctx.record["collision"] = collision_pieces(ctx.geometry, travel, times=ctx.times)


def _usd(ctx: ExportContext) -> None:
    with step(ctx.times, "usd"):
        _write_usd(ctx)


def _write_usd(ctx: ExportContext) -> None:
    from assetgen.core.frames import Frame
    from assetgen.formats.usd import usda_text

    g, peg = ctx.geometry, ctx.record["peg"]
    text = usda_text(
        peg=g.peg,
        module=g.module,
        pieces=ctx.pieces or [],
        entrance=g.entrance,
        bottom=g.bottom,
        peg_pose=Frame.from_json(ctx.record["frames"]["design_pose"]),
        peg_mass=peg["mass_kg"],
        peg_com=np.array(peg["com_m"]),
        peg_inertia=np.array(peg["inertia_kg_m2"]),
    )
    ctx.write(USD_FILE, text.encode())


def _mjcf(ctx: ExportContext) -> None:
    with step(ctx.times, "mjcf"):
        _write_mjcf(ctx)


def _write_mjcf(ctx: ExportContext) -> None:
    from assetgen.core.frames import Frame
    from assetgen.formats.mjcf import mjcf_document

    g, peg = ctx.geometry, ctx.record["peg"]
    # mjcf_document stores the peg and the checked pieces inline, reads them back (they must
    # be unchanged), checks each is closed and convex and compiles the model in MuJoCo. The
    # peg is the one just written to peg.stl, as parsed back from its bytes.
    xml = mjcf_document(
        peg=ctx.meshes["peg.stl"],
        pieces=ctx.pieces,
        entrance=g.entrance,
        bottom=g.bottom,
        peg_pose=Frame.from_json(ctx.record["frames"]["design_pose"]),
        peg_mass=peg["mass_kg"],
        peg_com=np.array(peg["com_m"]),
        peg_inertia=np.array(peg["inertia_kg_m2"]),
        clearance=g.params.clearance,
        name=MJCF_FILE,
    )
    ctx.write(MJCF_FILE, xml)


EXPORTERS: dict[str, Exporter] = {"collision": _collision, "mjcf": _mjcf, "usd": _usd}
"""Simulation-format exporters keyed by format name, run after the printable files."""


def available_formats() -> tuple[str, ...]:
    """Names of the registered formats, in the order they are written."""
    return tuple(EXPORTERS)


def with_dependencies(formats: tuple[str, ...]) -> tuple[str, ...]:
    """`formats` in writing order, with `collision` added where a format needs it, and `mjcf`
    where `collision` is asked for (the pieces are stored in the MJCF)."""
    wanted = set(formats)
    if wanted & NEEDS_COLLISION:
        wanted.add("collision")
    if "collision" in wanted:
        wanted.add("mjcf")
    return tuple(f for f in EXPORTERS if f in wanted) + tuple(
        f for f in formats if f not in EXPORTERS
    )
