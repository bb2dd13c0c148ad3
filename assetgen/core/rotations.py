"""Batched rotation helpers on numpy arrays; quaternions are (w, x, y, z)."""

from __future__ import annotations

import numpy as np

from assetgen.core.portable import norm


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions -> (..., 3, 3) rotation matrices (normalised first)."""
    q = np.asarray(q, dtype=float)
    q = q / norm(q)[..., None]
    w, x, y, z = np.moveaxis(q, -1, 0)
    r = np.empty((*q.shape[:-1], 3, 3))
    r[..., 0, 0] = 1 - 2 * (y * y + z * z)
    r[..., 0, 1] = 2 * (x * y - w * z)
    r[..., 0, 2] = 2 * (x * z + w * y)
    r[..., 1, 0] = 2 * (x * y + w * z)
    r[..., 1, 1] = 1 - 2 * (x * x + z * z)
    r[..., 1, 2] = 2 * (y * z - w * x)
    r[..., 2, 0] = 2 * (x * z - w * y)
    r[..., 2, 1] = 2 * (y * z + w * x)
    r[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices -> (..., 4) unit quaternions with w >= 0.

    Shepperd's method, branch per element: the largest of w, x, y, z is computed from the
    diagonal so no division by a small number happens.
    """
    r = np.asarray(r, dtype=float)
    m = r.reshape(-1, 3, 3)
    tr = np.trace(m, axis1=1, axis2=2)
    diag = np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    k = np.argmax(diag, axis=1)
    q = np.empty((len(m), 4))
    s = np.sqrt(np.maximum(1.0 + 2.0 * diag[np.arange(len(m)), k] - tr, 1e-300)) * 2.0
    # 4 q_k^2 = 1 + 2 diag_k - trace (diag_0 = trace for w); the others from off-diagonals
    a = m[:, 2, 1] - m[:, 1, 2]
    b = m[:, 0, 2] - m[:, 2, 0]
    c = m[:, 1, 0] - m[:, 0, 1]
    xy = m[:, 0, 1] + m[:, 1, 0]
    xz = m[:, 0, 2] + m[:, 2, 0]
    yz = m[:, 1, 2] + m[:, 2, 1]
    rows = {
        0: (s / 4, a / s, b / s, c / s),
        1: (a / s, s / 4, xy / s, xz / s),
        2: (b / s, xy / s, s / 4, yz / s),
        3: (c / s, xz / s, yz / s, s / 4),
    }
    for i, row in rows.items():
        sel = k == i
        q[sel] = np.stack(row, axis=1)[sel]
    q /= norm(q)[:, None]
    q[q[:, 0] < 0] *= -1
    return q.reshape(*r.shape[:-2], 4)


def matrix_to_rotvec(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (..., 3) rotation vectors, angle in [0, pi] (via quaternions: stable)."""
    q = matrix_to_quat(r)
    s = np.linalg.norm(q[..., 1:], axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 0])
    scale = np.where(s > 1e-12, angle / np.maximum(s, 1e-300), 2.0)
    return q[..., 1:] * scale[..., None]


def random_axes(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 3) unit vectors uniform on the sphere."""
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def rot6d(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (..., 6): the first two columns, column after column (Zhou et al. 2019)."""
    return np.concatenate([r[..., :, 0], r[..., :, 1]], axis=-1)


def rot6d_to_matrix(d6: np.ndarray) -> np.ndarray:
    """(..., 6) -> (..., 3, 3) by Gram-Schmidt: the inverse of rot6d for noisy input."""
    a = d6[..., :3]
    b = d6[..., 3:6]
    x = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b - np.sum(x * b, axis=-1, keepdims=True) * x
    y = b / np.linalg.norm(b, axis=-1, keepdims=True)
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=-1)


# Quaternion forms of the above for the env's per-step path: elementwise on (n,) columns, a
# few dozen numpy calls for the whole batch instead of (n, 3, 3) temporaries.


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., 4) x (..., 4) -> (..., 4) Hamilton products a b (rotation b, then a); the
    leading shapes broadcast."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = aw * bw - ax * bx - ay * by - az * bz
    out[..., 1] = aw * bx + ax * bw + ay * bz - az * by
    out[..., 2] = aw * by - ax * bz + ay * bw + az * bx
    out[..., 3] = aw * bz + ax * by - ay * bx + az * bw
    return out


def quat_conj(q: np.ndarray) -> np.ndarray:
    """(..., 4) -> (..., 4) conjugates (inverses of unit quaternions)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def rotvec_to_quat(v: np.ndarray) -> np.ndarray:
    """(n, 3) rotation vectors -> (n, 4) unit quaternions; zero vectors give identity."""
    angle = np.sqrt(np.einsum("ni,ni->n", v, v))
    # sin(angle / 2) / angle, with its limit 1/2 at 0
    s = np.where(angle > 1e-12, np.sin(0.5 * angle) / np.maximum(angle, 1e-300), 0.5)
    out = np.empty((len(v), 4))
    out[:, 0] = np.cos(0.5 * angle)
    out[:, 1:] = v * s[:, None]
    return out


def quat_rot6d(q: np.ndarray) -> np.ndarray:
    """(..., 4) unit quaternions -> (..., 6): rot6d of their matrices, without the matrices."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    out = np.empty((*q.shape[:-1], 6))
    out[..., 0] = 1 - 2 * (y * y + z * z)
    out[..., 1] = 2 * (x * y + w * z)
    out[..., 2] = 2 * (x * z - w * y)
    out[..., 3] = 2 * (x * y - w * z)
    out[..., 4] = 1 - 2 * (x * x + z * z)
    out[..., 5] = 2 * (y * z + w * x)
    return out
