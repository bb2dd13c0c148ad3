"""Checks every module passes before it is written: topology, exact clearance, free insertion.

The clearance and insertion checks run python-fcl on the meshes read back from the STL files
(millimetres, float32), not on the generator's in-memory solids, so what is verified is what a
user prints or simulates.
"""

from __future__ import annotations

import fcl
import numpy as np
from scipy.spatial import ConvexHull

from assetgen.core.frames import Frame
from assetgen.core.mesh import Mesh, cross3

CLEARANCE_TOLERANCE = 1e-6
"""Allowed |measured - nominal| clearance, m (1 um)."""
SEAT_PROBE = 1e-6
"""The insertion sweep ends this far (m) above the seat, where the floor gap would be zero."""


class CheckError(RuntimeError):
    """A generated module failed a check; the message gives the measured values."""


def topology(mesh: Mesh) -> dict:
    """Watertightness, winding, bodies, genus and volume (m^3) of a triangle mesh.

    Closed and consistently oriented <=> every directed edge appears once and its reverse
    once; genus from Euler's formula V - E + F = 2 - 2g per body (V counts the vertices the
    faces use, E the distinct undirected edges; bodies are the edge graph's components).
    """
    f = np.ascontiguousarray(mesh.faces, np.int64)
    counts = np.zeros(4, np.int64)
    _edge_graph()(f, len(mesh.vertices), counts)
    unique_directed, watertight, n_e, n_bodies = (int(c) for c in counts)
    n_v, n_f = int(np.count_nonzero(np.bincount(f.ravel(), minlength=1))), len(f)
    tri = mesh.vertices[f]
    volume = np.einsum("ij,ij->i", tri[:, 0], cross3(tri[:, 1], tri[:, 2])).sum() / 6.0
    return {
        "watertight": bool(watertight),
        "winding_consistent": bool(unique_directed),
        "bodies": n_bodies,
        "genus": int((2 * n_bodies - (n_v - n_e + n_f)) // 2),
        "volume_m3": float(volume),
        "triangles": int(n_f),
    }


def _edges(faces, n, counts):  # pragma: no cover - compiled (see _edge_graph)
    """counts = (every directed edge once, and its reverse too, undirected edges, bodies of
    the vertices the faces use): sorted integer keys a * n + b and a union-find, exact."""
    m = 3 * len(faces)
    key = np.empty(m, np.int64)
    pair = np.empty(m, np.int64)
    for t in range(len(faces)):
        for e in range(3):
            a, b = faces[t, e], faces[t, (e + 1) % 3]
            key[3 * t + e] = a * n + b
            pair[3 * t + e] = min(a, b) * n + max(a, b)
    key.sort()
    pair.sort()
    unique = 1
    for i in range(1, m):
        if key[i] == key[i - 1]:
            unique = 0
    closed = unique
    if closed:
        for i in range(m):
            a, b = key[i] // n, key[i] % n
            j = np.searchsorted(key, b * n + a)
            if j == m or key[j] != b * n + a:
                closed = 0
                break
    edges = 0
    parent = np.arange(n)
    for i in range(m):
        if i > 0 and pair[i] == pair[i - 1]:
            continue
        edges += 1
        a, b = pair[i] // n, pair[i] % n
        while parent[a] != a:  # path halving keeps the trees shallow
            parent[a] = parent[parent[a]]
            a = parent[a]
        while parent[b] != b:
            parent[b] = parent[parent[b]]
            b = parent[b]
        if a != b:
            parent[max(a, b)] = min(a, b)
    used = np.zeros(n, np.bool_)
    for t in range(len(faces)):
        for e in range(3):
            used[faces[t, e]] = True
    bodies = 0
    for v in range(n):
        if used[v] and parent[v] == v:
            bodies += 1
    counts[0], counts[1], counts[2], counts[3] = unique, closed, edges, bodies


_EDGES = None


def warm_up() -> None:
    """Load (or compile, then cached) the compiled checks, e.g. in a parent process before it
    forks: a tetrahedron through topology and the convexity proof."""
    from assetgen.checks.closed_mesh import check_closed_meshes

    tet = Mesh(
        np.vstack([np.zeros(3), np.eye(3)]), np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    )
    topology(tet)
    check_closed_meshes([tet], ["tetrahedron"], convex=True)


def _edge_graph():
    """_edges compiled (numba, cached on disk), on first use."""
    global _EDGES
    if _EDGES is None:
        from numba import njit

        _EDGES = njit(cache=True)(_edges)
    return _EDGES


def is_convex(mesh: Mesh, tol: float = 1e-7) -> bool:
    """Every vertex on or behind every face plane (outward normals), within `tol` m (float32
    STL coordinates put coplanar fan vertices a few nm off their face planes)."""
    tri = mesh.vertices[mesh.faces]
    n = cross3(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    height = np.einsum("fk,fvk->fv", n, mesh.vertices[None, :, :] - tri[:, None, 0, :])
    return bool(height.max() <= tol)


def fcl_object(mesh: Mesh, matrix: np.ndarray | None = None) -> fcl.CollisionObject:
    """`mesh` as a python-fcl triangle mesh (BVH), placed by the (4, 4) pose `matrix`
    (identity when None): exact triangle-triangle distances, any mesh."""
    bvh = fcl.BVHModel()
    bvh.beginModel(len(mesh.vertices), len(mesh.faces))
    bvh.addSubModel(mesh.vertices, mesh.faces)
    bvh.endModel()
    tf = fcl.Transform() if matrix is None else fcl.Transform(matrix[:3, :3], matrix[:3, 3])
    return fcl.CollisionObject(bvh, tf)


def fcl_convex(mesh: Mesh, matrix: np.ndarray | None = None) -> fcl.CollisionObject:
    """A convex mesh as an fcl.Convex: against a BVH mesh, fcl then runs GJK per triangle
    instead of triangle-triangle tests (0.3 against 0.8 ms a query), and agrees with the
    triangle-triangle distance within a few nm, far inside the 1 um tolerance. Only for
    meshes known to be convex (the checked peg, its sweeps)."""
    faces = np.column_stack([np.full(len(mesh.faces), 3), mesh.faces]).ravel()
    shape = fcl.Convex(mesh.vertices, len(mesh.faces), faces)
    tf = fcl.Transform() if matrix is None else fcl.Transform(matrix[:3, :3], matrix[:3, 3])
    return fcl.CollisionObject(shape, tf)


def fcl_distance(a: fcl.CollisionObject, b: fcl.CollisionObject) -> float:
    """The distance (m) between two fcl objects, as python-fcl measures it."""
    return float(fcl.distance(a, b, fcl.DistanceRequest(), fcl.DistanceResult()))


def lifted(pose: np.ndarray, distance: float) -> np.ndarray:
    """The (4, 4) pose moved by `distance` (m) along its own z axis (the hole axis for the
    peg's design pose): where the straight insertion starts, or how far down it goes."""
    out = pose.copy()
    out[:3, 3] += distance * pose[:3, 2]
    return out


def swept_hull(peg: Mesh, start: np.ndarray, end: np.ndarray) -> Mesh:
    """The volume a convex peg sweeps moving straight from pose `start` to pose `end`.

    A convex body translated along a segment sweeps the Minkowski sum body + segment, which
    is the convex hull of the body at both ends: one exact distance query covers the path.
    """
    pts = np.vstack([peg.transformed(start).vertices, peg.transformed(end).vertices])
    # Orientation of the hull's triangles does not matter to a distance query.
    return Mesh(pts, ConvexHull(pts).simplices.astype(np.int64))


def clearance_checks(
    peg: Mesh, module: Mesh, design: Frame, clearance: float, travel: float
) -> dict:
    """Measure the peg-to-module gaps, all in metres.

    peg    : the peg in the peg frame (convex); module: the module in the module frame.
    design : the peg frame's design pose (seated, lifted by the clearance).
    travel : how far above the design pose (along the hole axis) the insertion starts.
    """
    m_design = design.matrix()
    module_obj = fcl_object(module)
    gap = fcl_distance(fcl_convex(peg, m_design), module_obj)
    m_start = lifted(m_design, travel)
    insertion = fcl_distance(fcl_convex(swept_hull(peg, m_start, m_design)), module_obj)
    m_seat = lifted(m_design, -(clearance - SEAT_PROBE))
    seat = fcl_distance(fcl_convex(swept_hull(peg, m_design, m_seat)), module_obj)
    return {
        "clearance_m": gap,
        "clearance_error_m": gap - clearance,
        "insertion_travel_m": travel,
        "insertion_min_distance_m": insertion,
        "seat_approach_min_distance_m": seat,
    }


def verify(peg: Mesh, module: Mesh, design: Frame, clearance: float, travel: float) -> dict:
    """Run every check on meshes read back from disk; raise CheckError on the first failure.

    Returns every measured value (for module.json).
    """
    peg_t = topology(peg)
    peg_t["convex"] = is_convex(peg)
    mod_t = topology(module)
    for name, t in (("peg", peg_t), ("module", mod_t)):
        if not (t["watertight"] and t["winding_consistent"]):
            raise CheckError(f"{name} mesh is not a closed, consistently oriented surface: {t}")
        if t["bodies"] != 1:
            raise CheckError(f"{name} mesh has {t['bodies']} bodies, expected 1")
        if t["genus"] != 0:
            raise CheckError(f"{name} has genus {t['genus']}: the hole goes through (expected 0)")
        if t["volume_m3"] <= 0:
            raise CheckError(f"{name} volume {t['volume_m3']:.3e} m^3 is not positive")
    if not peg_t["convex"]:
        raise CheckError("peg mesh is not convex")
    gaps = clearance_checks(peg, module, design, clearance, travel)
    if abs(gaps["clearance_error_m"]) > CLEARANCE_TOLERANCE:
        raise CheckError(
            f"measured clearance {gaps['clearance_m'] * 1e3:.6f} mm differs from the nominal "
            f"{clearance * 1e3:g} mm by more than {CLEARANCE_TOLERANCE * 1e6:g} um"
        )
    if abs(gaps["insertion_min_distance_m"] - clearance) > CLEARANCE_TOLERANCE:
        raise CheckError(
            "straight insertion comes within "
            f"{gaps['insertion_min_distance_m'] * 1e3:.6f} mm of the module, "
            f"expected the clearance {clearance * 1e3:g} mm"
        )
    if gaps["seat_approach_min_distance_m"] < 0.5 * SEAT_PROBE:
        raise CheckError(
            f"the peg collides with the module on its last {clearance * 1e3:g} mm down to the seat"
        )
    return {"peg": peg_t, "module": mod_t, **gaps, "passed": True}
