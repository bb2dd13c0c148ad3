"""A rigid part's mass properties, validated once for every writer (MJCF, USD, assemblies)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from assetgen.core.portable import symmetric_eigen
from assetgen.core.rotations import matrix_to_quat


@dataclass(frozen=True)
class MassProperties:
    """Mass kg, centre of mass (3,) m and inertia (3, 3) kg m^2 about it, in the part's frame.

    Build it with `checked`: the values are finite, the mass positive, the tensor symmetric
    (made exactly so) with principal moments positive and obeying the triangle inequality
    (a physical body)."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray

    @classmethod
    def checked(
        cls, mass: float, com: np.ndarray, inertia: np.ndarray, name: str = "peg"
    ) -> MassProperties:
        """Validated properties; ValueError naming `{name}_mass`, `_com` or `_inertia`, what
        is wrong and what is expected."""
        try:
            ok = bool(np.isfinite(mass) and mass > 0)
        except TypeError:
            ok = False
        if not ok:
            raise ValueError(f"{name}_mass = {mass!r}; expected a finite mass > 0 in kilograms")
        c = np.asarray(com, dtype=float)
        if c.shape != (3,) or not np.isfinite(c).all():
            raise ValueError(
                f"{name}_com = {com!r}; expected a finite (3,) centre of mass in the part's "
                "frame, metres"
            )
        i = np.asarray(inertia, dtype=float)
        if i.shape != (3, 3) or not np.isfinite(i).all():
            raise ValueError(
                f"{name}_inertia has shape {i.shape} or non-finite entries; expected a finite "
                "(3, 3) inertia tensor about the COM in the part's frame, kg m^2"
            )
        if not np.allclose(i, i.T, rtol=0.0, atol=1e-9 * float(np.abs(i).max())):
            raise ValueError(f"{name}_inertia is not symmetric; pass the (3, 3) inertia tensor")
        i = 0.5 * (i + i.T)
        moments = np.linalg.eigvalsh(i)
        if not moments.min() > 0 or moments.max() > moments.sum() - moments.max() + 1e-12 * (
            moments.max()
        ):
            raise ValueError(
                f"{name}_inertia has principal moments {moments.tolist()} kg m^2; they must be "
                "> 0 and obey the triangle inequality (a physical body)"
            )
        return cls(float(mass), c, i)

    def principal(self, portable: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Principal moments (3,) kg m^2 and axes as a quaternion (4,) (w, x, y, z): the
        rotation R with inertia = R diag(moments) R^T (how UsdPhysics reads principalAxes).

        portable: by assetgen.core.portable.symmetric_eigen, the same bits on every CPU,
        also for a symmetric section whose in-plane moments are equal (the assembly
        families). False: LAPACK's eigh, which Table I's pinned files were written with;
        on its pegs it gives the same bits under the determinism test's CPU emulations
        (checked on 10,000 seeds with the Prescott kernel, 200 with the AVX2 one)."""
        if portable:
            moments, axes = symmetric_eigen(self.inertia)
        else:
            moments, axes = np.linalg.eigh(self.inertia)
        if np.linalg.det(axes) < 0:  # a reflection; a rotation is needed
            axes[:, 2] = -axes[:, 2]
        return moments, matrix_to_quat(axes)
