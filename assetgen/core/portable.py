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


def cube(x: np.ndarray) -> np.ndarray:
    """x * x * x elementwise (numpy's `x ** 3` differs between CPUs in the last bit)."""
    x = np.asarray(x, dtype=np.float64)
    return x * x * x
