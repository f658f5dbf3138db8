"""The small symmetric eigenproblems by Jacobi rotations (``ffsm_pin/_symmetric_kernels.py``)
against LAPACK (``np.linalg.eigh`` / ``eigvalsh``): the same eigenvalues to rounding of |A|,
orthonormal eigenvectors, and the damped pseudo-inverse's smallest singular value."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin._symmetric_kernels import smallest_eigenvalue, symmetric_eigen
from ffsm_pin.control.kernels import damped_pinv

EPS = np.finfo(float).eps


def _cases(rng, m):
    """Gram matrices over six decades, near-singular ones (two rows almost equal), repeated,
    widely spread (1e-12 .. 1e4), diagonal and zero matrices."""
    cases = []
    for k in range(200):
        Y = rng.normal(size=(m, 3 * m + 5)) * 10.0 ** rng.uniform(-3, 3)
        if k % 4 == 0:
            Y[-1] = Y[0] * (1.0 + 1e-7 * rng.normal(size=Y.shape[1]))
        cases.append(Y @ Y.T)
    Q = np.linalg.qr(rng.normal(size=(m, m)))[0]
    cases.append(Q @ np.diag(np.r_[1.0, 1.0, np.arange(m - 2) + 2.0][:m]) @ Q.T)  # repeated
    cases.append(Q @ np.diag(np.r_[np.arange(m - 2) + 1.0, 5.0, 5.0][-m:]) @ Q.T)  # largest twice
    cases.append(Q @ np.diag(np.logspace(-12, 4, m)) @ Q.T)
    cases.append(np.diag(rng.normal(size=m)))
    cases.append(np.zeros((m, m)))
    return cases


@pytest.mark.parametrize("m", [2, 3, 6])
def test_symmetric_eigen_is_lapacks_eigh_to_rounding(m, rng):
    """Jacobi's eigenvalues are LAPACK's to rounding of |A| (ascending), its eigenvectors
    orthonormal and V diag(lam) V^T = A to rounding; also for repeated eigenvalues (a
    regressor's G = Y Y^T with equal rows' norms), a diagonal and a zero matrix, and widely
    spread eigenvalues (1e-12 .. 1e4)."""
    cases = _cases(rng, m)
    for A in cases:
        lam, V = symmetric_eigen(A)
        want = np.linalg.eigvalsh(A)
        scale = max(np.abs(want).max(), 1e-300)
        assert np.all(np.diff(lam) >= 0)
        assert np.abs(lam - want).max() <= 16 * m * EPS * scale
        assert np.abs(V.T @ V - np.eye(m)).max() <= 16 * m * EPS
        assert np.abs(V @ np.diag(lam) @ V.T - A).max() <= 16 * m * EPS * scale
    upper = np.triu(cases[0]) + np.tril(rng.normal(size=(m, m)), -1)  # the upper triangle read
    assert np.array_equal(symmetric_eigen(upper)[0], symmetric_eigen(cases[0])[0])


@pytest.mark.parametrize("m", [1, 2, 3, 4, 6])
def test_smallest_eigenvalue_is_lapacks_to_rounding(m, rng):
    """The smallest eigenvalue is LAPACK's to rounding of |A| on every case of
    :func:`_cases` (up to JACOBI_LARGEST rows by rotations, above by LAPACK itself: the
    same LAPACK routine, though numba's and numpy's LAPACK builds may round apart), reading the
    upper triangle only."""
    for A in _cases(rng, m) if m > 1 else [np.array([[x]]) for x in rng.normal(size=20)]:
        want = np.linalg.eigvalsh(A)
        scale = max(np.abs(want).max(), 1e-300)
        got = smallest_eigenvalue(A)
        assert abs(got - want[0]) <= 16 * m * EPS * scale
    A = _cases(rng, m)[0] if m > 1 else np.array([[2.0]])
    upper = np.triu(A) + np.tril(rng.normal(size=(m, m)), -1)
    assert smallest_eigenvalue(upper) == smallest_eigenvalue(A)


@pytest.mark.parametrize("shape", [(2, 3), (3, 3), (3, 5), (6, 7)])
def test_the_damped_pseudo_inverse_sigma_is_the_smallest_singular_value(shape, rng):
    """damped_pinv's sigma is the smallest singular value of Re A (numpy's SVD) to rounding,
    its damping thr^2 - sigma^2 below the threshold and 0 above it, and its pseudo-inverse
    A^T (A A^T + damping E)^-1 (its residual that of a backward-stable solve), for
    well-conditioned and nearly rank-deficient A."""
    m, k = shape
    for j in range(100):
        A = rng.normal(size=shape)
        if j % 2:
            A[-1] = A[0] + 1e-4 * rng.normal(size=k)
        s = np.linalg.svd(A, compute_uv=False)
        thr = float(s[-1] * (2.0 if j % 3 else 0.5))
        pinv, sigma, damping = damped_pinv(A, thr)
        assert abs(sigma - s[-1]) <= 64 * EPS * s[0] ** 2 / max(s[-1], 1e-300)
        if s[-1] < thr * (1 - 1e-6):
            assert damping == pytest.approx(thr * thr - sigma * sigma, rel=1e-14)
        elif s[-1] > thr * (1 + 1e-6):
            assert damping == 0.0
        G = A @ A.T + damping * np.eye(m)
        residual = np.abs(pinv @ G - A.T).max()
        assert residual <= 64 * m * EPS * np.abs(pinv).max() * np.abs(G).max()
