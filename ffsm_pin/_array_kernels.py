"""Compiled (numba) array helpers and linear algebra the compiled kernels of every layer use (the
models', the attitude's and the controllers'): copies into part of an array, matrix products by
loops (real, or complex for a complex step), a solve as a kernel of its own, and the small
factorisations the control periods decide with. Each is the one home of its helper; the numpy
references they equal are named in their docstrings."""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit


@njit(cache=True)
def put(dst, start, src):
    """``dst[start : start + src.size] = src`` for vectors, by a loop: the same values, but a
    slice assignment from an array makes numba compile the code of its shape-mismatch message,
    about a second of a first run's critical path per array rank."""
    for i in range(src.size):
        dst[start + i] = src[i]


@njit(cache=True)
def put_rows(dst, src):
    """``dst[: src.shape[0], : src.shape[1]] = src`` for matrices, by a loop (see :func:`put`)."""
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]


@njit(cache=True)
def mv(A, x):
    """A @ x in x's dtype: A real and x real or complex, or both complex (a complex A with a
    real x is a typing error)."""
    out = np.zeros(A.shape[0], dtype=x.dtype)
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            out[i] += A[i, j] * x[j]
    return out


@njit(cache=True)
def mm(A, B):
    """A @ B by loops, in A's dtype (A complex, or A and B real; a complex B with a real A is
    a typing error). For the small matrices of the control periods (up to about 10 x 20): a
    few tens of ns against 0.15-0.3 us for numba's BLAS call; each entry sums its products in
    ascending order, so it may differ from a BLAS's sum in the last bits (docs/REPRODUCTION.md,
    "How exact these numbers are")."""
    out = np.zeros((A.shape[0], B.shape[1]), dtype=A.dtype)
    _add_product(A, B, out)
    return out


@njit(cache=True)
def _add_product(A, B, out):
    """out += A @ B by loops, each entry's products added in ascending order (:func:`mm`,
    :func:`cmm`)."""
    for i in range(A.shape[0]):
        for l in range(A.shape[1]):
            a = A[i, l]
            for j in range(B.shape[1]):
                out[i, j] += a * B[l, j]


@njit(cache=True)
def gram(A):
    """A @ A.T (plain transpose, complex-step safe) by loops, in A's dtype: symmetric by
    construction (each entry below the diagonal is the one above it); zeros for an A without
    columns."""
    m, k = A.shape
    out = np.zeros((m, m), dtype=A.dtype)
    for i in range(m):
        for j in range(i + 1):
            acc = out[i, j]
            for l in range(k):
                acc += A[i, l] * A[j, l]
            out[i, j] = acc
            out[j, i] = acc
    return out


# ---------------------------------------------------------------------- complex products
@njit(cache=True)
def cmm(A, B):
    """A @ B as complex128 (A, B real or complex, any layout)."""
    out = np.zeros((A.shape[0], B.shape[1]), dtype=np.complex128)
    _add_product(A, B, out)
    return out


@njit(cache=True)
def cmmt(A, B):
    """A @ B.T (plain transpose) as complex128: :func:`cmm` of the transposed view (each entry
    the same sum, in the same order)."""
    return cmm(A, B.T)


@njit(cache=True)
def cmv(A, x):
    """A @ x as complex128."""
    out = np.zeros(A.shape[0], dtype=np.complex128)
    for i in range(A.shape[0]):
        acc = 0j
        for j in range(A.shape[1]):
            acc += A[i, j] * x[j]
        out[i] = acc
    return out


@njit(cache=True)
def cmtv(A, x):
    """A.T @ x as complex128: :func:`cmv` of the transposed view (the same sums, in the same
    order)."""
    return cmv(A.T, x)


# ---------------------------------------------------------------------- linear algebra
@njit(cache=True)
def difference(A, B):
    """``A - B`` of two matrices of the same shape, by loops: the same values as numba's array
    expression, at about half its cost on the spatial regressors (10 x 300)."""
    out = np.empty(A.shape)
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            out[i, j] = A[i, j] - B[i, j]
    return out


@njit(cache=True)
def add_scaled(A, c, B):
    """``A += c * B`` in place for two matrices of the same shape, by loops: the same values as
    numba's array expression (each entry ``A + (c B)``), without its temporary (on the
    spatial regressors, 10 x 300: about 0.25 us against 2 us)."""
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            A[i, j] += c * B[i, j]


