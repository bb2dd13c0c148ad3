"""The CPU-independent arithmetic (assetgen.core.portable): the same results as numpy's and
LAPACK's up to rounding, and where LAPACK's are not unique (equal eigenvalues), a definite
answer. That its bits hold on other CPUs is tests/test_determinism.py's part."""

from __future__ import annotations

import numpy as np
import pytest

from assetgen.core.portable import matmul, rigid_inverse, symmetric_eigen


def _check_eigen(a: np.ndarray) -> None:
    values, vectors = symmetric_eigen(a)
    scale = np.abs(np.linalg.eigvalsh(a)).max()
    assert np.all(np.diff(values) >= 0)  # ascending
    assert values == pytest.approx(np.linalg.eigvalsh(a), abs=1e-14 * scale)
    assert np.abs(a @ vectors - vectors * values).max() <= 1e-14 * scale
    assert np.abs(vectors.T @ vectors - np.eye(3)).max() <= 1e-14


def test_symmetric_eigen_matches_lapack_on_random_matrices() -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        a = rng.normal(size=(3, 3))
        _check_eigen(a + a.T)


def test_symmetric_eigen_on_equal_moments_and_diagonal_matrices() -> None:
    """A symmetric section's inertia: two equal moments, in a turned frame, with the noise of
    a mesh integral; a diagonal matrix comes back as it is, its axes the unit vectors."""
    rng = np.random.default_rng(1)
    for _ in range(50):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        a = q @ np.diag([2e-5, 2e-5, 3e-5]) @ q.T
        _check_eigen(0.5 * (a + a.T) + 1e-21 * np.diag(rng.normal(size=3)))
    values, vectors = symmetric_eigen(np.diag([3.0, 1.0, 2.0]))
    assert values.tolist() == [1.0, 2.0, 3.0]
    assert vectors.tolist() == np.eye(3)[:, [1, 2, 0]].tolist()


def test_rigid_inverse_undoes_the_transform() -> None:
    rng = np.random.default_rng(2)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = q, rng.normal(size=3)
    assert np.abs(matmul(rigid_inverse(m), m) - np.eye(4)).max() < 1e-15
