"""Exact convex decomposition of a module whose hole is convex (hand-written: no library
decomposes exactly; CoACD approximates and eats into a 1 mm clearance).

The hole is H = {x : s_i(x) <= 0 for every hole plane i}, s_i(x) = n_i . x - d_i. Outside H
the largest s_i is positive, so the material splits exactly into the convex cells

    cell_i = material ∩ {s_i >= 0} ∩ {s_i >= s_j for the planes j next to i},

"material beyond face plane i where plane i is the farthest". Each cell lies beyond one hole
plane, so no piece comes nearer the seated peg than the clearance. The material is the plate
near the hole (a local box; the far plate is four plain boxes, so a broadphase prunes them)
and the sleeve below it.

Each face of the hole belongs to one piece alone, its wall piece: cell i within the sleeve's
outline (its mitred outer planes and its box), from the sleeve's floor up through the plate
to the mounting surface (inside the outline the plate is material too). The rest of cell i
in the plate lies beyond that outline: one piece beyond the mitred plane, and one beyond each
box plane that trims the outline within the cell. (When a sleeve piece and a plate piece both
reached the same face, a peg face lying flat on it lay on two coplanar faces of two pieces,
where MuJoCo 4.0's multiccd returned contacts tens of mm deep: docs/physics.md.)

The cells tile the module and only touch; the pieces overlap instead (OVERLAP, why there).
Internal faces move OVERLAP into the neighbouring cell: the seams between cells (the rows
s_j <= s_i, scaled to unit normals, so each seam moves that distance whatever the angle
between the faces), the local box's sides inside the plate (into the far boxes; those along
y reach into those along x), and the plate pieces' faces on the sleeve's outline (into the
wall piece, and into the plate piece before them). What bounds the module never moves: the
plate's and the sleeve's outer planes, and each piece's own hole plane. So each piece still
lies in the material and beyond its hole plane, inside the module, and contains the cell it
grew from: their union is the module, with no seam left open. A wall piece that reaches past
its neighbours' cells may cross another face's mitred outer plane: it gets that plane too
(checked on its vertices).

Cells' vertices come from enumerating plane triples in one compiled loop over all of a
module's cells (assetgen.geometry.triple_vertices: 6 - 71 planes a cell, ~0.9 ms a module in
all), and their faces from the planes each vertex lies on (assetgen.collision.cell_meshes).
"""

from __future__ import annotations

import numpy as np

from assetgen.collision.cell_meshes import aligned_cell_meshes, largest_residuals
from assetgen.core.mesh import Mesh
from assetgen.core.portable import norm
from assetgen.geometry.polytope import offset_planes, polytope_vertices, transform_planes
from assetgen.geometry.solids import ModuleGeometry
from assetgen.geometry.triple_vertices import polytope_vertices_batch

OVERLAP = 0.002
"""How far (m) each piece reaches past a seam it shares with another piece, into that
piece. MuJoCo collides each convex piece on its own: where two pieces only touched, a peg
pressed into the seam could slip between them (each piece pushes it out through the shared
face, the shortest way out of that piece). Faces of the module itself (the plate's outside,
the sleeve's, the hole's) never move."""


