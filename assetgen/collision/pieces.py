"""Collision geometry of a module: convex pieces, checked as the simulation files store them.

Whatever made the pieces (the exact decomposition, or CoACD for non-convex holes), they are
rounded as the MJCF and USD files store them (float32 millimetres, assetgen.core.inline_mesh)
and their distance to the seated and the inserting peg is bounded
from below by separating planes (a proof; python-fcl measures any piece the planes cannot
clear): a module whose collision geometry comes nearer the peg than the clearance is refused.
The exact pieces, which overlap at their seams, are also checked to make up the module:
each inside it, and each the whole cell it was made from (check_union).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from assetgen.checks.module_checks import (
    CLEARANCE_TOLERANCE,
    CheckError,
    fcl_distance,
    fcl_object,
    lifted,
    swept_hull,
)
from assetgen.collision.cell_meshes import cell_fit, largest_residuals
from assetgen.collision.coacd_pieces import coacd_pieces
from assetgen.collision.exact import OVERLAP, exact_decomposition, exact_pieces
from assetgen.collision.separating_planes import (
    edge_cross_directions,
    mesh_edge_directions,
    separation_bounds,
    unit_directions,
)
from assetgen.core.inline_mesh import stored
from assetgen.core.mesh import Mesh, cross3
from assetgen.core.timing import StepTimes, step
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
    normals = np.vstack([geom.hole_planes[:, :3], geom.hole_chamfer_planes[:, :3]])
    bound = separation_bounds(sets, bodies, unit_directions(normals))
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
        soup = fcl_object(_soup([pieces[i] for i in unproven]))
        exact = (
            fcl_distance(fcl_object(peg, design), soup),
            fcl_distance(fcl_object(swept_hull(peg, start, design)), soup),
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


UNION_TOLERANCE = 1e-7
"""How far (m) a stored exact piece's vertex may lie outside the module, or off the plane
of the face it is on: the 20 nm snap of the vertices (up to 17 nm along a normal) and the
files' float32 millimetres (up to 13 nm on a 0.5 m plate), with room."""


def check_union(
    pieces: Sequence[Mesh], systems: Sequence[np.ndarray], geom: ModuleGeometry
) -> dict:
    """Check that the exact pieces (as stored) make up the module: their union is the
    module, seams overlapping; raise CheckError if not.

    - Inside the module: each piece's vertices (so the piece, convex) lie in the plate or in
      the sleeve's outline up to the mounting surface (the plate fills the outline above the
      sleeve; the sleeve's footprint is checked to lie within the plate's), and beyond one
      hole plane, or, a far-plate box, to one side of the hole's
      section through the plate.
    - Each piece is the whole polytope of its half-spaces: every vertex satisfies them all
      and every triangle lies on one of their planes (a closed convex surface inside a
      polytope, all on its boundary, is the polytope's surface: no vertex missing).
    The polytopes cover the module by construction (see assetgen.collision.exact: each one
    contains the cell of the exact tiling it grew from). Within UNION_TOLERANCE.
    Returns how far the pieces reach outside the module (m; <= 0 within it).
    """
    p = geom.params
    t, half = p.plate_thickness, p.plate_size / 2
    k = len(geom.hole_planes)
    lo, hi = geom.hole_section
    eye = np.eye(3)
    rows = np.vstack(
        [
            np.column_stack([np.vstack([eye, -eye]), [half, half, 0.0, half, half, t]]),  # plate
            # the sleeve's outline up to the mounting surface (a wall piece's room)
            np.vstack([geom.sleeve_planes[:-1], [[0.0, 0.0, 1.0, 0.0]]]),
            -geom.hole_planes,  # beyond hole plane i
            np.column_stack([-eye[:2], -hi]),  # the hole's section's +x, +y side
            np.column_stack([eye[:2], lo]),  # its -x, -y side
            -geom.hole_chamfer_planes,  # beyond side i's entrance chamfer face
        ]
    )
    worst = largest_residuals(pieces, rows)
    chamfer = len(geom.hole_chamfer_planes)
    worst, beyond_chamfer = worst[:, : len(rows) - chamfer], worst[:, len(rows) - chamfer :]
    plate = worst[:, :6].max(axis=1)
    sleeve = worst[:, 6 : 6 + len(geom.sleeve_planes)].max(axis=1)
    # beyond side i means beyond its chamfer face too, where the entrance has one
    hole_faces = worst[:, -k - 4 : -4].copy()
    hole_faces[:, :chamfer] = np.maximum(hole_faces[:, :chamfer], beyond_chamfer)
    beyond = hole_faces.min(axis=1)
    side = worst[:, -4:].min(axis=1)  # only where the piece is in the plate
    outside = np.maximum(
        np.minimum(plate, sleeve),
        np.where(plate <= UNION_TOLERANCE, np.minimum(beyond, side), beyond),
    )
    if outside.max() > UNION_TOLERANCE:
        s = int(outside.argmax())
        raise CheckError(
            f"collision piece {s} reaches {outside[s] * 1e3:.6f} mm outside the module (into "
            f"the hole or past the plate's or the sleeve's faces; tolerance "
            f"{UNION_TOLERANCE * 1e3:g} mm)"
        )

    worst, loose = cell_fit(pieces, systems, UNION_TOLERANCE)
    if worst.max() > UNION_TOLERANCE:
        s = int(worst.argmax())
        raise CheckError(
            f"collision piece {s} reaches {worst[s] * 1e3:.6f} mm past one of its own planes: "
            "its mesh is not its cell"
        )
    if loose.any():
        s = int(np.flatnonzero(loose)[0])
        raise CheckError(
            f"collision piece {s} has {loose[s]} triangle(s) on none of its cell's planes: "
            "its mesh misses part of its cell (a gap in the collision geometry)"
        )
    return {"outside_module_m": float(outside.max())}


def collision_pieces(
    geom: ModuleGeometry, travel: float, method: str = "exact", times: StepTimes | None = None
) -> tuple[list[Mesh], dict]:
    """Decompose the module, round the pieces as the files store them and check those.
    Returns the stored pieces (the MJCF and USD writers store them, and the MJCF writer
    checks that they read back unchanged) and a record for module.json; `times` gets the
    steps' wall times."""
    if method not in DECOMPOSERS:
        raise ValueError(f"unknown decomposition {method!r}; valid: {sorted(DECOMPOSERS)}")
    systems = None
    with step(times, "collision: decompose"):
        if method == "exact":
            pieces, systems = exact_decomposition(geom)
        else:
            pieces = DECOMPOSERS[method](geom)
    with step(times, "collision: re-check"):
        kept = stored(pieces)
        gaps = check_pieces(kept, geom.peg, geom, travel)
    record = {
        "method": method,
        "pieces": len(pieces),
        "volume_ratio": _volume(pieces) / geom.module_volume,
    }
    if systems is not None:
        with step(times, "collision: union"):
            record |= {"overlap_m": OVERLAP, **check_union(kept, systems, geom)}
    return kept, {**record, **gaps}


def _volume(pieces: Sequence[Mesh]) -> float:
    """Total volume (m^3) of closed outward meshes: all triangles in one pass."""
    if not pieces:
        return 0.0
    t = np.vstack([m.vertices[m.faces] for m in pieces])
    return float(np.einsum("ij,ij->i", t[:, 0], cross3(t[:, 1], t[:, 2])).sum() / 6.0)
