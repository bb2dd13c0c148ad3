"""Products and norms whose bits do not depend on the CPU.

numpy hands `@`, `np.dot` and `np.linalg.norm` of a 1-D array to OpenBLAS, which picks its
kernel at run time: with AVX-512 its dot product fuses each multiply-add (one rounding),
without it rounds twice, and older kernels sum in another order. The last bits of a hole
plane then differ between machines, and manifold3d's boolean can triangulate the module
differently: the same seed would give other files on another CPU. numpy's power `x ** 3` likewise
uses SVML with AVX-512 and the C library without it.

Here every product is an elementwise multiply and every sum runs left to right over the
short inner axis, each step one IEEE-rounded numpy operation (numpy never fuses them), so the
result is the same on every machine. The arrays of the generator are tiny (3-vectors, 3 x 3
matrices, a few hundred vertices), where this costs nothing measurable.
"""

from __future__ import annotations

import math

import numpy as np


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """sum_i a[..., i] b[..., i], left to right: (..., n), (..., n) -> (...)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    total = a[..., 0] * b[..., 0]
    for i in range(1, a.shape[-1]):
        total = total + a[..., i] * b[..., i]
    return total


def norm(a: np.ndarray) -> np.ndarray:
    """Euclidean norm over the last axis, (..., n) -> (...). Bit for bit what
    np.linalg.norm(a, axis=-1) gives (a left-to-right sum of squares)."""
    return np.sqrt(dot(a, a))


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ b for a (..., n, k) or (k,) and b (k, m) or (k,), summed left to right over k."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if b.ndim == 1:
        return dot(a, b)
    rows = a[None] if a.ndim == 1 else a
    total = rows[..., :, 0, None] * b[0]
    for j in range(1, rows.shape[-1]):
        total = total + rows[..., :, j, None] * b[j]
    return total[0] if a.ndim == 1 else total


def rigid_inverse(m: np.ndarray) -> np.ndarray:
    """The inverse (4, 4) of a rigid transform [R p; 0 1]: [R^T  -R^T p; 0 1] (exact, where
    LAPACK's inverse differs between CPUs in the last bit)."""
    m = np.asarray(m, dtype=np.float64)
    out = np.eye(4)
    out[:3, :3] = m[:3, :3].T
    out[:3, 3] = -matmul(m[:3, :3].T, m[:3, 3])
    return out


def symmetric_eigen(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (3,) ascending and unit eigenvectors (3, 3, columns) of a symmetric 3 x 3
    matrix, by cyclic Jacobi rotations in Python's float arithmetic (each step one IEEE
    rounding, square roots correctly rounded, no fused multiply-add): the same bits on every
    CPU. LAPACK's eigh differs between kernels in the last bits, and where two eigenvalues
    are (nearly) equal, as the in-plane moments of a symmetric section are, its eigenvectors
    turn freely within their plane. Hand-written: no library promises CPU-independent bits.
    """
    m = [[float(a[i][j]) for j in range(3)] for i in range(3)]
    v = [[1.0 if i == j else 0.0 for j in range(3)] for i in range(3)]
    for _sweep in range(64):
        if m[0][1] == 0.0 and m[0][2] == 0.0 and m[1][2] == 0.0:
            break
        for p, q in ((0, 1), (0, 2), (1, 2)):
            apq = m[p][q]
            if apq == 0.0:
                continue
            app, aqq = m[p][p], m[q][q]
            g = 100.0 * abs(apq)
            if abs(app) + g == abs(app) and abs(aqq) + g == abs(aqq):
                m[p][q] = m[q][p] = 0.0  # below the diagonal's last bit: done
                continue
            theta = (aqq - app) / (2.0 * apq)
            t = (
                1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                if abs(theta) < 1e150
                else (0.5 / abs(theta))
            )
            t = -t if theta < 0.0 else t
            c = 1.0 / math.sqrt(t * t + 1.0)
            s = t * c
            m[p][p], m[q][q] = app - t * apq, aqq + t * apq
            m[p][q] = m[q][p] = 0.0
            r = 3 - p - q  # the third index
            arp, arq = m[r][p], m[r][q]
            m[r][p] = m[p][r] = c * arp - s * arq
            m[r][q] = m[q][r] = s * arp + c * arq
            for k in range(3):
                vkp, vkq = v[k][p], v[k][q]
                v[k][p], v[k][q] = c * vkp - s * vkq, s * vkp + c * vkq
    order = sorted(range(3), key=lambda k: (m[k][k], k))
    values = np.array([m[k][k] for k in order])
    vectors = np.array([[v[i][k] for k in order] for i in range(3)])
    return values, vectors


def cube(x: np.ndarray) -> np.ndarray:
    """x * x * x elementwise (numpy's `x ** 3` differs between CPUs in the last bit)."""
    x = np.asarray(x, dtype=np.float64)
    return x * x * x
