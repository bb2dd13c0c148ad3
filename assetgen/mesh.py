"""The triangle-mesh value passed between geometry, checks and exporters."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Mesh:
    """A closed triangle mesh.

    vertices : (n, 3) float64, metres, in the frame the owner names (peg or module frame).
    faces    : (m, 3) int64, counter-clockwise seen from outside (outward normals).
    """

    vertices: np.ndarray
    faces: np.ndarray

    def transformed(self, matrix: np.ndarray) -> Mesh:
        """The mesh moved by a (4, 4) homogeneous transform."""
        v = self.vertices @ matrix[:3, :3].T + matrix[:3, 3]
        return Mesh(v, self.faces)

    def to_trimesh(self):
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, process=False)