def _incidence(planes: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """(k, p) bool: vertex p lies on plane k."""
    s = vertices @ planes[:, :3].T - planes[:, 3]
    return (np.abs(s) < 1e-9).T


def face_neighbours(
    hole_planes: np.ndarray, offsets: list[np.ndarray], cap: np.ndarray
) -> list[np.ndarray]:
    """For each hole plane, the planes sharing a vertex with it in the hole polytope or in any
    of its outward offsets (faces can meet differently once moved out). `cap` (1, 4) closes
    the polytope above every face."""
    k = len(hole_planes)
    adjacent = np.zeros((k, k), bool)
    systems = [np.vstack([offset_planes(hole_planes, off), cap]) for off in offsets]
    for planes, vertices in zip(systems, polytope_vertices_batch(systems), strict=True):
        inc = _incidence(planes, vertices)[:k].astype(int)
        adjacent |= (inc @ inc.T) >= 1
    np.fill_diagonal(adjacent, False)
    return [np.flatnonzero(row) for row in adjacent]


def _cell_planes(
    hole_planes: np.ndarray, nbrs: list[np.ndarray], overlap: float
) -> list[np.ndarray]:
    """For each hole plane i, the half-spaces of 'beyond plane i, and plane i the farthest
    among its neighbours', each seam with a neighbour moved `overlap` (m) into the
    neighbour's cell."""
    k = len(hole_planes)
    own = np.repeat(np.arange(k), [len(n) for n in nbrs])
    other = np.concatenate(nbrs)
    # s_j <= s_i  <=>  (n_j - n_i) . x <= d_j - d_i, scaled to a unit normal so that the
    # overlap moves the seam by that distance whatever the angle between the faces
    dn = hole_planes[other, :3] - hole_planes[own, :3]
    size = norm(dn)
    dd = (hole_planes[other, 3] - hole_planes[own, 3]) / size + overlap
    rivals = np.split(
        np.column_stack([dn / size[:, None], dd]), np.cumsum([len(n) for n in nbrs])[:-1]
    )
    return [np.vstack([-hole_planes[i : i + 1], rivals[i]]) for i in range(k)]


def _beyond_chamfer(cells: list[np.ndarray], chamfer: np.ndarray) -> list[np.ndarray]:
    """Each side's cell also beyond that side's entrance chamfer face (a face of the module:
    it never moves); the floor's cell as it is. Every side opens at the same rate, so the
    cells still tile the material (assetgen.geometry.solids.entrance_chamfer_planes)."""
    if not len(chamfer):
        return cells
    return [np.vstack([c, -chamfer[i : i + 1]]) for i, c in enumerate(cells[:-1])] + cells[-1:]


def _box_planes(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    eye = np.eye(3)
    return np.vstack([np.column_stack([eye, hi]), np.column_stack([-eye, -lo])])


def local_footprint(geom: ModuleGeometry) -> tuple[np.ndarray, np.ndarray]:
    """xy bounds (lo, hi) of the plate region around the hole, each (2,) in m: the hole's
    section grown by the wall, and the sleeve's outline through the plate (the wall pieces
    rise through it; a tilted hole's outline leans out)."""
    p = geom.params
    lo, hi = geom.hole_section
    lo, hi = lo - p.sleeve_wall, hi + p.sleeve_wall
    k = len(geom.hole_planes)
    slab = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, -1.0, p.plate_thickness]])
    outline = polytope_vertices(np.vstack([geom.sleeve_planes[: k + 4], slab]))
    if len(outline):
        lo = np.minimum(lo, outline[:, :2].min(axis=0))
        hi = np.maximum(hi, outline[:, :2].max(axis=0))
    half = p.plate_size / 2
    return np.maximum(lo, -half), np.minimum(hi, half)


