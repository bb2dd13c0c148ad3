"""Collision geometry of a module: convex pieces, checked as the simulation files store them.

Whatever made the pieces (the exact decomposition, or CoACD for non-convex holes), they are
rounded as the MJCF and USD files store them (float32 millimetres, assetgen.core.inline_mesh)
and their distance to the seated and the inserting peg is bounded
from below by separating planes (a proof; python-fcl measures any piece the planes cannot
clear): a module whose collision geometry comes nearer the peg than the clearance is refused.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from assetgen.checks.module_checks import (
    CLEARANCE_TOLERANCE,
    CheckError,
    _distance,
    _fcl_object,
    _swept_hull,
    lifted,
)
from assetgen.collision.coacd_pieces import coacd_pieces
from assetgen.collision.exact import exact_pieces
from assetgen.collision.separating_planes import (
    edge_cross_directions,
    mesh_edge_directions,
    separation_bounds,
    unit_directions,
)
from assetgen.core.inline_mesh import stored
from assetgen.core.mesh import Mesh, cross3
from assetgen.core.timing import step
from assetgen.formats.context import ExportContext
from assetgen.geometry.solids import ModuleGeometry

DECOMPOSERS: dict[str, Callable[[ModuleGeometry], list[Mesh]]] = {
    "exact": exact_pieces,
    "coacd": lambda g: coacd_pieces(g.module),
}
"""Decomposition methods by name: `exact` for convex holes (ours), `coacd` in general."""


def _soup(meshes: list[Mesh]) -> Mesh:
    """All pieces as one triangle soup, for a single FCL distance query over them."""
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return Mesh(
        np.vstack([m.vertices for m in meshes]),
        np.vstack([m.faces + o for m, o in zip(meshes, offsets, strict=True)]),
    )


def check_pieces(pieces: Sequence[Mesh], peg: Mesh, geom: ModuleGeometry, travel: float) -> dict:
    """Bound the gaps between the peg (seated, and along its straight insertion) and every
    piece; raise CheckError if a piece comes nearer than the clearance.

    Each piece's distance is bounded from below by its best separating direction (a hole
    plane's normal, an axis, or an axis crossed with a peg edge; see
    assetgen.collision.separating_planes): a proof, tight to nanometres for exact pieces.
    A piece whose
    bound falls short of the clearance (a CoACD piece that fills the gap, or one no such
    direction clears) is measured exactly with python-fcl and refused only if that distance
    falls short too. Returns the smallest bounds (or distances) and how many pieces needed
    FCL.
    """
    c = geom.params.clearance
    design = geom.design_pose.matrix()
    start = lifted(design, travel)
    seated = peg.transformed(design).vertices
    # A convex peg moving straight sweeps the hull of its two end poses, whose points are
    # convex combinations of the peg's vertices at both ends: those vertices are the body.
    swept = np.vstack([peg.transformed(start).vertices, seated])
    bodies = [seated, swept]
    sets = [m.vertices for m in pieces]
    bound = separation_bounds(sets, bodies, unit_directions(geom.hole_planes[:, :3]))
    need = c - CLEARANCE_TOLERANCE
    unproven = np.flatnonzero(bound.min(axis=1) < need)
    if len(unproven):
        # Far-plate boxes under a peg that stands out above the plate: the crosses of the
        # boxes' edges (the axes) with the peg's and the sweep's edges.
        edges = np.vstack([mesh_edge_directions(seated, peg.faces), design[:3, 2]])
        dirs = edge_cross_directions(np.eye(3), edges)
        better = separation_bounds([sets[i] for i in unproven], bodies, dirs)
        bound[unproven] = np.maximum(bound[unproven], better)
        unproven = np.flatnonzero(bound.min(axis=1) < need)
    gaps = bound.min(axis=0) if len(pieces) else np.full(2, np.inf)
    if len(unproven):
        soup = _fcl_object(_soup([pieces[i] for i in unproven]))
        exact = (
            _distance(_fcl_object(peg, design), soup),
            _distance(_fcl_object(_swept_hull(peg, start, design)), soup),
        )
        proven = np.delete(bound, unproven, axis=0)
        gaps = np.minimum(proven.min(axis=0), exact) if len(proven) else np.array(exact)
    gap, insertion = float(gaps[0]), float(gaps[1])
    if gap < need or insertion < need:
        raise CheckError(
            f"collision pieces come within {min(gap, insertion) * 1e3:.4f} mm of the seated or "
            f"inserting peg, less than the clearance {c * 1e3:g} mm: the decomposition lost "
            "clearance (use the exact decomposition, or a finer CoACD threshold)"
        )
    return {
        "clearance_lower_bound_m": gap,
        "insertion_lower_bound_m": insertion,
        "pieces_measured_with_fcl": len(unproven),
    }


def collision_pieces(ctx: ExportContext, travel: float, method: str = "exact") -> dict:
    """Decompose the module, round the pieces as the files store them and check those; set
    ctx.pieces to them (the MJCF and USD writers store them, and the MJCF writer checks that
    they read back unchanged) and return a record for module.json."""
    if method not in DECOMPOSERS:
        raise ValueError(f"unknown decomposition {method!r}; valid: {sorted(DECOMPOSERS)}")
    geom = ctx.geometry
    with step(ctx.times, "collision: decompose"):
        pieces = DECOMPOSERS[method](geom)
    with step(ctx.times, "collision: re-check"):
        ctx.pieces = stored(pieces)
        gaps = check_pieces(ctx.pieces, geom.peg, geom, travel)
    volume = _volume(pieces)
    record = {
        "method": method,
        "pieces": len(pieces),
        "volume_ratio": volume / geom.module_volume,
        **gaps,
    }
    if method == "exact" and abs(record["volume_ratio"] - 1.0) > 1e-6:
        raise CheckError(
            f"exact convex pieces add up to {record['volume_ratio']:.8f} of the module's volume "
            "(expected 1): pieces overlap or leave gaps"
        )
    return record


def _volume(pieces: Sequence[Mesh]) -> float:
    """Total volume (m^3) of closed outward meshes: all triangles in one pass."""
    if not pieces:
        return 0.0
    t = np.vstack([m.vertices[m.faces] for m in pieces])
    return float(np.einsum("ij,ij->i", t[:, 0], cross3(t[:, 1], t[:, 2])).sum() / 6.0)
