"""Exact convex decomposition of a module whose hole is convex (hand-written: no library
decomposes exactly; CoACD approximates and eats into a 1 mm clearance).

The hole is H = {x : s_i(x) <= 0 for every hole plane i}, s_i(x) = n_i . x - d_i. Outside H
the largest s_i is positive, so the material splits exactly into the convex cells

    piece_i = material ∩ {s_i >= 0} ∩ {s_i >= s_j for the planes j next to i},

"material beyond face plane i where plane i is the farthest". Each cell lies beyond one hole
plane, so no piece comes nearer the seated peg than the clearance, and the cells do not
overlap, so their volumes add up to the module's (checked). The material is the plate near
the hole (a local box; the far plate is four plain boxes, so a broadphase prunes them) and
the sleeve below it. Cells are computed by enumerating plane triples, vectorised: a dozen
planes per cell, microseconds each.
"""

from __future__ import annotations

from functools import cache
from itertools import combinations

import numpy as np
from scipy.spatial import ConvexHull

from assetgen.geometry import ModuleGeometry
from assetgen.mesh import Mesh, cross3
from assetgen.polytope import (
    interior_point,
    offset_planes,
    polytope_vertices,
    transform_planes,
)

SNAP = 2e-8
"""Grid (m) piece vertices are snapped to: far below the 1 um clearance tolerance, above
float32 millimetre resolution (~5 nm on a 15 cm plate)."""
MIN_PIECE_VOLUME = 1e-12
"""Pieces below this volume (m^3, a 0.1 mm cube) are slivers of numerical noise: dropped."""


@cache
def _triples(m: int) -> np.ndarray:
    return np.array(list(combinations(range(m), 3)), dtype=np.int64)


def halfspace_vertices_batch(systems: list[np.ndarray], tol: float = 1e-10) -> list[np.ndarray]:
    """Vertices of many bounded polytopes {n . x <= d}, each given as (m_i, 4) planes.

    Every plane triple is solved at once (Cramer's rule over all systems, padded with the
    always-true plane 0 . x <= 1), then kept where it satisfies all of its system's planes.
    """
    m = max(len(s) for s in systems)
    planes = np.zeros((len(systems), m, 4))
    planes[:, :, 3] = 1.0
    for i, s in enumerate(systems):
        planes[i, : len(s)] = s
    idx = _triples(m)
    n = planes[:, idx, :3]  # (S, T, 3, 3)
    d = planes[:, idx, 3]  # (S, T, 3)
    bc = cross3(n[..., 1, :], n[..., 2, :])
    ca = cross3(n[..., 2, :], n[..., 0, :])
    ab = cross3(n[..., 0, :], n[..., 1, :])
    det = np.einsum("stk,stk->st", n[..., 0, :], bc)
    # |det| is the conditioning of the triple (unit normals): near-parallel triples give
    # vertices off by eps / |det|; genuine vertices also come from well-conditioned triples.
    ok = np.abs(det) > 1e-6
    safe = np.where(ok, det, 1.0)[..., None]
    x = (d[..., 0:1] * bc + d[..., 1:2] * ca + d[..., 2:3] * ab) / safe  # (S, T, 3)
    slack = np.einsum("stk,smk->stm", x, planes[..., :3]) - planes[:, None, :, 3]
    keep = ok & np.all(slack <= tol, axis=2)
    # Vertices where more than three planes meet come out several times; the hull merges them.
    return [x[i, keep[i]] for i in range(len(systems))]


