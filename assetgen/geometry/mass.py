"""Volume, centre of mass and inertia of a closed triangle mesh (divergence theorem).

The integrals are trimesh's (Eberly, "Polyhedral Mass Properties"), with x * x * x where
trimesh has `x ** 3`: numpy's power takes other last bits on CPUs with AVX-512, and the
inertia written into the MJCF and USD files must be the same on every machine.
"""

from __future__ import annotations

import numpy as np

from assetgen.core.mesh import Mesh, cross3
from assetgen.core.portable import cube

_DIVISORS = np.array([6, 24, 24, 24, 60, 60, 60, 120, 120, 120], dtype=np.float64)


def mass_properties(mesh: Mesh, mass: float) -> tuple[float, np.ndarray, np.ndarray]:
    """(volume m^3, centre of mass (3,) m, inertia (3, 3) kg m^2 about the centre of mass)
    of `mesh` (closed, outward normals) with `mass` spread uniformly over its volume."""
    tri = np.asarray(mesh.vertices, dtype=np.float64)[mesh.faces]
    t0, t1, t2 = tri[:, 0], tri[:, 1], tri[:, 2]
    crosses = cross3(t1 - t0, t2 - t1)
    f1 = t0 + t1 + t2
    f2 = t0 * t0 + t1 * t1 + t0 * t1 + t2 * f1
    f3 = cube(t0) + t0 * t0 * t1 + t0 * (t1 * t1) + cube(t1) + t2 * f2
    g = [f2 + (t + f1) * t for t in (t0, t1, t2)]
    integral = np.zeros((10, len(tri)))
    integral[0] = crosses[:, 0] * f1[:, 0]
    integral[1:4] = (crosses * f2).T
    integral[4:7] = (crosses * f3).T
    for i in range(3):
        j = (i + 1) % 3
        integral[7 + i] = crosses[:, i] * (
            t0[:, j] * g[0][:, i] + t1[:, j] * g[1][:, i] + t2[:, j] * g[2][:, i]
        )
    s = integral.sum(axis=1) / _DIVISORS
    volume = s[0]
    com = s[1:4] / volume
    density = mass / volume
    i = np.empty((3, 3))
    i[0, 0] = s[5] + s[6] - volume * (com[1] * com[1] + com[2] * com[2])
    i[1, 1] = s[4] + s[6] - volume * (com[0] * com[0] + com[2] * com[2])
    i[2, 2] = s[4] + s[5] - volume * (com[0] * com[0] + com[1] * com[1])
    i[0, 1] = i[1, 0] = -(s[7] - volume * com[0] * com[1])
    i[1, 2] = i[2, 1] = -(s[8] - volume * com[1] * com[2])
    i[0, 2] = i[2, 0] = -(s[9] - volume * com[0] * com[2])
    return float(volume), com, i * density
