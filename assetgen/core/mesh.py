"""The triangle-mesh value passed between geometry, checks and exporters."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from assetgen.core.portable import matmul


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
        v = matmul(self.vertices, matrix[:3, :3].T) + matrix[:3, 3]
        return Mesh(v, self.faces)

    def to_trimesh(self):
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, process=False)


@dataclass(frozen=True)
class StoredMesh(Mesh):
    """A mesh as a float32-millimetre file stores it and a reader gets it back (corners
    float32 mm, identical corners merged, vertices in byte order): what
    assetgen.core.stl.merge_vertices makes of float32 triangles. The type records it, so
    assetgen.core.inline_mesh.stored passes it through instead of rounding it again.
    Moving it (`transformed`) gives a plain Mesh."""


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (..., 3): np.cross without its per-call overhead,
    which dominates for the many small arrays of the mesh pipeline."""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], axis=-1)
