"""Collision geometry of a module: convex pieces, written to collision/ and re-checked.

Whatever made the pieces (the exact decomposition, or CoACD for non-convex holes), they are
read back from the files and the clearance is measured on them with python-fcl: a module
whose collision geometry comes nearer the seated peg than the clearance is refused.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from assetgen.checks import CLEARANCE_TOLERANCE, CheckError, _distance, _fcl_object, _swept_hull
from assetgen.coacd_decomposition import coacd_pieces
from assetgen.decomposition import exact_pieces
from assetgen.geometry import ModuleGeometry
from assetgen.mesh import Mesh, cross3
from assetgen.module_writer import ExportContext
from assetgen.stl import parse_stl_triangles_mm, stl_bytes_many
from assetgen.timing import step

DECOMPOSERS: dict[str, Callable[[ModuleGeometry], list[Mesh]]] = {
    "exact": exact_pieces,
    "coacd": lambda g: coacd_pieces(g.module),
}
"""Decomposition methods by name: `exact` for convex holes (ours), `coacd` in general."""


def piece_name(i: int) -> str:
    return f"collision/piece_{i:03d}.stl"


def _soup(meshes: list[Mesh]) -> Mesh:
    """All pieces as one triangle soup, for a single FCL distance query over them."""
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return Mesh(
        np.vstack([m.vertices for m in meshes]),
        np.vstack([m.faces + o for m, o in zip(meshes, offsets, strict=True)]),
    )


def _indexed_soup(tris: list[np.ndarray], pieces: list[Mesh]) -> Mesh:
    """The triangles read back from the files, (m_i, 3, 3) each, as one indexed mesh that
    shares the corners the in-memory pieces share.

    python-fcl converts every vertex with a numpy call, so a soup with three vertices per
    triangle costs ~3x the vertices of the indexed mesh to load; FCL itself only sees the
    triangles, which are the file's bit for bit (checked below; otherwise the plain soup is
    used), so the measured distances do not change.
    """
    offsets = np.cumsum([0] + [len(m.vertices) for m in pieces[:-1]])
    faces = np.vstack([m.faces + o for m, o in zip(pieces, offsets, strict=True)])
    points = np.concatenate(tris).reshape(-1, 3)
    soup = Mesh(points, np.arange(len(points)).reshape(-1, 3))
    if len(points) != faces.size:
        return soup
    used, corner = np.unique(faces.ravel(), return_inverse=True)
    vertices = np.empty((len(used), 3))
    vertices[corner] = points
    if not np.array_equal(vertices[corner], points):  # corners the files do not share
        return soup
    return Mesh(vertices, corner.reshape(-1, 3))


def check_pieces(pieces: list[Mesh] | Mesh, peg: Mesh, geom: ModuleGeometry, travel: float) -> dict:
    """Measure the gaps between the peg and the pieces (or their union as one mesh); raise
    CheckError if one is lost."""
    c = geom.params.clearance
    design = geom.design_pose.matrix()
    soup = _fcl_object(pieces if isinstance(pieces, Mesh) else _soup(pieces))
    gap = _distance(_fcl_object(peg, design), soup)
    start = design.copy()
    start[:3, 3] += travel * design[:3, 2]
    insertion = _distance(_fcl_object(_swept_hull(peg, start, design)), soup)
    if gap < c - CLEARANCE_TOLERANCE or insertion < c - CLEARANCE_TOLERANCE:
        raise CheckError(
            f"collision pieces come within {min(gap, insertion) * 1e3:.4f} mm of the seated or "
            f"inserting peg, less than the clearance {c * 1e3:g} mm: the decomposition lost "
            "clearance (use the exact decomposition, or a finer CoACD threshold)"
        )
    return {"clearance_m": gap, "insertion_min_distance_m": insertion}


def write_collision(ctx: ExportContext, travel: float, method: str = "exact") -> dict:
    """Decompose, write collision/piece_XXX.stl (mm) and check the pieces as written (their
    float32 millimetre bytes parsed back); return a record for module.json."""
    if method not in DECOMPOSERS:
        raise ValueError(f"unknown decomposition {method!r}; valid: {sorted(DECOMPOSERS)}")
    geom = ctx.geometry
    with step(ctx.times, "collision: decompose"):
        pieces = DECOMPOSERS[method](geom)
    ctx.pieces = pieces
    names = [piece_name(i) for i in range(len(pieces))]
    with step(ctx.times, "collision: write"):
        tris = [
            parse_stl_triangles_mm(ctx.write(n, data), n)
            for n, data in zip(names, stl_bytes_many(pieces), strict=True)
        ]
    with step(ctx.times, "collision: FCL re-check"):
        gaps = check_pieces(_indexed_soup(tris, pieces), geom.peg, geom, travel)
    volume = float(sum(_volume(m) for m in pieces))
    record = {
        "method": method,
        "pieces": names,
        "volume_ratio": volume / geom.module_volume,
        **gaps,
    }
    if method == "exact" and abs(record["volume_ratio"] - 1.0) > 1e-6:
        raise CheckError(
            f"exact convex pieces add up to {record['volume_ratio']:.8f} of the module's volume "
            "(expected 1): pieces overlap or leave gaps"
        )
    return record


def _volume(m: Mesh) -> float:
    t = m.vertices[m.faces]
    return float(np.einsum("ij,ij->i", t[:, 0], cross3(t[:, 1], t[:, 2])).sum() / 6.0)
