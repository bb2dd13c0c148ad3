"""Convex cells as meshes, their faces read off the planes each vertex lies on.

The decompositions (assetgen.collision.exact for one convex hole, assetgen.collision.carve
for a union of convex holes) describe each piece as a small system of half-spaces
{n . x <= d}. Enumerating plane triples (assetgen.geometry.triple_vertices) gives each cell's
vertices and, for each, the planes it lies on. A face of the cell is then the set of
vertices on one of its planes: a convex polygon, ordered around its centre, fanned into
triangles and wound counter-clockwise about the plane's normal, which points outward.

Hand-written because the faces come for free from the enumeration: a general hull
(qhull, which this replaced) rediscovers them at ~70 us a cell, most of a module's
decomposition. Degenerate cells are common here (four or more planes meet where
neighbouring hole faces' cells meet), so:

- a vertex is a cluster of enumerated points closer than MERGE, its planes their union (a
  point where k planes meet comes out of each of their triples, picometres apart; two
  vertices nearer than float32 millimetres can resolve would merge when stored anyway);
- a plane holding fewer than three vertices, or the same vertices as an earlier one, adds
  no face;
- the vertices are snapped to a grid (SNAP), which moves a face's vertices off its plane by
  nanometres, so a face's triangles are flipped until every fold between them is convex
  for the snapped points: the mesh is then the hull of its vertices, as qhull's was (to
  within the snap where two vertices lie tens of nanometres apart, as planes that meet by
  chance can give: the sliver between them folds by ~10 nm);
- every cell's triangles must close (each directed edge once, its reverse once, every
  vertex used). A cell that does not, which takes near-coincident planes (none of the
  90,054 cells of Table I seeds 0-3071, nor of the 38,821 of profile-bolt assemblies 0-149),
  goes to qhull (scipy) instead.

A cell's vertices are sorted lexicographically (x, then y, then z), as before: the vertex
arrays are those qhull gave, and only the triangles differ.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from assetgen.core.mesh import Mesh, cross3
from assetgen.geometry.triple_vertices import Stacked, enumerate_vertices

SNAP = 2e-8
"""Grid (m) piece vertices are snapped to: far below the 1 um clearance tolerance, above
float32 millimetre resolution (~5 nm on a 15 cm plate)."""
MERGE = 5e-8
"""Enumerated points closer than this (m) are one vertex: more than float32 millimetres
resolve on a 15 cm plate (~8 nm), and more than the snap can move two points together
(2 x SNAP x sqrt(3) / 2), so distinct vertices stay distinct once snapped."""
MIN_PIECE_VOLUME = 1e-12
"""Pieces below this volume (m^3, a 0.1 mm cube) are slivers of numerical noise: dropped."""


def _cluster(points, bounds, masks, merge2, rep, cmask, cbounds):  # pragma: no cover
    """Group each cell's points into vertices (compiled; see _kernels): vertex c is point
    rep[c], with the planes cmask[c] of every point merged into it; cell s's vertices are
    cbounds[s]:cbounds[s + 1]. Returns the number of vertices."""
    n = 0
    words = masks.shape[1]
    for s in range(len(bounds) - 1):
        first = n
        cbounds[s] = first
        for r in range(bounds[s], bounds[s + 1]):
            hit = -1
            for c in range(first, n):
                q = rep[c]
                dx = points[r, 0] - points[q, 0]
                dy = points[r, 1] - points[q, 1]
                dz = points[r, 2] - points[q, 2]
                if dx * dx + dy * dy + dz * dz < merge2:
                    hit = c
                    break
            if hit < 0:
                hit = n
                rep[n] = r
                n += 1
            for w in range(words):
                cmask[hit, w] |= masks[r, w]
    cbounds[len(bounds) - 1] = n
    return n


def _faces(vpos, cbounds, cmask, planes, starts, sizes, tris, tri_cell, state):  # pragma: no cover
    """Each cell's triangles from its planes' vertex sets (compiled; see _kernels).

    state[s]: 1 the cell closed, 0 fewer than 4 vertices, 2 flat (one plane holds every
    vertex), 3 did not close (the caller asks qhull)."""
    nt = 0
    cap = 0
    for s in range(len(sizes)):
        v = cbounds[s + 1] - cbounds[s]
        if v > cap:
            cap = v
    members = np.empty((64, cap), np.int64)  # vertex lists of a cell's faces so far
    lengths = np.empty(64, np.int64)
    order = np.empty(cap, np.int64)
    key = np.empty(cap)
    count = np.zeros((cap, cap), np.int32)
    for s in range(len(sizes)):
        vs = cbounds[s]
        nv = cbounds[s + 1] - vs
        if nv < 4:
            state[s] = 0
            continue
        if sizes[s] > members.shape[0]:
            members = np.empty((sizes[s], cap), np.int64)
            lengths = np.empty(sizes[s], np.int64)
        first_tri = nt
        nf = 0
        flat = False
        for q in range(sizes[s]):
            word = q >> 6
            bit = np.uint64(1) << np.uint64(q & 63)
            k = 0
            for c in range(nv):
                if cmask[vs + c, word] & bit:
                    order[k] = c
                    k += 1
            if k < 3:
                continue
            if k == nv:
                flat = True
                break
            same = False
            for f in range(nf):
                if lengths[f] == k:
                    same = True
                    for i in range(k):
                        if members[f, i] != order[i]:
                            same = False
                            break
                    if same:
                        break
            if same:
                continue
            for i in range(k):
                members[nf, i] = order[i]
            lengths[nf] = k
            nf += 1
            # order the polygon by a pseudo-angle about its centre in the plane's own basis
            # (only + - * / and sqrt: the same order on every machine)
            p = planes[starts[s] + q]
            cx = 0.0
            cy = 0.0
            cz = 0.0
            for i in range(k):
                cx += vpos[vs + order[i], 0]
                cy += vpos[vs + order[i], 1]
                cz += vpos[vs + order[i], 2]
            cx /= k
            cy /= k
            cz /= k
            ax = abs(p[0])
            ay = abs(p[1])
            az = abs(p[2])
            if ax <= ay and ax <= az:  # u = e_x x n
                ux, uy, uz = 0.0, -p[2], p[1]
            elif ay <= az:  # u = e_y x n
                ux, uy, uz = p[2], 0.0, -p[0]
            else:  # u = e_z x n
                ux, uy, uz = -p[1], p[0], 0.0
            wx = p[1] * uz - p[2] * uy  # w = n x u: (u, w, n) is right-handed
            wy = p[2] * ux - p[0] * uz
            wz = p[0] * uy - p[1] * ux
            for i in range(k):
                c = vs + order[i]
                dx = vpos[c, 0] - cx
                dy = vpos[c, 1] - cy
                dz = vpos[c, 2] - cz
                x = dx * ux + dy * uy + dz * uz
                y = dx * wx + dy * wy + dz * wz
                t = abs(x) + abs(y)
                a = 0.0 if t == 0.0 else x / t
                key[i] = 1.0 - a if y >= 0.0 else 3.0 + a
            for i in range(1, k):  # insertion sort of (key, vertex)
                kk = key[i]
                oo = order[i]
                j = i - 1
                while j >= 0 and key[j] > kk:
                    key[j + 1] = key[j]
                    order[j + 1] = order[j]
                    j -= 1
                key[j + 1] = kk
                order[j + 1] = oo
            start = 0
            for i in range(1, k):
                if order[i] < order[start]:
                    start = i
            a0 = order[start]
            face_first = nt
            for i in range(1, k - 1):
                tris[nt, 0] = a0
                tris[nt, 1] = order[(start + i) % k]
                tris[nt, 2] = order[(start + i + 1) % k]
                tri_cell[nt] = s
                nt += 1
            _convex_folds(vpos, vs, tris, face_first, nt)
        if flat:
            nt = first_tri
            state[s] = 2
            continue
        # closed: every directed edge once and its reverse once
        for i in range(nv):
            for j in range(nv):
                count[i, j] = 0
        for t in range(first_tri, nt):
            for e in range(3):
                count[tris[t, e], tris[t, (e + 1) % 3]] += 1
        closed = nt - first_tri >= 4
        for i in range(nv):  # and every vertex on some triangle
            used = False
            for j in range(nv):
                if count[i, j] > 0:
                    used = True
                    break
            if not used:
                closed = False
        for t in range(first_tri, nt):
            for e in range(3):
                a = tris[t, e]
                b = tris[t, (e + 1) % 3]
                if count[a, b] != 1 or count[b, a] != 1:
                    closed = False
        if closed:
            state[s] = 1
        else:
            nt = first_tri
            state[s] = 3
    return nt


def _convex_folds(vpos, vs, tris, first, end):  # pragma: no cover - compiled
    """Flip diagonals of one face's triangles [first, end) until every fold between two of
    them is convex for the snapped vertices (the fourth vertex on or below the other
    triangle's plane). The snap moves a face's vertices off its plane by up to ~17 nm; a
    fan that ignores that folds inward by as much, which tilts a thin triangle's normal
    visibly. For a convex polygon whose vertices are lifted slightly off its plane, locally
    convex folds are the hull's (flips terminate: each raises the surface)."""
    for _ in range(64):
        flipped = False
        for t in range(first, end):
            for u in range(t + 1, end):
                for e in range(3):
                    a = tris[t, e]
                    b = tris[t, (e + 1) % 3]
                    c = tris[t, (e + 2) % 3]
                    d = -1
                    for f in range(3):
                        if tris[u, f] == b and tris[u, (f + 1) % 3] == a:
                            d = tris[u, (f + 2) % 3]
                    if d < 0:
                        continue
                    pa = vpos[vs + a]
                    abx = vpos[vs + b, 0] - pa[0]
                    aby = vpos[vs + b, 1] - pa[1]
                    abz = vpos[vs + b, 2] - pa[2]
                    acx = vpos[vs + c, 0] - pa[0]
                    acy = vpos[vs + c, 1] - pa[1]
                    acz = vpos[vs + c, 2] - pa[2]
                    adx = vpos[vs + d, 0] - pa[0]
                    ady = vpos[vs + d, 1] - pa[1]
                    adz = vpos[vs + d, 2] - pa[2]
                    nx = aby * acz - abz * acy
                    ny = abz * acx - abx * acz
                    nz = abx * acy - aby * acx
                    if nx * adx + ny * ady + nz * adz > 0.0:  # d above (a, b, c): concave
                        tris[t, 0] = c
                        tris[t, 1] = a
                        tris[t, 2] = d
                        tris[u, 0] = d
                        tris[u, 1] = b
                        tris[u, 2] = c
                        flipped = True
                        break
        if not flipped:
            return


def _fit(
    vertices, vbounds, faces, fbounds, planes, starts, sizes, tol, worst, loose
):  # pragma: no cover
    """How each mesh fits its cell (compiled; see cell_fit): worst[s] its vertices' largest
    residual over the cell's planes, loose[s] how many of its triangles have no plane that
    all three corners lie on (within tol)."""
    words = (sizes.max() + 63) // 64
    most = 0
    for s in range(len(sizes)):
        most = max(most, vbounds[s + 1] - vbounds[s])
    on = np.zeros((most, words), np.uint64)
    for s in range(len(sizes)):
        top = -np.inf
        for a in range(vbounds[s + 1] - vbounds[s]):
            x = vertices[vbounds[s] + a, 0]
            y = vertices[vbounds[s] + a, 1]
            z = vertices[vbounds[s] + a, 2]
            for w in range(words):
                on[a, w] = 0
            for q in range(sizes[s]):
                p = planes[starts[s] + q]
                r = x * p[0] + y * p[1] + z * p[2] - p[3]
                top = max(top, r)
                if abs(r) <= tol:
                    on[a, q >> 6] |= np.uint64(1) << np.uint64(q & 63)
        worst[s] = top
        bad = 0
        for f in range(fbounds[s], fbounds[s + 1]):
            a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
            common = False
            for w in range(words):
                if on[a, w] & on[b, w] & on[c, w]:
                    common = True
            if not common:
                bad += 1
        loose[s] = bad


def _largest(vertices, vbounds, planes, out):  # pragma: no cover - compiled
    """out[s, q]: the largest n_q . x - d_q over mesh s's vertices (compiled; see
    largest_residuals). Summed left to right, as assetgen.core.portable.matmul does."""
    for s in range(len(vbounds) - 1):
        for q in range(len(planes)):
            top = -np.inf
            for a in range(vbounds[s], vbounds[s + 1]):
                r = vertices[a, 0] * planes[q, 0]
                r = r + vertices[a, 1] * planes[q, 1]
                r = r + vertices[a, 2] * planes[q, 2]
                top = max(top, r - planes[q, 3])
            out[s, q] = top


_KERNELS = None
_CHECKS = None


def _kernels():
    """The two loops compiled (numba, cached on disk), on first use."""
    global _KERNELS
    if _KERNELS is None:
        from numba import njit

        global _convex_folds  # _faces calls it: compiled first, under the same name
        # one explicit signature: left to infer, numba compiles it three times over (its
        # index arguments come as the literal 0 or as int64)
        _convex_folds = njit("void(f8[:, ::1], i8, i8[:, ::1], i8, i8)", cache=True)(_convex_folds)
        _KERNELS = (njit(cache=True)(_cluster), njit(cache=True)(_faces))
    return _KERNELS


def warm_up() -> None:
    """Load (or compile, on a fresh checkout: a few seconds, then cached) every kernel of
    this module and of the vertex enumeration, e.g. in a parent process before it forks."""
    eye = np.eye(3)
    cube = np.column_stack([np.vstack([eye, -eye]), np.ones(6)])
    meshes = cell_meshes([cube])
    cell_fit(meshes, [cube], 0.0)
    largest_residuals(meshes, cube)


def _checks():
    """The two check loops compiled (numba, cached on disk), on first use."""
    global _CHECKS
    if _CHECKS is None:
        from numba import njit

        _CHECKS = (njit(cache=True)(_fit), njit(cache=True)(_largest))
    return _CHECKS


def _stacked(meshes: Sequence[Mesh]) -> tuple[np.ndarray, np.ndarray]:
    """All meshes' vertices in one array, and where each mesh's start (meshes + 1,)."""
    bounds = np.cumsum([0] + [len(m.vertices) for m in meshes])
    return np.ascontiguousarray(np.vstack([m.vertices for m in meshes]), np.float64), bounds


def cell_fit(
    meshes: Sequence[Mesh], systems: Sequence[np.ndarray], tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """How each closed convex mesh fits its cell {n . x <= d} ((m, 4) rows, unit normals):
    its vertices' largest residual n . x - d over the cell's planes (m; <= tol: the mesh is
    inside the cell), and how many of its triangles lie on none of the cell's planes (all
    three corners within `tol` of it). A closed convex surface inside the cell and all on
    its planes is the cell's surface: with no such triangle, the mesh is the whole cell."""
    planes, starts, sizes = Stacked.of(list(systems))
    vertices, vbounds = _stacked(meshes)
    fbounds = np.cumsum([0] + [len(m.faces) for m in meshes])
    faces = np.ascontiguousarray(np.vstack([m.faces for m in meshes]), np.int64)
    worst = np.empty(len(meshes))
    loose = np.empty(len(meshes), np.int64)
    _checks()[0](vertices, vbounds, faces, fbounds, planes, starts, sizes, tol, worst, loose)
    return worst, loose


def largest_residuals(meshes: Sequence[Mesh], planes: np.ndarray) -> np.ndarray:
    """(meshes, planes): the largest n . x - d over each mesh's vertices, for each of the
    (m, 4) `planes` (the same bits on every machine)."""
    vertices, bounds = _stacked(meshes)
    out = np.empty((len(meshes), len(planes)))
    _checks()[1](vertices, bounds, np.ascontiguousarray(planes, np.float64), out)
    return out


def cell_meshes(systems: list[np.ndarray]) -> list[Mesh]:
    """Each bounded cell {n . x <= d} ((m, 4) rows, unit normals) as a closed convex mesh,
    outward-oriented, in input order; cells with no volume (empty, flat, or a sliver below
    MIN_PIECE_VOLUME) are dropped."""
    return [m for m in aligned_cell_meshes(systems) if m is not None]


def aligned_cell_meshes(systems: list[np.ndarray]) -> list[Mesh | None]:
    """cell_meshes, with None in place of each dropped cell: item s is system s's mesh."""
    if not systems:
        return []
    cluster, faces = _kernels()
    planes, starts, sizes = stacked = Stacked.of(systems)
    points, bounds, masks = enumerate_vertices(stacked)
    n = len(points)
    rep = np.empty(n, np.int64)
    cmask = np.zeros((n, masks.shape[1]), np.uint64)
    cbounds = np.empty(len(systems) + 1, np.int64)
    nc = cluster(points, bounds, masks, MERGE * MERGE, rep, cmask, cbounds)
    # + 0.0 turns -0.0 into 0.0: equal coordinates are stored with one sign
    vpos = np.round(points[rep[:nc]] / SNAP) * SNAP + 0.0
    nv = np.diff(cbounds)
    tris = np.empty((int((sizes * nv).sum()), 3), np.int64)
    tri_cell = np.empty(len(tris), np.int64)
    state = np.zeros(len(systems), np.int64)
    nt = faces(vpos, cbounds, cmask[:nc], planes, starts, sizes, tris, tri_cell, state)
    tris, tri_cell = tris[:nt], tri_cell[:nt]
    tbounds = np.searchsorted(tri_cell, np.arange(len(systems) + 1))
    meshes: list[Mesh | None] = [None] * len(systems)
    for s in np.flatnonzero(state == 1):
        cell = vpos[cbounds[s] : cbounds[s + 1]]
        meshes[s] = Mesh(*_sorted(cell, tris[tbounds[s] : tbounds[s + 1]]))
    for s in np.flatnonzero(state == 3):
        meshes[s] = _qhull_mesh(_sorted(vpos[cbounds[s] : cbounds[s + 1]], None)[0])
    kept = [s for s, m in enumerate(meshes) if m is not None]
    if kept:
        volume = _volumes([meshes[s] for s in kept])
        for s in np.asarray(kept)[volume < MIN_PIECE_VOLUME]:
            meshes[s] = None
    return meshes


def _sorted(vertices: np.ndarray, faces: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
    """The vertices in lexicographic order (x, then y, then z), the faces renumbered."""
    order = np.lexsort((vertices[:, 2], vertices[:, 1], vertices[:, 0]))
    if faces is None:
        return vertices[order], None
    rank = np.empty(len(order), np.int64)
    rank[order] = np.arange(len(order))
    return vertices[order], rank[faces]


def _volumes(meshes: list[Mesh]) -> np.ndarray:
    nf = np.array([len(m.faces) for m in meshes])
    t = np.vstack([m.vertices[m.faces] for m in meshes])
    signed = np.einsum("ij,ij->i", t[:, 0], cross3(t[:, 1], t[:, 2])) / 6.0
    return np.add.reduceat(signed, np.concatenate([[0], np.cumsum(nf)[:-1]]))


def _qhull_mesh(vertices: np.ndarray) -> Mesh | None:
    """The hull of a cell whose planes did not give a closed surface; None if it has no
    volume."""
    from scipy.spatial import ConvexHull

    try:
        hull = ConvexHull(vertices)
    except Exception:  # coplanar or degenerate: no volume
        return None
    faces = hull.simplices
    tri = vertices[faces]
    normal = cross3(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    flip = np.einsum("ij,ij->i", normal, hull.equations[:, :3]) < 0
    faces = np.where(flip[:, None], faces[:, ::-1], faces)
    remap = np.empty(len(vertices), np.int64)
    remap[hull.vertices] = np.arange(len(hull.vertices))
    return Mesh(vertices[hull.vertices], remap[faces])
