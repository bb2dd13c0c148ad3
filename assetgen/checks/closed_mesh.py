"""Checks that meshes are closed (convex) solids, for many small meshes at once.

A module has ~30 collision pieces of a dozen triangles each; checked one by one (trimesh,
qhull) they cost ~1.4 ms each, far more than the arithmetic, so every test here runs on all
meshes together in a few numpy calls and the per-mesh loop only picks the first failure.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from assetgen.core.mesh import Mesh, cross3

CONVEX_TOLERANCE = 1e-6
"""A vertex may lie this far inside the convex hull of the mesh's vertices (m) and the mesh
still count as convex: float32 millimetre STL rounding is ~1e-8 m on a 15 cm plate, a real
dent is far larger."""
MIN_PLANE_ALTITUDE = 1e-3
"""Triangles at least this tall (m) supply the planes of the fast convexity bound: their
planes are known to ~1e-8 x size / altitude despite float32 rounding. Slivers are left out,
which only loosens the bound (see convexity_excess)."""


def check_closed_meshes(meshes: Sequence[Mesh], names: Sequence[str], *, convex: bool) -> None:
    """Raise ValueError naming the first mesh that is not a closed solid.

    In order, for each mesh: at least 4 triangles; watertight (every edge joins exactly two
    triangles); consistently wound (every directed edge once); positive volume; and with
    `convex`, no vertex deeper than CONVEX_TOLERANCE inside the hull of the vertices.
    """
    if not meshes:
        return
    nf = np.array([len(m.faces) for m in meshes])
    nv = np.array([len(m.vertices) for m in meshes])
    foff = np.concatenate([[0], np.cumsum(nf)])
    voff = np.concatenate([[0], np.cumsum(nv)])
    vertices = np.vstack([m.vertices for m in meshes])
    faces = np.vstack([m.faces + o for m, o in zip(meshes, voff, strict=False)])
    owner = np.repeat(np.arange(len(meshes)), nf)  # mesh of each face

    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edge_owner = np.tile(owner, 3)
    n = len(vertices)
    undirected = np.sort(directed, axis=1)
    _, inv, count = np.unique(
        undirected[:, 0] * n + undirected[:, 1], return_inverse=True, return_counts=True
    )
    open_mesh = np.zeros(len(meshes), bool)
    open_mesh[edge_owner[count[inv] != 2]] = True
    key = directed[:, 0] * n + directed[:, 1]
    _, inv, count = np.unique(key, return_inverse=True, return_counts=True)
    flipped = np.zeros(len(meshes), bool)
    flipped[edge_owner[count[inv] != 1]] = True

    tri = vertices[faces]
    signed = np.einsum("ij,ij->i", tri[:, 0], cross3(tri[:, 1], tri[:, 2])) / 6.0
    volume = np.add.reduceat(signed, foff[:-1]) if len(signed) else np.zeros(len(meshes))
    volume[nf == 0] = 0.0

    for i, name in enumerate(names):
        if nf[i] < 4:
            raise ValueError(f"{name}: {nf[i]} triangles cannot enclose a volume")
        if open_mesh[i]:
            raise ValueError(
                f"{name}: not watertight (some edges do not join exactly two triangles); "
                "MuJoCo needs closed meshes"
            )
        if flipped[i]:
            raise ValueError(f"{name}: triangles are wound inconsistently (flipped faces)")
        if not volume[i] > 0:
            raise ValueError(
                f"{name}: volume {volume[i]:.3e} m^3 is not positive (faces point inwards, or "
                "the mesh is flat)"
            )
    if not convex:
        return
    for i in np.flatnonzero(~_convex_by_own_planes(vertices, faces, owner, voff)):
        excess, vertex = convexity_excess(meshes[i])
        if excess > CONVEX_TOLERANCE:
            raise ValueError(
                f"{names[i]}: not convex: vertex {vertex} lies {excess * 1e3:.4f} mm inside "
                "the mesh's convex hull; MuJoCo would collide it as its convex hull, filling "
                "the dent (decompose it into convex pieces)"
            )


def _convex_by_own_planes(
    vertices: np.ndarray, faces: np.ndarray, owner: np.ndarray, voff: np.ndarray
) -> np.ndarray:
    """(meshes,) bool: convexity proven cheaply; False means "ask qhull", not "dent".

    Let P be the intersection of the half-spaces below a mesh's well-shaped triangles (unit
    normals), grown by t = CONVEX_TOLERANCE / 2. Any set of half-spaces makes a convex P. If
    every vertex w lies inside P, the hull of the vertices does too, so w's depth in that
    hull is at most its depth in P, t - max_f(n_f . w - d_f). If moreover max_f(...) >= -t
    for every w, no vertex is deeper than 2 t = CONVEX_TOLERANCE: the exact test holds.
    Every vertex of a mesh against every good plane of its own (compiled: as numpy pairs this
    cost ~0.7 ms a module, most of the MJCF's mesh checks).
    """
    foff = np.searchsorted(owner, np.arange(len(voff)))  # faces come grouped by mesh
    proven = np.zeros(len(voff) - 1, bool)
    _proof()(
        np.ascontiguousarray(vertices, np.float64),
        np.ascontiguousarray(faces, np.int64),
        foff.astype(np.int64),
        np.asarray(voff, np.int64),
        CONVEX_TOLERANCE / 2,
        MIN_PLANE_ALTITUDE,
        proven,
    )
    return proven


def _own_planes(vertices, faces, foff, voff, t, altitude, proven):  # pragma: no cover
    """_convex_by_own_planes' loop (compiled; see _proof): proven[i] for mesh i."""
    for i in range(len(voff) - 1):
        f0, f1 = foff[i], foff[i + 1]
        planes = np.empty((f1 - f0, 4))
        n = 0
        for f in range(f0, f1):
            a = vertices[faces[f, 0]]
            b = vertices[faces[f, 1]]
            c = vertices[faces[f, 2]]
            ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
            vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
            nx = uy * vz - uz * vy
            ny = uz * vx - ux * vz
            nz = ux * vy - uy * vx
            area2 = np.sqrt(nx * nx + ny * ny + nz * nz)
            longest = 0.0
            for p, q in ((a, c), (b, a), (c, b)):
                dx, dy, dz = p[0] - q[0], p[1] - q[1], p[2] - q[2]
                longest = max(longest, dx * dx + dy * dy + dz * dz)
            if not area2 >= altitude * max(np.sqrt(longest), 1e-300):
                continue  # a sliver: its plane is ill-determined, left out
            nx, ny, nz = nx / area2, ny / area2, nz / area2
            planes[n, 0], planes[n, 1], planes[n, 2] = nx, ny, nz
            planes[n, 3] = nx * a[0] + ny * a[1] + nz * a[2]
            n += 1
        if n == 0:
            continue
        ok = True
        for v in range(voff[i], voff[i + 1]):
            w = vertices[v]
            top = -np.inf
            for k in range(n):
                h = w[0] * planes[k, 0] + w[1] * planes[k, 1] + w[2] * planes[k, 2] - planes[k, 3]
                top = max(top, h)
            if not (top <= t and top >= -t):
                ok = False
                break
        proven[i] = ok


_PROOF = None


def _proof():
    """_own_planes compiled (numba, cached on disk), on first use."""
    global _PROOF
    if _PROOF is None:
        from numba import njit

        _PROOF = njit(cache=True)(_own_planes)
    return _PROOF


def convexity_excess(mesh: Mesh) -> tuple[float, int]:
    """How deep (m) the deepest vertex lies inside the mesh's convex hull, and its index.

    0 for a convex mesh: every vertex is on its hull. Judged against qhull's hull (whose
    facets are merged robustly) rather than against each triangle's own plane: the planes of
    sliver triangles, which exact convex pieces can have, are ill-determined in float32.
    """
    from scipy.spatial import ConvexHull

    hull = ConvexHull(mesh.vertices)
    # equations: n . x + d <= 0 inside; on the hull the largest value over facets is ~0.
    height = (mesh.vertices @ hull.equations[:, :3].T + hull.equations[:, 3]).max(axis=1)
    k = int(np.argmin(height))
    return float(-height[k]), k