def exact_decomposition(
    geom: ModuleGeometry, overlap: float = OVERLAP
) -> tuple[list[Mesh], list[np.ndarray]]:
    """Convex pieces (module frame, m) whose union is exactly the module, each reaching
    `overlap` (m) past its internal seams (0: cells that only touch), and each piece's
    half-spaces {n . x <= d} (unit normals), of which it is the intersection."""
    if not 0.0 <= overlap:
        raise ValueError(f"overlap = {overlap!r} m; expected >= 0")
    p = geom.params
    t = p.plate_thickness
    half = p.plate_size / 2
    hp = geom.hole_planes
    k = len(hp)
    walls = np.full(k, p.sleeve_wall)
    walls[-1] = p.floor_thickness
    # Close the hole above the peg's top so every face (the straight part above the top too)
    # has its vertices and neighbours.
    cap = transform_planes(
        np.array([[0.0, 0.0, 1.0, p.peg_height + 0.05]]), geom.design_pose.matrix()
    )
    nbrs = face_neighbours(hp, [np.zeros(k), walls], cap)

    systems: list[np.ndarray] = []
    lo, hi = local_footprint(geom)
    # Far plate: four boxes around the local box, the two along y reaching `overlap` into
    # the two along x (away from the hole, so they stay whole boxes of plate).
    wide_lo = max(lo[0] - overlap, -half)
    wide_hi = min(hi[0] + overlap, half)
    for blo, bhi in (
        ((-half, -half), (lo[0], half)),
        ((hi[0], -half), (half, half)),
        ((wide_lo, -half), (wide_hi, lo[1])),
        ((wide_lo, hi[1]), (wide_hi, half)),
    ):
        if bhi[0] - blo[0] > 1e-9 and bhi[1] - blo[1] > 1e-9:
            systems.append(_box_planes(np.array([*blo, -t]), np.array([*bhi, 0.0])))
    # The local box reaches `overlap` into the far boxes (its sides inside the plate).
    local_box = _box_planes(
        np.array([*np.maximum(lo - overlap, -half), -t]),
        np.array([*np.minimum(hi + overlap, half), 0.0]),
    )
    # Walls: each face of the hole belongs to one piece alone. Wall piece i is the sleeve's
    # cell i (mitred hole planes, the sleeve's 4 box planes) raised through the plate to
    # its top: inside the sleeve's outline the plate is material too. (Sleeve and plate
    # pieces that each reached the same face left a peg's face lying flat on two coplanar
    # faces, where MuJoCo's multiccd returns contacts tens of mm deep.)
    mitred = geom.sleeve_planes[:k]
    box = geom.sleeve_planes[k : k + 4]
    wall_cap = np.vstack([box, [[0.0, 0.0, 1.0, 0.0]]])
    cells = _beyond_chamfer(_cell_planes(hp, nbrs, overlap), geom.hole_chamfer_planes)
    # Without overlap, inside cell i every s_j <= s_i, so of the mitred planes only i's own,
    # its neighbours' and the floor's (thickness may differ from the wall's) can bind; a
    # cell reaching past its seams may cross others' (added below).
    has = np.zeros((k, k), bool)
    has[np.arange(k), np.arange(k)] = True
    has[:, k - 1] = True
    has[np.repeat(np.arange(k), [len(n) for n in nbrs]), np.concatenate(nbrs)] = True

    def wall_system(i: int) -> np.ndarray:
        """Wall piece i's half-spaces, with the mitred planes `has[i]` names."""
        return np.vstack([mitred[has[i]], wall_cap, cells[i]])

    first = len(systems)
    systems += [wall_system(i) for i in range(k)]
    # The plate of cell i around its wall piece: beyond the mitred plane, then beyond each
    # box plane that cuts the cell's part of the sleeve's outline (the box trims acute
    # corners), each inside the outer planes before it. Each reaches `overlap` into the
    # wall piece and into the plate pieces before it; none comes near a face of the hole.
    # Which of them hold plate is decided without overlap, so that the pieces grow from
    # the same cells whatever the overlap (a box plane may cut only where another one
    # already did: no cell of its own).
    bare_box = _box_planes(np.array([*lo, -t]), np.array([*hi, 0.0]))
    bare = _beyond_chamfer(_cell_planes(hp, nbrs, 0.0), geom.hole_chamfer_planes)

    def plate_cells(i: int, shift: float, region: np.ndarray, cell: np.ndarray) -> list:
        """Cell i's plate pieces within `region`, their outline planes moved `shift`."""
        move = np.array([0.0, 0.0, 0.0, shift])
        outer = np.vstack([mitred[i], box])
        beyond, inside, shared = move - outer, outer + move, np.concatenate([region, cell])
        # beyond outer plane j (from `shift` inside it), inside those before it (to `shift`)
        return [np.concatenate([shared, beyond[j : j + 1], inside[:j]]) for j in range(len(outer))]

    # which outline cells hold plate, for every i in one batch (each system's mesh depends on
    # that system alone, so batching changes no piece)
    tried = [plate_cells(i, 0.0, bare_box, bare[i]) for i in range(k)]
    kept = iter(aligned_cell_meshes([s for cells_i in tried for s in cells_i]))
    for i in range(k):
        grown = plate_cells(i, overlap, local_box, cells[i])
        systems += [s for s in grown if next(kept) is not None]
    meshes = aligned_cell_meshes(systems)

    # Every wall piece inside every mitred plane: a piece whose vertices all satisfy one
    # lies inside it (convex); one that crosses planes it lacks gets them and is made again
    # (it only shrinks, so the planes it satisfied stay satisfied).
    todo = [i for i in range(k) if meshes[first + i] is not None]
    while todo:
        reach = largest_residuals([meshes[first + i] for i in todo], mitred)
        more = (reach > 0.0) & ~has[todo]
        redo = [i for i, row in zip(todo, more.any(axis=1), strict=True) if row]
        if not redo:
            break
        has[todo] |= more
        for i in redo:
            systems[first + i] = wall_system(i)
        again = aligned_cell_meshes([systems[first + i] for i in redo])
        for i, m in zip(redo, again, strict=True):
            meshes[first + i] = m
        todo = [i for i in redo if meshes[first + i] is not None]
    kept = [s for s, m in enumerate(meshes) if m is not None]
    return [meshes[s] for s in kept], [systems[s] for s in kept]  # type: ignore[misc]


def exact_pieces(geom: ModuleGeometry, overlap: float = OVERLAP) -> list[Mesh]:
    """Convex pieces (module frame, m) whose union is exactly the module, overlapping by
    `overlap` (m) at their internal seams (see exact_decomposition)."""
    return exact_decomposition(geom, overlap)[0]