def _incidence(planes: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """(k, p) bool: vertex p lies on plane k."""
    s = vertices @ planes[:, :3].T - planes[:, 3]
    return (np.abs(s) < 1e-9).T


def face_neighbours(
    hole_planes: np.ndarray, offsets: list[np.ndarray], cap: np.ndarray, guess: np.ndarray
) -> list[np.ndarray]:
    """For each hole plane, the planes sharing a vertex with it in the hole polytope or in any
    of its outward offsets (faces can meet differently once moved out). `cap` (1, 4) closes
    the polytope above every face; `guess` is a point inside the hole."""
    k = len(hole_planes)
    adjacent = np.zeros((k, k), bool)
    for off in offsets:
        planes = np.vstack([offset_planes(hole_planes, off), cap])
        inside = interior_point(planes, guess)
        inc = _incidence(planes, polytope_vertices(planes, inside))[:k].astype(int)
        adjacent |= (inc @ inc.T) >= 1
    np.fill_diagonal(adjacent, False)
    return [np.flatnonzero(row) for row in adjacent]


def _cell_planes(hole_planes: np.ndarray, i: int, nbrs: np.ndarray) -> np.ndarray:
    """Half-spaces of 'beyond plane i, and plane i the farthest among its neighbours'."""
    ni, di = hole_planes[i, :3], hole_planes[i, 3]
    beyond = np.array([[*(-ni), -di]])
    # s_j <= s_i  <=>  (n_j - n_i) . x <= d_j - d_i
    rivals = np.column_stack([hole_planes[nbrs, :3] - ni, hole_planes[nbrs, 3] - di])
    return np.vstack([beyond, rivals])


def _box_planes(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    eye = np.eye(3)
    return np.vstack([np.column_stack([eye, hi]), np.column_stack([-eye, -lo])])


_ROW = np.dtype([("x", np.float64), ("y", np.float64), ("z", np.float64)])


def _unique_rows(v: np.ndarray) -> np.ndarray:
    """np.unique(v, axis=0) for (n, 3) float64, by the same steps (sort the rows as records,
    keep the first of each run of equal ones) without its per-call reshaping, which costs
    more than the sort for the few dozen rows of a piece. Same steps, same rows: of 0.0 and
    -0.0, which compare equal, the same one is kept, so the files do not change."""
    rows = np.array(v, dtype=np.float64, order="C").view(_ROW).ravel()  # sorted: a copy
    rows.sort()
    keep = np.empty(len(rows), bool)
    keep[:1] = True
    keep[1:] = rows[1:] != rows[:-1]
    return rows[keep].view(np.float64).reshape(-1, 3)


def _mesh(vertices: np.ndarray) -> Mesh | None:
    """The convex hull of `vertices` as an outward-oriented mesh, or None if it has no volume."""
    # Vertices where several planes meet come out of different triples a few picometres
    # apart; snapped to a 20 nm grid they merge, so no sliver edge collapses when the piece
    # is stored as float32 millimetres (the clearance is re-measured on the stored piece).
    vertices = _unique_rows(np.round(vertices / SNAP) * SNAP)
    if len(vertices) < 4:
        return None
    try:
        hull = ConvexHull(vertices)
    except Exception:  # coplanar or degenerate: no volume
        return None
    if hull.volume < MIN_PIECE_VOLUME:
        return None
    faces = hull.simplices
    # qhull's simplices are unoriented; its facet equations give the outward normals.
    tri = vertices[faces]
    normal = cross3(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    flip = np.einsum("ij,ij->i", normal, hull.equations[:, :3]) < 0
    faces = np.where(flip[:, None], faces[:, ::-1], faces)
    remap = np.empty(len(vertices), np.int64)
    remap[hull.vertices] = np.arange(len(hull.vertices))
    return Mesh(vertices[hull.vertices], remap[faces])


def local_footprint(geom: ModuleGeometry) -> tuple[np.ndarray, np.ndarray]:
    """xy bounds (lo, hi) of the plate region around the hole, each (2,) in m."""
    p = geom.params
    t = p.plate_thickness
    slab = np.vstack([geom.hole_planes, [[0.0, 0.0, 1.0, 0.0]], [[0.0, 0.0, -1.0, t]]])
    v = polytope_vertices(slab, interior_point(slab, np.array([p.hole_x, p.hole_y, -t / 2])))
    half = p.plate_size / 2
    lo = np.maximum(v[:, :2].min(axis=0) - p.sleeve_wall, -half)
    hi = np.minimum(v[:, :2].max(axis=0) + p.sleeve_wall, half)
    return lo, hi


def exact_pieces(geom: ModuleGeometry) -> list[Mesh]:
    """Convex pieces (module frame, m) whose union is exactly the module."""
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
    design = geom.design_pose.matrix()
    guess = design[:3, 3] + 0.5 * p.hole_depth * design[:3, 2]
    nbrs = face_neighbours(hp, [np.zeros(k), walls], cap, guess)

    systems: list[np.ndarray] = []
    lo, hi = local_footprint(geom)
    # Far plate: four boxes around the local box.
    for blo, bhi in (
        ((-half, -half), (lo[0], half)),
        ((hi[0], -half), (half, half)),
        ((lo[0], -half), (hi[0], lo[1])),
        ((lo[0], hi[1]), (hi[0], half)),
    ):
        if bhi[0] - blo[0] > 1e-9 and bhi[1] - blo[1] > 1e-9:
            systems.append(_box_planes(np.array([*blo, -t]), np.array([*bhi, 0.0])))
    local_box = _box_planes(np.array([*lo, -t]), np.array([*hi, 0.0]))
    # Sleeve rows: k mitred hole planes, 4 box planes, the mid-plate cap. Below the plate the
    # sleeve is alone (inside it the local box covers everything), so cap at the underside.
    mitred = geom.sleeve_planes[:k]
    box_and_floor = np.vstack([geom.sleeve_planes[k : k + 4], [[0.0, 0.0, 1.0, -t]]])
    for i in range(k):
        cell = _cell_planes(hp, i, nbrs[i])
        systems.append(np.vstack([local_box, cell]))
        # Inside cell i every s_j <= s_i, so of the mitred planes only i's own, its
        # neighbours' and the floor's (thickness may differ from the wall's) can bind.
        rows = np.unique(np.concatenate([[i, k - 1], nbrs[i]]))
        systems.append(np.vstack([mitred[rows], box_and_floor, cell]))
    return [m for m in map(_mesh, _solve_all(systems)) if m is not None]


BATCH_MAX_PLANES = 24
"""Systems up to this many planes go through the batched triple solver; larger ones (the
floor's cell borders every side face) through qhull, whose cost grows more gently."""


def _solve_all(systems: list[np.ndarray]) -> list[np.ndarray]:
    out: list[np.ndarray | None] = [None] * len(systems)
    by_size: dict[int, list[int]] = {}
    for i, s in enumerate(systems):
        if len(s) <= BATCH_MAX_PLANES:
            by_size.setdefault(len(s), []).append(i)
        else:
            inside = interior_point(s)
            out[i] = polytope_vertices(s, inside) if inside is not None else np.zeros((0, 3))
    for group in by_size.values():
        for i, v in zip(group, halfspace_vertices_batch([systems[i] for i in group]), strict=True):
            out[i] = v
    return out  # type: ignore[return-value]
