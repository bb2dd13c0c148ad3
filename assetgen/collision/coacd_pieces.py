"""Approximate convex decomposition with CoACD, the general path for non-convex geometry.

Our modules have convex holes and use the exact decomposition; this path exists for parts
whose hole is not convex (profiles, sockets). CoACD can eat into a 1 mm clearance, so its
output always goes through the same clearance re-check as the exact pieces
(assetgen/collision/pieces.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from assetgen.core.mesh import Mesh


@dataclass(frozen=True)
class CoacdConfig:
    """CoACD settings (see its documentation)."""

    threshold: float = 0.02
    """Concavity threshold, in units of the mesh's bounding-box diagonal; lower = finer."""
    max_convex_hull: int = -1
    """Upper bound on the number of pieces; -1 = no bound."""
    preprocess_mode: str = "off"
    """Manifold pre-processing; our meshes are already manifold, so off."""
    seed: int = 0
    """CoACD's own random seed, fixed so the pieces are reproducible."""


def coacd_pieces(mesh: Mesh, config: CoacdConfig = CoacdConfig()) -> list[Mesh]:
    """Convex pieces (same frame and units as `mesh`) approximating `mesh`."""
    import coacd

    coacd.set_log_level("error")
    parts = coacd.run_coacd(
        coacd.Mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces)),
        threshold=config.threshold,
        max_convex_hull=config.max_convex_hull,
        preprocess_mode=config.preprocess_mode,
        seed=config.seed,
    )
    return [Mesh(np.asarray(v, float), np.asarray(f, np.int64)) for v, f in parts]