@njit(cache=True)
def positive_definite(A):
    """True when the symmetric real ``A`` is positive definite (M-hat of the filter, Eq. 46).

    A Cholesky factorisation by loops decides (5x5 to 10x10: 0.05-0.15 us against 1.2-3.8 us
    for LAPACK's eigenvalues inside a kernel); only when it meets a pivot that is not positive
    does LAPACK's smallest eigenvalue decide, the test the periods made before
    (``eigvalsh(A)[0] > 0``, that of the numpy reference). The two differ only for a matrix
    whose smallest eigenvalue is zero to rounding, where the factorisation may still complete.
    A decision, not a value: the periods' outputs are unchanged.
    """
    if not _cholesky(A)[1]:
        return np.linalg.eigvalsh(A)[0] > 0.0
    return True


@njit(cache=True)
def _cholesky(A):
    """(L, True) with L L^T = A, L lower triangular, for a symmetric ``A`` (its lower triangle
    read), by loops; (part of L, False) as soon as a pivot is not positive (or NaN)."""
    n = A.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return L, False
        d = np.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, n):
            x = A[i, j]
            for k in range(j):
                x -= L[i, k] * L[j, k]
            L[i, j] = x / d
    return L, True


@njit(cache=True)
def smallest_singular_value_above(A, tol):
    """(``sigma_3(A) > tol``, sigma_3 or NaN) for a real 3x3 ``A`` (the base rows' matrix of
    Eqs. 60a, 64-65, spatial).

    sigma_3 >= 2 |det A| / |A|_F^2 (since sigma_1 sigma_2 <= (sigma_1^2 + sigma_2^2) / 2):
    when that bound, less a margin for its own rounding, exceeds ``tol`` the answer is True
    without an SVD (the value is then not needed and returned as NaN); otherwise LAPACK's
    SVD decides, as before. Bound: 0.1 us; SVD inside a kernel: about 2 us.
    """
    det = (A[0, 0] * (A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1])
           - A[0, 1] * (A[1, 0] * A[2, 2] - A[1, 2] * A[2, 0])
           + A[0, 2] * (A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]))  # fmt: skip
    fro2 = 0.0
    for i in range(3):
        for j in range(3):
            fro2 += A[i, j] * A[i, j]
    if fro2 > 0.0 and np.isfinite(det):  # (entries near 1e100: det overflows, SVD decides)
        # the determinant's rounding is below ~20 eps |A|^3, the bound's below ~20 eps |A|
        if 2.0 * abs(det) / fro2 - 64.0 * 2.220446049250313e-16 * np.sqrt(fro2) > tol:
            return True, np.nan
    smallest = np.linalg.svd(A)[1][2]
    return smallest > tol, smallest


def _lapack_gesv() -> tuple[Any, Any]:
    """(numba's external declaration of LAPACK's dgesv, the integer type of its pivots): what
    :func:`np.linalg.solve` calls inside numba (SciPy's LAPACK through numba's helper library);
    (None, None) when this numba does not have them under those private names (:func:`solve`
    then calls ``np.linalg.solve``)."""
    try:
        from numba import types
        from numba.np.linalg import _LAPACK, F_INT_nptype

        return _LAPACK().numba_xgesv(types.float64), F_INT_nptype
    except (ImportError, AttributeError, TypeError):  # another numba's internals
        return None, None


_GESV, _PIVOT = _lapack_gesv()
_GESV_KIND = ord("d")  # numba's code for float64 (numba.np.linalg.get_blas_kind)
_SINGULAR = "Matrix is singular to machine precision."  # numba's message, word for word
_NOT_FINITE = "Array must not contain infs or NaNs."


@njit(cache=True)
def _finite_system(A, b) -> bool:
    """True when every entry of the matrix ``A`` and the vector ``b`` is finite."""
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            if not np.isfinite(A[i, j]):
                return False
    for i in range(b.size):
        if not np.isfinite(b[i]):
            return False
    return True


if _GESV is None:

    @njit(cache=True)
    def solve(A, b):
        """``np.linalg.solve(A, b)`` (this numba has no dgesv declaration under the private
        name :func:`_lapack_gesv` looks for)."""
        return np.linalg.solve(A, b)

