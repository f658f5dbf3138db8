"""Small real symmetric eigenproblems for the compiled kernels, by cyclic Jacobi rotations
(loops): the eigen-decomposition of Eq. (28)'s 3 x 3 exponential and of the spatial
H_bm-hat H_bm-hat^T (:func:`symmetric_eigen`), and the smallest eigenvalue of the damped
pseudo-inverse's Gram matrix (:func:`smallest_eigenvalue`). On matrices this small LAPACK's
own routines cost more than the rotations (numbers in the docstrings); the numpy references
are ``np.linalg.eigh`` and ``np.linalg.eigvalsh``, which they equal to rounding."""

from __future__ import annotations

import numpy as np
from numba import njit

#: the largest order :func:`smallest_eigenvalue` takes by rotations (LAPACK above it)
JACOBI_LARGEST = 3


@njit(cache=True)
def symmetric_eigen(A):
    """(eigenvalues ascending, eigenvectors as columns) of a small real symmetric ``A`` (its
    upper triangle read), as ``np.linalg.eigh``: cyclic Jacobi rotations by loops until the
    off-diagonal part is below 1e-18 of the diagonal's (quadratic convergence: 3-5 sweeps for
    3 x 3). The 3 x 3 exponentials of Eq. (28) and the smallest singular value of H_bm-hat
    (spatial): about 0.1 us against 1-1.5 us for LAPACK's call inside a kernel. Eigenvalues to
    rounding of |A| like LAPACK's (tests/test_symmetric_kernels.py), in another order of
    operations.

    Parameters
    ----------
    A : ndarray, shape (m, m)
        The symmetric matrix (real).

    Returns
    -------
    lam : ndarray, shape (m,)
        The eigenvalues, ascending.
    V : ndarray, shape (m, m)
        Orthonormal eigenvectors, column ``i`` for ``lam[i]``.
    """
    m = A.shape[0]
    a = _symmetric_copy(A)
    V = np.zeros((m, m))
    for i in range(m):
        V[i, i] = 1.0
    _jacobi_sweeps(a, V)
    order = np.empty(m, dtype=np.int64)  # ascending, by insertion
    for i in range(m):
        j = i
        while j > 0 and a[order[j - 1], order[j - 1]] > a[i, i]:
            order[j] = order[j - 1]
            j -= 1
        order[j] = i
    lam = np.empty(m)
    W = np.empty((m, m))
    for j in range(m):
        lam[j] = a[order[j], order[j]]
        for i in range(m):
            W[i, j] = V[i, order[j]]
    return lam, W


@njit(cache=True)
def smallest_eigenvalue(A):
    """The smallest eigenvalue of a small real symmetric ``A`` (its upper triangle read): up to
    :data:`JACOBI_LARGEST` rows the rotations of :func:`symmetric_eigen` without the
    eigenvectors (2 x 2 0.13 us, 3 x 3 0.4 us, against 0.28 and 0.6 us for LAPACK's
    ``eigvalsh`` inside a kernel, which is LAPACK's own cost on matrices this small), above it
    LAPACK's ``eigvalsh`` (4 x 4 a tie, 6 x 6 1.8 us against 3.1 us for the rotations; the
    damped pseudo-inverse's Gram matrix is 2 x 2 to 6 x 6). To rounding of |A| like LAPACK's
    (tests/test_symmetric_kernels.py), in another order of operations.

    Parameters
    ----------
    A : ndarray, shape (m, m)
        The symmetric matrix (real).

    Returns
    -------
    float
        Its smallest eigenvalue.
    """
    a = _symmetric_copy(A)
    if a.shape[0] > JACOBI_LARGEST:
        return np.linalg.eigvalsh(a)[0]
    _jacobi_sweeps(a, None)
    lam = a[0, 0]
    for i in range(1, a.shape[0]):
        lam = min(lam, a[i, i])
    return lam


@njit(cache=True)
def _symmetric_copy(A):
    """A real symmetric copy of ``A`` from its upper triangle."""
    m = A.shape[0]
    a = np.empty((m, m))
    for i in range(m):
        for j in range(i, m):
            a[i, j] = A[i, j]
            a[j, i] = A[i, j]
    return a


@njit(cache=True)
def _jacobi_sweeps(a, V):
    """Cyclic Jacobi rotations of the symmetric ``a`` in place until its off-diagonal part is
    below 1e-18 of its diagonal's; the rotations accumulated into ``V`` (``V <- V G``) unless
    it is None (numba then compiles none of it)."""
    m = a.shape[0]
    for _sweep in range(50):
        off = 0.0
        diag = 0.0
        for i in range(m):
            diag += a[i, i] * a[i, i]
            for j in range(i + 1, m):
                off += a[i, j] * a[i, j]
        if not off > 1e-36 * diag:  # (also a zero or NaN matrix)
            break
        for p in range(m - 1):
            for q in range(p + 1, m):
                apq = a[p, q]
                if apq == 0.0:
                    continue
                theta = (a[q, q] - a[p, p]) / (2.0 * apq)
                t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                for k in range(m):  # A <- A G, then G^T A, V <- V G
                    akp, akq = a[k, p], a[k, q]
                    a[k, p], a[k, q] = c * akp - s * akq, s * akp + c * akq
                for k in range(m):
                    apk, aqk = a[p, k], a[q, k]
                    a[p, k], a[q, k] = c * apk - s * aqk, s * apk + c * aqk
                if V is not None:
                    for k in range(m):
                        vkp, vkq = V[k, p], V[k, q]
                        V[k, p], V[k, q] = c * vkp - s * vkq, s * vkp + c * vkq


__all__ = ["JACOBI_LARGEST", "smallest_eigenvalue", "symmetric_eigen"]
