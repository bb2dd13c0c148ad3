"""Exact convex decomposition of a module whose hole is convex (hand-written: no library
decomposes exactly; CoACD approximates and eats into a 1 mm clearance).

The hole is H = {x : s_i(x) <= 0 for every hole plane i}, s_i(x) = n_i . x - d_i. Outside H
the largest s_i is positive, so the material splits exactly into the convex cells

    piece_i = material ∩ {s_i >= 0} ∩ {s_i >= s_j for the planes j next to i},

"material beyond face plane i where plane i is the farthest". Each cell lies beyond one hole
plane, so no piece comes nearer the seated peg than the clearance, and the cells do not
overlap, so their volumes add up to the module's (checked). The material is the plate near
the hole (a local box; the far plate is four plain boxes, so a broadphase prunes them) and
the sleeve below it. Cells' vertices come from enumerating plane triples in one compiled
loop over all of a module's cells (assetgen.collision.triple_vertices: 6 - 71 planes a cell, ~0.7 ms
a module in all), and their faces from the planes each vertex lies on
(assetgen.collision.cell_meshes).
"""

from __future__ import annotations

import numpy as np

from assetgen.collision.cell_meshes import cell_meshes
from assetgen.collision.triple_vertices import polytope_vertices_batch
from assetgen.core.mesh import Mesh
from assetgen.geometry.polytope import offset_planes, transform_planes
from assetgen.geometry.solids import ModuleGeometry


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


def local_footprint(geom: ModuleGeometry) -> tuple[np.ndarray, np.ndarray]:
    """xy bounds (lo, hi) of the plate region around the hole, each (2,) in m."""
    p = geom.params
    t = p.plate_thickness
    slab = np.vstack([geom.hole_planes, [[0.0, 0.0, 1.0, 0.0]], [[0.0, 0.0, -1.0, t]]])
    (v,) = polytope_vertices_batch([slab])
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
    nbrs = face_neighbours(hp, [np.zeros(k), walls], cap)

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
    return cell_meshes(systems)
