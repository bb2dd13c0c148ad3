"""Exact convex decomposition of a convex solid with several convex holes cut from it.

This is how a part that is not convex gets an exact clearance hole: a part is a union of
convex solids C_i = {x : n . x <= d for each of its planes}, and its hole is the union of
each solid's planes moved out by the clearance c (assetgen.geometry.clearance_hole). Any
point outside that union violates one moved plane of every solid, so it lies more than c
from each of them: the gap is never below c, and it is exactly c at every face.

The material M (a convex solid) minus the union of convex holes H_1 .. H_k splits exactly
into convex cells. Outside H = {s_j <= 0 for all j}, s_j(x) = n_j . x - d_j, some s_j is
positive, so the complement of H is the union of the "farthest-plane" cells

    F_j = {s_j >= 0} ∩ {s_j >= s_i for every other plane i of H},

which are convex and do not overlap (they share only boundaries). Cutting one hole after
another, each cell that the hole's interior meets is replaced by its intersections with the
hole's F_j; a cell the hole misses is kept whole. Each cell lies outside every hole, so none
comes nearer the part than the clearance.

As the module's pieces do (assetgen.collision.exact), the cells reach `overlap` past their
seams: each rival row s_i <= s_j, scaled to a unit normal, moves that far into F_i, so a
part pressed into a seam meets a piece on both sides of it rather than the shared face of
two pieces that only touch. Each F_j still lies beyond plane j, so the cells stay outside
the holes; the solid's own planes do not move, so they stay inside it; and each contains
the cell it grew from, so they still cover the solid minus the holes. With overlap 0 they
tile it, and their volumes add up to its volume (tested).

Each F_j is contained in the half-space beyond plane j: these cells refine "one outward
plane per hole, clipped to the solid" into cells that do not overlap. A cell's vertices come
from enumerating plane triples (assetgen.geometry.triple_vertices), redundant planes are
dropped between holes (a facet of a bounded polytope has at least three vertices), and
assetgen.collision.cell_meshes turns the cells into meshes. Hand-written: no
library decomposes exactly (CoACD approximates, and eats into a sub-millimetre gap).

Before that, each face that bounds every hole from one side is given to one piece whole:
when a plane p of some hole has every hole on its inner side (s_p <= 0 throughout the
material), the material beyond it, {s_p >= 0}, is one cell that no hole meets, and the rest
is the material with {s_p <= overlap}, carved by the holes without row p. A hole's floor
shared by the convex pieces of a non-convex hole is then one face of one piece, not the
coplanar faces of a dozen: a peg landing on a floor split into many pieces met many
contacts at once, and MuJoCo's multi-point convex collision let it sink through for a step.
The peeling goes on while such a plane is left (the plane in most holes first); for one
convex hole it gives every face its own piece.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from assetgen.collision.cell_meshes import cell_meshes
from assetgen.collision.exact import OVERLAP
from assetgen.core.mesh import Mesh
from assetgen.core.portable import matmul, norm
from assetgen.geometry.triple_vertices import polytope_vertices_batch

ON_PLANE = 1e-9
"""A vertex within this distance (m) of a plane lies on it (redundant-plane pruning)."""
SOLID = 1e-8
"""A cell (or a cell's overlap with a hole) is solid when its vertices spread more than this
(m, RMS) off their best-fitting plane. The vertex enumeration admits points 1e-10 m outside
a plane, so a flat set (two cells' shared face) reads as a film of about that thickness,
which a volume threshold cannot tell from a genuine sliver on a large face. What is thinner
is dropped: a hole overlapping a cell by less leaves material at most 10 nm inside it, far
within the 1 um clearance tolerance."""
PARALLEL = 1e-12
"""Two planes whose normals differ by less than this are parallel (their rival row is
constant and is dropped; a duplicate plane of a hole is dropped before that)."""


def _unit(planes: np.ndarray, what: str) -> np.ndarray:
    planes = np.asarray(planes, dtype=np.float64)
    if planes.ndim != 2 or planes.shape[1] != 4 or len(planes) < 4:
        raise ValueError(f"{what}: expected (k >= 4, 4) half-space rows [n, d], n . x <= d")
    if not np.isfinite(planes).all():
        raise ValueError(f"{what}: non-finite plane coefficients")
    norms = np.linalg.norm(planes[:, :3], axis=1)
    if norms.min() < 1e-12:
        raise ValueError(f"{what}: a plane has a zero normal")
    return planes / norms[:, None]


def _distinct(planes: np.ndarray) -> np.ndarray:
    """The planes without repeats (within PARALLEL), in their first order."""
    keep: list[int] = []
    for i, p in enumerate(planes):
        if all(np.abs(p - planes[j]).max() > PARALLEL for j in keep):
            keep.append(i)
    return planes[keep]


def farthest_cells(hole: np.ndarray, overlap: float = 0.0) -> list[np.ndarray]:
    """The cells F_j (half-space rows, unit normals) that tile the complement of the convex
    polytope `hole` (unit-normal rows n . x <= d): F_j is beyond plane j and plane j is the
    farthest there, each seam with F_i moved `overlap` (m) into F_i (0: a tiling). Rival
    rows s_i <= s_j are normalised. A parallel plane's rival row is a constant: always true
    (plane j is the tighter one: dropped), or never (plane j is redundant and F_j is empty:
    no cell)."""
    hole = _distinct(hole)
    cells = []
    for j, (nj, dj) in enumerate(zip(hole[:, :3], hole[:, 3], strict=True)):
        rows = [np.array([*(-nj), -dj])]
        for i, (ni, di) in enumerate(zip(hole[:, :3], hole[:, 3], strict=True)):
            dn = ni - nj
            size = float(norm(dn))
            if i == j or size >= PARALLEL:
                if i != j:
                    rows.append(np.array([*(dn / size), (di - dj) / size + overlap]))
            elif di < dj:  # a parallel plane i is tighter: s_i > s_j everywhere, F_j is empty
                break
        else:
            cells.append(np.vstack(rows))
    return cells


def _solid(vertices: np.ndarray) -> bool:
    """The points span a solid thicker than SOLID (see there)."""
    if len(vertices) < 4:
        return False
    centred = vertices - vertices.mean(axis=0)
    return bool(np.linalg.svd(centred, compute_uv=False)[-1] / np.sqrt(len(vertices)) > SOLID)


def _pruned(planes: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """The cell's facet planes: those with at least three of its vertices on them."""
    on = np.abs(matmul(vertices, planes[:, :3].T) - planes[:, 3]) < ON_PLANE
    return planes[on.sum(axis=0) >= 3]


def carve_cells(
    material: np.ndarray, holes: Sequence[np.ndarray], overlap: float = OVERLAP
) -> list[np.ndarray]:
    """Convex cells (each a (m, 4) system of unit-normal half-spaces) whose union is the
    bounded convex `material` minus the interiors of the convex `holes`, overlapping by
    `overlap` (m) at their seams (0: without overlaps).

    material : (m, 4) rows [n, d] meaning n . x <= d (bounded).
    holes    : (h_k, 4) rows each, the same form (they may extend beyond the material).
    Raises ValueError naming the argument for a malformed system or an empty material.
    """
    material = _unit(material, "material")
    holes = [_unit(h, f"hole {k}") for k, h in enumerate(holes)]
    (v,) = polytope_vertices_batch([material])
    if not _solid(v):
        raise ValueError("material: the half-spaces enclose no volume (or are unbounded)")
    slabs, material, v, holes = _peel(material, v, holes, overlap)
    cells = [_pruned(material, v)]
    for hole in holes:
        meets = polytope_vertices_batch([np.vstack([c, hole]) for c in cells])
        tiles = farthest_cells(hole, overlap)
        candidates: list[np.ndarray] = []
        for cell, inside in zip(cells, meets, strict=True):
            if not _solid(inside):
                candidates.append(cell)  # the hole misses this cell: kept whole
            else:
                candidates += [np.vstack([cell, t]) for t in tiles]
        cells = [
            _pruned(c, v)
            for c, v in zip(candidates, polytope_vertices_batch(candidates), strict=True)
            if _solid(v)
        ]
    return slabs + cells


def _same(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Which rows of `a` (k, 4) equal the row `b` within PARALLEL."""
    return np.abs(a - b).max(axis=1) <= PARALLEL


def _peel(
    material: np.ndarray, v: np.ndarray, holes: list[np.ndarray], overlap: float
) -> tuple[list[np.ndarray], np.ndarray, np.ndarray, list[np.ndarray]]:
    """Peel off the material beyond each hole plane that has every hole on its inner side
    (see the module's docstring): (the peeled cells, the material left (rows, vertices),
    the holes to carve from it, each without its peeled rows). Holes that do not meet the
    material are left out (none meets it: nothing is peeled, the material stays whole)."""
    full = list(holes)  # the criterion looks at the whole holes; the carving at what is left
    carving = list(holes)
    slabs: list[np.ndarray] = []
    while True:
        inside = polytope_vertices_batch([np.vstack([material, h]) for h in full])
        live = [k for k, x in enumerate(inside) if _solid(x)]
        if not live:
            return slabs, material, v, []
        points = np.vstack([inside[k] for k in live])
        rows = np.vstack([carving[k] for k in live])
        owner = np.repeat(np.arange(len(live)), [len(carving[k]) for k in live])
        same = np.abs(rows[:, None] - rows[None]).max(axis=2) <= PARALLEL
        # in how many holes each row is; only holes on its inner side, material beyond it
        count = np.array([len(set(owner[m])) for m in same])
        fits = (matmul(points, rows[:, :3].T) - rows[:, 3]).max(axis=0) <= ON_PLANE
        beyond = (matmul(v, rows[:, :3].T) - rows[:, 3]).max(axis=0) > max(SOLID, overlap)
        if not (fits & beyond).any():
            return slabs, material, v, [carving[k] for k in live]
        best = rows[int(np.argmax(np.where(fits & beyond, count, 0)))]
        slab = np.vstack([material, -best])
        material = np.vstack([material, best + np.array([0.0, 0.0, 0.0, overlap])])
        sv, v = polytope_vertices_batch([slab, material])
        if _solid(sv):
            slabs.append(_pruned(slab, sv))
        material = _pruned(material, v)
        full = [full[k] for k in live]
        carving = [carving[k][~_same(carving[k], best)] for k in live]


def carve(
    material: np.ndarray, holes: Sequence[np.ndarray], overlap: float = OVERLAP
) -> list[Mesh]:
    """The convex pieces (outward meshes, m) of `material` minus `holes` (see carve_cells);
    slivers below assetgen.collision.cell_meshes.MIN_PIECE_VOLUME are dropped."""
    cells = carve_cells(material, holes, overlap)
    return cell_meshes(cells)


def carve_part(
    solids: Sequence[np.ndarray], holes: Sequence[np.ndarray], overlap: float = OVERLAP
) -> list[Mesh]:
    """The convex pieces of a part made of convex `solids` with convex `holes` cut from it
    (same frame): each solid carved by every hole, its pieces overlapping by `overlap` (m)
    at their seams. Pieces of different solids overlap where the solids do (a simulator's
    collision geoms may; the files' volume check is then done on the part's mesh, not on a
    sum of pieces), and only touch where the solids only touch."""
    return [m for s in solids for m in carve(s, holes, overlap)]
