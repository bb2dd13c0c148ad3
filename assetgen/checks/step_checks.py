"""Checks of an assembly sequence, on the parts as their files store them.

For each step: the moving part in its design pose is at exactly its clearance (within
CLEARANCE_TOLERANCE) from everything present at that step (the base and the parts of earlier
steps, in their design poses), and its straight insertion path, from `travel` up its axis
to the design pose, comes no nearer than the clearance. Every part is one closed, outward
surface of positive volume (printable alone). Distances are python-fcl's, between the parts'
stored meshes (non-convex: a BVH each) and, for the path, the sweeps of the moving part's
convex pieces (a convex piece moved straight sweeps the hull of its two end poses; the
pieces' sweeps together are the part's).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from assetgen.checks.module_checks import (
    CLEARANCE_TOLERANCE,
    CheckError,
    fcl_distance,
    fcl_object,
    swept_hull,
    topology,
)
from assetgen.core.mesh import Mesh
from assetgen.core.rotations import quat_to_matrix
from assetgen.families.parts import Assembly


def _axis(frame) -> np.ndarray:
    return quat_to_matrix(np.asarray(frame.quat, dtype=float))[:, 2]


def check_parts(meshes: Mapping[str, Mesh]) -> dict:
    """Topology of every part's stored surface; CheckError unless each is one closed,
    consistently oriented body of positive volume."""
    out = {}
    for name, mesh in meshes.items():
        t = topology(mesh)
        if not (t["watertight"] and t["winding_consistent"]) or t["bodies"] != 1:
            raise CheckError(f"part {name!r} is not one closed, consistently oriented body: {t}")
        if t["volume_m3"] <= 0:
            raise CheckError(f"part {name!r} has volume {t['volume_m3']:.3e} m^3")
        out[name] = t
    return out


def _seated(assembly: Assembly, meshes: Mapping[str, Mesh], k: int):
    """Step k's part, the parts present (fcl objects, posed) and the part's seated gap (m)."""
    part = assembly.part(assembly.steps[k].part)
    present = [fcl_object(meshes[p.name], p.pose) for p in assembly.present_at(k)]
    moving = fcl_object(meshes[part.name], part.pose)
    return part, present, min(fcl_distance(moving, other) for other in present)


def check_steps(
    assembly: Assembly,
    meshes: Mapping[str, Mesh],
    pieces: Mapping[str, Sequence[Mesh]],
) -> list[dict]:
    """Measure every step (see the module docstring); CheckError on the first failure.

    meshes : each part's stored surface, in its part frame (m).
    pieces : each moving part's convex pieces, in its part frame (m).
    Returns per step the seated gap and the path's smallest gap (m).
    """
    out = []
    for k, step in enumerate(assembly.steps):
        part, present, seated = _seated(assembly, meshes, k)
        start = part.pose.copy()
        start[:3, 3] += step.travel * _axis(step.bottom)
        path = min(
            fcl_distance(fcl_object(swept_hull(piece, start, part.pose)), other)
            for piece in pieces[part.name]
            for other in present
        )
        c = step.clearance
        if abs(seated - c) > CLEARANCE_TOLERANCE:
            raise CheckError(
                f"step {k + 1} ({part.name}): seated {seated * 1e3:.6f} mm from the parts "
                f"present, not its clearance {c * 1e3:g} mm (within "
                f"{CLEARANCE_TOLERANCE * 1e6:g} um)"
            )
        if path < c - CLEARANCE_TOLERANCE:
            raise CheckError(
                f"step {k + 1} ({part.name}): its straight path comes within "
                f"{path * 1e3:.6f} mm of the parts present, less than its clearance "
                f"{c * 1e3:g} mm"
            )
        out.append({"part": part.name, "clearance_m": seated, "insertion_min_distance_m": path})
    return out


def check_printed(assembly: Assembly, meshes: Mapping[str, Mesh], offset: float) -> dict:
    """The printed files (every hole's faces moved out by `offset`, m): each part one closed
    body, and each step's seated gap measured on them, between its clearance (a gap that is
    not a hole's, such as a bolt head's seat, does not move) and its clearance plus the
    offset; CheckError otherwise. Returns the offset, the parts' topology and the gaps."""
    parts = check_parts(meshes)
    steps = []
    for k, step in enumerate(assembly.steps):
        part, _, seated = _seated(assembly, meshes, k)
        lo, hi = sorted((step.clearance, step.clearance + offset))
        if not lo - CLEARANCE_TOLERANCE <= seated <= hi + CLEARANCE_TOLERANCE:
            raise CheckError(
                f"step {k + 1} ({part.name}): the printed files seat it {seated * 1e3:.6f} mm "
                f"from the parts present, outside {lo * 1e3:g}-{hi * 1e3:g} mm (its clearance "
                f"and the print offset {offset * 1e3:g} mm)"
            )
        steps.append({"part": part.name, "clearance_m": seated})
    return {"print_offset_m": offset, "parts": parts, "steps": steps}
