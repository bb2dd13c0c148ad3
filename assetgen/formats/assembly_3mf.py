"""3MF package of an assembly's parts laid out for printing, in millimetres.

Each part is its own object, turned to the orientation that prints it without supports (the
base on its plate, the profile on its bottom face, the bolt on its head) and placed on the
bed (z >= 0) beside the previous one, 10 mm apart along x. Deterministic bytes, as the
module's 3MF (assetgen.formats.threemf, whose package parts this shares).
"""

from __future__ import annotations

import numpy as np

from assetgen.core.mesh import Mesh
from assetgen.core.portable import matmul
from assetgen.formats.threemf import object_xml, package

GAP_MM = 10.0
"""Space between neighbouring parts on the bed, mm."""


def _placement(mesh: Mesh, turn: np.ndarray, x_mm: float) -> tuple[np.ndarray, float]:
    """The 3MF row-vector transform (4, 3) that turns the part by `turn` (3, 3), rests it
    on the bed and puts its left edge at x_mm; and the part's width along x, mm."""
    v = matmul(mesh.vertices * 1000.0, turn.T)
    lo, hi = v.min(axis=0), v.max(axis=0)
    cy = (lo[1] + hi[1]) / 2
    m = np.vstack([turn.T, [x_mm - lo[0], -cy, -lo[2]]])
    return m, float(hi[0] - lo[0])


def assembly_3mf_bytes(parts: list[tuple[str, Mesh, np.ndarray]]) -> bytes:
    """The 3MF of `parts`: (name, surface in its part frame (m), print turn (3, 3))."""
    objects, items, x = [], [], 0.0
    for oid, (name, mesh, turn) in enumerate(parts, 1):
        objects.append(object_xml(oid, name, mesh))
        m, width = _placement(mesh, np.asarray(turn, float), x)
        transform = " ".join(f"{v:.6f}" for v in m.ravel())
        items.append(f'<item objectid="{oid}" transform="{transform}"/>')
        x += width + GAP_MM
    model = (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<model unit="millimeter" xml:lang="en-US" '
        'xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">'
        '<metadata name="Application">assetgen</metadata>'
        "<resources>" + "".join(objects) + "</resources><build>" + "".join(items) + "</build>"
        "</model>"
    )
    return package(model)
