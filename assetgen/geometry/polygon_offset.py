"""The exact mitred offset of a simple polygon, and the checks that it is one.

Every edge's line moves out by the clearance c; each vertex of the offset is where its two
edges' moved lines meet (mitred: the faces move, the corners follow). Outside the offset
polygon, a point violates some moved line near it, so it lies more than c from the polygon;
on a moved edge, it lies exactly c from its edge. At a concave corner of the polygon the two
moved lines meet on the corner's bisector, exactly c from both edges: the gap is exact there
too. This is the non-convex counterpart of assetgen.geometry.clearance_hole (which moves
every plane of a convex solid) and of Table I's hole (solids.py), in two dimensions.

The offset is only an offset while every edge keeps its direction and the result stays
simple (no slot narrower than 2c closes, no short edge between two concave corners flips):
`mitred_offset` checks both and names the edge that fails. Hand-written: Clipper2 (through
manifold3d's CrossSection.offset) rounds its coordinates to a fixed grid, and the clearance
here must be exact to float rounding.
"""

from __future__ import annotations

import numpy as np

from assetgen.core.portable import dot
from assetgen.params.module_params import ParamError

PARALLEL = 1e-12
"""Two edges whose unit directions' cross product is below this are collinear."""


class OffsetError(ParamError):
    """The polygon cannot be offset by that distance and stay an offset of it (a parameter
    error: the user hears it in one line, as every ParamError)."""


def signed_area(poly: np.ndarray) -> float:
    """The signed area (m^2) of a polygon (n, 2), positive when counter-clockwise."""
    x, y = poly[:, 0], poly[:, 1]
    # numpy's pairwise sum, not BLAS's dot: the same bits on every CPU
    return 0.5 * float((x * np.roll(y, -1)).sum() - (np.roll(x, -1) * y).sum())


def centroid(poly: np.ndarray) -> np.ndarray:
    """The area centroid (2,) of a simple polygon (n, 2)."""
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    a = cross.sum() / 2
    return np.array([((x + xn) * cross).sum(), ((y + yn) * cross).sum()]) / (6 * a)


def edge_lines(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward unit normals (n, 2) and offsets (n,) of a counter-clockwise polygon's edges:
    edge i, from vertex i to i + 1, lies on n_i . x = d_i, the polygon on n_i . x <= d_i."""
    e = np.roll(poly, -1, axis=0) - poly
    normals = np.column_stack([e[:, 1], -e[:, 0]]) / np.linalg.norm(e, axis=1)[:, None]
    return normals, dot(normals, poly)


def segments_cross(a0, a1, b0, b1) -> bool:
    """Whether two closed segments share a point (collinear overlaps included)."""

    def orient(p, q, r) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    def on(p, q, r) -> bool:  # r on segment pq, given collinear
        return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(
            p[1], q[1]
        )

    d1, d2 = orient(b0, b1, a0), orient(b0, b1, a1)
    d3, d4 = orient(a0, a1, b0), orient(a0, a1, b1)
    if ((d1 > 0 > d2) or (d1 < 0 < d2)) and ((d3 > 0 > d4) or (d3 < 0 < d4)):
        return True
    return (
        (d1 == 0 and on(b0, b1, a0))
        or (d2 == 0 and on(b0, b1, a1))
        or (d3 == 0 and on(a0, a1, b0))
        or (d4 == 0 and on(a0, a1, b1))
    )


def first_crossing(poly: np.ndarray) -> tuple[int, int] | None:
    """The first pair of non-adjacent edges (i, j) of a closed polygon that meet, or None
    when it is simple."""
    n = len(poly)
    for i in range(n):
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue  # adjacent through the closing vertex
            if segments_cross(poly[i], poly[(i + 1) % n], poly[j], poly[(j + 1) % n]):
                return i, j
    return None


def check_simple(poly: np.ndarray, what: str = "polygon") -> np.ndarray:
    """poly (n, 2) as float64 if it is a simple counter-clockwise polygon without repeated or
    collinear consecutive vertices; OffsetError naming the fault otherwise."""
    poly = np.asarray(poly, dtype=float)
    if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3:
        raise OffsetError(f"{what}: give (n >= 3, 2) vertices, not shape {poly.shape}")
    if not np.isfinite(poly).all():
        raise OffsetError(f"{what}: a vertex is not finite")
    if signed_area(poly) <= 0:
        raise OffsetError(f"{what}: its vertices must run counter-clockwise (area > 0)")
    e = np.roll(poly, -1, axis=0) - poly
    length = np.linalg.norm(e, axis=1)
    if (length == 0).any():
        raise OffsetError(f"{what}: vertex {int(np.argmin(length))} repeats the next one")
    u = e / length[:, None]
    turn = np.abs(np.roll(u, 1, axis=0)[:, 0] * u[:, 1] - np.roll(u, 1, axis=0)[:, 1] * u[:, 0])
    if (turn < PARALLEL).any():
        raise OffsetError(f"{what}: vertex {int(np.argmin(turn))} lies on the line of its edges")
    crossing = first_crossing(poly)
    if crossing is not None:
        raise OffsetError(f"{what}: edges {crossing[0]} and {crossing[1]} cross; not simple")
    return poly


def _solve2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with a[i] @ x[i] = b[i] for 2 x 2 systems a (n, 2, 2), b (n, 2), by Cramer's rule
    (LAPACK's solve differs between CPUs in the last bit)."""
    det = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    x = (b[:, 0] * a[:, 1, 1] - a[:, 0, 1] * b[:, 1]) / det
    y = (a[:, 0, 0] * b[:, 1] - b[:, 0] * a[:, 1, 0]) / det
    return np.column_stack([x, y])


def mitred_offset(poly: np.ndarray, distance: float) -> np.ndarray:
    """The polygon (n, 2) with every edge moved out by `distance` (m, > 0), vertex i where
    the moved lines of edges i - 1 and i meet. OffsetError if an edge would turn round or
    vanish, or the offset would not be simple (the distance closes a slot or a notch)."""
    poly = check_simple(poly)
    if not distance > 0:
        raise OffsetError(f"offset distance = {distance!r} m; give a gap > 0")
    normals, d = edge_lines(poly)
    d = d + distance
    prev = np.roll(np.arange(len(poly)), 1)
    a = np.stack([normals[prev], normals], axis=1)  # (n, 2, 2): rows n_{i-1}, n_i
    out = _solve2(a, np.column_stack([d[prev], d]))
    e_old = np.roll(poly, -1, axis=0) - poly
    e_new = np.roll(out, -1, axis=0) - out
    along = dot(e_old, e_new) / dot(e_old, e_old)
    if (along <= 0).any():
        i = int(np.argmin(along))
        raise OffsetError(
            f"edge {i} ({np.linalg.norm(e_old[i]) * 1e3:.3f} mm) vanishes when the polygon is "
            f"offset by {distance * 1e3:g} mm: its corners close over it (a slot or a notch "
            "narrower than twice the clearance)"
        )
    crossing = first_crossing(out)
    if crossing is not None:
        raise OffsetError(
            f"the polygon offset by {distance * 1e3:g} mm is not simple (edges {crossing[0]} "
            f"and {crossing[1]} meet): a gap of the section is narrower than twice the clearance"
        )
    return out