else:

    @njit(cache=True)
    def solve(A, b):
        """``np.linalg.solve(A, b)`` for a real n x n ``A`` and a real vector ``b``, as a
        cached kernel of its own: the same LAPACK call (dgesv on a Fortran-ordered copy of A
        and a copy of b) and the same errors (``LinAlgError`` for entries not finite and for
        a singular A) as numba's ``np.linalg.solve``, hence the same values, bitwise; but its
        copies are loops, where numba's wrapper copies b by a slice assignment whose
        shape-mismatch message costs about 1.6 s of compiling (a first run compiles this
        kernel once, in its second process, and the periods and the plant load it).

        Parameters
        ----------
        A : ndarray, shape (n, n)
            The matrix (float64).
        b : ndarray, shape (n,)
            The right-hand side (float64).

        Returns
        -------
        ndarray, shape (n,)
            The solution x of A x = b.
        """
        n = A.shape[0]
        if A.shape[1] != n or b.size != n:
            raise ValueError("solve: A must be n x n and b of size n")
        if not _finite_system(A, b):
            raise np.linalg.LinAlgError(_NOT_FINITE)
        acpy = np.empty((n, n))  # A^T in C order: A in Fortran order, as LAPACK reads it
        for i in range(n):
            for j in range(n):
                acpy[j, i] = A[i, j]
        x = np.empty(n)
        for i in range(n):
            x[i] = b[i]
        ipiv = np.empty(n, dtype=_PIVOT)
        if n > 0:
            info = _GESV(_GESV_KIND, n, 1, acpy.ctypes, n, ipiv.ctypes, x.ctypes, n)
            if info > 0:  # (info < 0: an argument LAPACK refuses, not possible here)
                raise np.linalg.LinAlgError(_SINGULAR)
            acpy[0, 0] = ipiv[0]  # the copies stay alive until dgesv has returned
        return x


# ---------------------------------------------------------------------- small solves by loops
@njit(cache=True)
def symmetric_solve_transposed(G, B):
    """``(G^-1 B).T`` for a symmetric ``G`` (m x m, plain transpose: real, or complex at a
    complex step) whose real part is positive definite, and ``B`` (m x k), in G's dtype: an
    LDL^T factorisation without pivoting and k forward and back substitutions, by loops
    (m = 3..6: 0.1-0.3 us against 0.6-1 us for numba's ``np.linalg.inv`` and a product). A
    zero pivot raises ``LinAlgError``, as LAPACK's inverse of a singular matrix does.

    Parameters
    ----------
    G : ndarray, shape (m, m)
        The symmetric matrix (its upper triangle is not read).
    B : ndarray, shape (m, k)
        The right-hand sides, as columns.

    Returns
    -------
    ndarray, shape (k, m)
        The solutions, as rows.
    """
    m = G.shape[0]
    k = B.shape[1]
    L = np.zeros((m, m), dtype=G.dtype)
    d = np.empty(m, dtype=G.dtype)
    for j in range(m):
        dj = G[j, j]
        for l in range(j):
            dj -= L[j, l] * L[j, l] * d[l]
        if dj == 0.0:
            raise np.linalg.LinAlgError(_SINGULAR)
        d[j] = dj
        L[j, j] = 1.0
        for i in range(j + 1, m):
            x = G[i, j]
            for l in range(j):
                x -= L[i, l] * L[j, l] * d[l]
            L[i, j] = x / dj
    out = np.empty((k, m), dtype=G.dtype)
    for c in range(k):
        for i in range(m):  # L y = b
            x = B[i, c]
            for l in range(i):
                x -= L[i, l] * out[c, l]
            out[c, i] = x
        for i in range(m):  # D z = y
            out[c, i] = out[c, i] / d[i]
        for i in range(m - 1, -1, -1):  # L^T x = z
            x = out[c, i]
            for l in range(i + 1, m):
                x -= L[l, i] * out[c, l]
            out[c, i] = x
    return out


@njit(cache=True)
def spd_solve(A, b):
    """``np.linalg.solve(A, b)`` for a real symmetric positive definite ``A`` (n x n) and a
    vector ``b``, by a Cholesky factorisation in loops (n = 2..10: 0.05-0.3 us against 0.4-1 us
    for LAPACK's dgesv with its copies; the factorisation is :func:`positive_definite`'s). A
    matrix that is not positive definite to rounding, entries that are not finite or a result
    that is not finite hand the system to :func:`solve`, LAPACK's, with its errors.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        The matrix (only its lower triangle enters the factorisation).
    b : ndarray, shape (n,)
        The right-hand side.

    Returns
    -------
    ndarray, shape (n,)
        The solution x of A x = b.
    """
    n = A.shape[0]
    L, factored = _cholesky(A)
    if not (factored and _finite_system(A, b)):
        return solve(A, b)
    y = np.empty(n)
    for i in range(n):  # L y = b
        x = b[i]
        for l in range(i):
            x -= L[i, l] * y[l]
        y[i] = x / L[i, i]
    for i in range(n - 1, -1, -1):  # L^T x = y
        x = y[i]
        for l in range(i + 1, n):
            x -= L[l, i] * y[l]
        y[i] = x / L[i, i]
    if not np.all(np.isfinite(y)):
        return solve(A, b)
    return y


__all__ = [
    "add_scaled", "cmm", "cmmt", "cmtv", "cmv", "difference", "gram", "mm", "mv",
    "positive_definite", "put", "put_rows", "smallest_singular_value_above", "solve", "spd_solve",
    "symmetric_solve_transposed",
]  # fmt: skip
