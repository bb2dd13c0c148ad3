"""Checks every module passes before it is written: topology, exact clearance, free insertion.

The clearance and insertion checks run python-fcl on the meshes read back from the STL files
(millimetres, float32), not on the generator's in-memory solids, so what is verified is what a
user prints or simulates.
"""

from __future__ import annotations

import fcl
import numpy as np
import trimesh

from assetgen.frames import Frame
from assetgen.mesh import Mesh

CLEARANCE_TOLERANCE = 1e-6
"""Allowed |measured - nominal| clearance, m (1 um)."""
SEAT_PROBE = 1e-6
"""The insertion sweep ends this far (m) above the seat, where the floor gap would be zero."""


class CheckError(RuntimeError):
    """A generated module failed a check; the message gives the measured values."""


def topology(mesh: Mesh) -> dict:
    """Watertightness, winding, bodies, genus and volume (m^3) of a closed mesh."""
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    euler = int(tm.euler_number)
    return {
        "watertight": bool(tm.is_watertight),
        "winding_consistent": bool(tm.is_winding_consistent),
        "bodies": int(tm.body_count),
        "genus": (2 - euler) // 2,
        "volume_m3": float(tm.volume),
        "triangles": len(tm.faces),
    }


def _fcl_object(mesh: Mesh, matrix: np.ndarray | None = None) -> fcl.CollisionObject:
    bvh = fcl.BVHModel()
    bvh.beginModel(len(mesh.vertices), len(mesh.faces))
    bvh.addSubModel(mesh.vertices, mesh.faces)
    bvh.endModel()
    tf = fcl.Transform() if matrix is None else fcl.Transform(matrix[:3, :3], matrix[:3, 3])
    return fcl.CollisionObject(bvh, tf)


def _distance(a: fcl.CollisionObject, b: fcl.CollisionObject) -> float:
    return float(fcl.distance(a, b, fcl.DistanceRequest(), fcl.DistanceResult()))


def _swept_hull(peg: Mesh, start: np.ndarray, end: np.ndarray) -> Mesh:
    """The volume a convex peg sweeps moving straight from pose `start` to pose `end`.

    A convex body translated along a segment sweeps the Minkowski sum body + segment, which
    is the convex hull of the body at both ends: one exact distance query covers the path.
    """
    pts = np.vstack([peg.transformed(start).vertices, peg.transformed(end).vertices])
    hull = trimesh.convex.convex_hull(pts)
    return Mesh(np.asarray(hull.vertices), np.asarray(hull.faces, np.int64))


def clearance_checks(
    peg: Mesh, module: Mesh, design: Frame, clearance: float, travel: float
) -> dict:
    """Measure the peg-to-module gaps, all in metres.

    peg    : the peg in the peg frame (convex); module: the module in the module frame.
    design : the peg frame's design pose (seated, lifted by the clearance).
    travel : how far above the design pose (along the hole axis) the insertion starts.
    """
    m_design = design.matrix()
    axis = m_design[:3, 2]
    module_obj = _fcl_object(module)
    gap = _distance(_fcl_object(peg, m_design), module_obj)

    m_start = m_design.copy()
    m_start[:3, 3] += travel * axis
    insertion = _distance(_fcl_object(_swept_hull(peg, m_start, m_design)), module_obj)

    m_seat = m_design.copy()
    m_seat[:3, 3] -= (clearance - SEAT_PROBE) * axis
    seat = _distance(_fcl_object(_swept_hull(peg, m_design, m_seat)), module_obj)
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
    peg_t["convex"] = bool(trimesh.Trimesh(peg.vertices, peg.faces, process=False).is_convex)
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
