"""Vertices of small bounded polytopes {n . x <= d} by enumerating plane triples, compiled.

A module's exact decomposition cuts ~30 cells of 6 - 71 planes each. Every triple of a
cell's planes is solved (Cramer's rule) and the point kept if it satisfies all the cell's
planes. As numpy over all triples at once this takes ~3.4 ms a module, mostly temporaries of
(systems, triples, planes) shape; one compiled loop that stops testing a point at the first
plane it violates (trying first the plane that cut off the last rejected point) takes a
fraction of that. Hand-written (numba) because no library solves
many tiny vertex enumerations at once: qhull's HalfspaceIntersection needs an interior point
(a linear program) and costs ~100 us a call.

Arithmetic: the same operations as that numpy form, in the same order where numpy's order
is defined (cross products, Cramer's sums); numpy sums its dot products (einsum) in an order
it does not fix, so a coordinate may differ in its last bit. The vertices are snapped to a
20 nm grid afterwards (assetgen.collision.cell_meshes.SNAP), which absorbs that: the pieces equal
the numpy form's up to the sign of zero, which the decomposition normalises.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

TOL = 1e-10
"""A point this far (m) beyond a plane still counts as inside it, and this near as on it."""
DET_MIN = 1e-6
"""|det| of a triple of unit normals below this: near-parallel planes, skipped. Their
vertices would be off by eps / |det|; genuine vertices also come from well-conditioned
triples."""


def _enumerate(planes, starts, sizes, tol, out, owner, masks):  # pragma: no cover - compiled
    found = 0
    words = masks.shape[1]
    for s in range(len(sizes)):
        base = starts[s]
        m = sizes[s]
        last = 0
        for i in range(m):
            a = planes[base + i]
            for j in range(i + 1, m):
                b = planes[base + j]
                for k in range(j + 1, m):
                    c = planes[base + k]
                    bcx = b[1] * c[2] - b[2] * c[1]
                    bcy = b[2] * c[0] - b[0] * c[2]
                    bcz = b[0] * c[1] - b[1] * c[0]
                    det = a[0] * bcx + a[1] * bcy + a[2] * bcz
                    if not abs(det) > DET_MIN:
                        continue
                    cax = c[1] * a[2] - c[2] * a[1]
                    cay = c[2] * a[0] - c[0] * a[2]
                    caz = c[0] * a[1] - c[1] * a[0]
                    abx = a[1] * b[2] - a[2] * b[1]
                    aby = a[2] * b[0] - a[0] * b[2]
                    abz = a[0] * b[1] - a[1] * b[0]
                    x = (a[3] * bcx + b[3] * cax + c[3] * abx) / det
                    y = (a[3] * bcy + b[3] * cay + c[3] * aby) / det
                    z = (a[3] * bcz + b[3] * caz + c[3] * abz) / det
                    # the plane that cut off the last rejected point first: most points
                    # are rejected, and a plane that cuts one off often cuts the next
                    p = planes[base + last]
                    if x * p[0] + y * p[1] + z * p[2] - p[3] > tol:
                        continue
                    inside = True
                    for q in range(m):
                        p = planes[base + q]
                        r = x * p[0] + y * p[1] + z * p[2] - p[3]
                        if r > tol:
                            inside = False
                            last = q
                            break
                        if words and r >= -tol:  # on plane q: bit q of the point's mask
                            masks[found, q >> 6] |= np.uint64(1) << np.uint64(q & 63)
                    if not inside:
                        for w in range(words):
                            masks[found, w] = 0
                    else:
                        out[found, 0] = x
                        out[found, 1] = y
                        out[found, 2] = z
                        owner[found] = s
                        found += 1
    return found


_KERNEL = None


def _compiled():
    """_enumerate compiled (numba, cached on disk). Imported on first use: numba's import
    costs ~0.9 s, which commands that generate nothing (a cached re-run) should not pay."""
    global _KERNEL
    if _KERNEL is None:
        from numba import njit

        _KERNEL = njit(cache=True)(_enumerate)
    return _KERNEL


def polytope_vertices_batch(systems: list[np.ndarray], tol: float = TOL) -> list[np.ndarray]:
    """Vertices of each bounded polytope {n . x <= d} given as (m_i, 4) planes (unit normals).

    Vertices where more than three planes meet come out once per triple through them (the
    caller merges them); an empty or flat polytope gives fewer than 4 points.
    """
    if not systems:
        return []
    v, bounds, _ = enumerate_vertices(Stacked.of(systems), tol, incidence=False)
    return [v[bounds[i] : bounds[i + 1]] for i in range(len(systems))]


class Stacked(NamedTuple):
    """Several systems of planes in one array, as the compiled loops take them."""

    planes: np.ndarray
    """(sum m_i, 4) every system's rows, in order."""
    starts: np.ndarray
    """(systems,) int64: where system i's rows start."""
    sizes: np.ndarray
    """(systems,) int64: m_i."""

    @classmethod
    def of(cls, systems: list[np.ndarray]) -> Stacked:
        sizes = np.array([len(s) for s in systems], dtype=np.int64)
        starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        return cls(np.ascontiguousarray(np.vstack(systems), dtype=np.float64), starts, sizes)


def enumerate_vertices(
    systems: Stacked, tol: float = TOL, *, incidence: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every polytope's vertices in one array, as polytope_vertices_batch finds them.

    Returns (points (n, 3), bounds (len(systems.sizes) + 1,): polytope i's points are
    points[bounds[i]:bounds[i + 1]], masks (n, words) uint64): with `incidence`, bit q of a
    point's mask says it lies on plane q of its system (|n . x - d| <= tol); without, no
    words.
    """
    planes, starts, sizes = systems
    capacity = int((sizes * (sizes - 1) * (sizes - 2) // 6).sum())
    out = np.empty((capacity, 3))
    owner = np.empty(capacity, np.int64)
    words = (int(sizes.max()) + 63) // 64 if incidence else 0
    masks = np.zeros((capacity, words), np.uint64)
    found = _compiled()(planes, starts, sizes, tol, out, owner, masks)
    bounds = np.searchsorted(owner[:found], np.arange(len(sizes) + 1))
    return out[:found], bounds, masks[:found]
