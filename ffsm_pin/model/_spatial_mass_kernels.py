"""Compiled (numba) kernels of the spatial model's mass matrix: M(q, theta_d) (Eq. 9a) and
its regressor Y_M(q, a) with Y_M theta_d = M a (whose first three rows are the momentum
regressor of Eq. 14).

The same expressions as the numpy reference of :mod:`ffsm_pin.model.spatial` (checked against
it in tests/model), written as loops over bodies and pairs that exploit the structure of
``S_k = [E_3, z_1, ..., z_k, 0, ...]``: ``S_k^T x = (x, z_1 . x, ..., z_k . x, 0, ...)``.

Shapes: R (n+1, 3, 3) body rotations, z (n, 3) inertial joint axes, N = n + 3 velocity
components, n_d = 6 (n+1) + 9 n (n+1) / 2 dynamic parameters.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._docstrings import doc_entries, fill_doc
from ._kernel_docs import KERNEL_DOC
from ._spatial_kinematics_kernels import body_rates, mm, mmt
from ._spatial_layout import SYM6


def _symmetric_index(entries) -> np.ndarray:
    """(3, 3) index of each entry of a symmetric 3x3 matrix in a 6-vector stored in the order
    ``entries`` ((i, j) pairs, i <= j)."""
    index = np.empty((3, 3), dtype=np.int64)
    for p, (i, j) in enumerate(entries):
        index[i, j] = index[j, i] = p
    return index


#: theta_k's index of body k's inertia entry (i, j) (:data:`._spatial_layout.SYM6`'s order:
#: xx, xy, xz, yy, yz, zz), for the compiled kernels.
INERTIA_INDEX = _symmetric_index(SYM6)


@njit(cache=True, inline="always")
def _add_st(Y, col, k, z, x0, x1, x2, base_only):
    """Y[:, col] += S_k^T x."""
    Y[0, col] += x0
    Y[1, col] += x1
    Y[2, col] += x2
    if not base_only:
        for j in range(k):
            Y[3 + j, col] += z[j, 0] * x0 + z[j, 1] * x1 + z[j, 2] * x2


@njit(cache=True, inline="always")
def _add_pair(Y, col, k, z, Rk, a, c, be_a, be_c, base_only):
    """Y[:, col] += S_k^T x, x = R_k[:, a] be_c + R_k[:, c] be_a: the Phi(beta) column of the
    pair (a, c) of axes, a != c, mapped by R_k."""
    _add_st(
        Y, col, k, z,
        Rk[0, a] * be_c + Rk[0, c] * be_a,
        Rk[1, a] * be_c + Rk[1, c] * be_a,
        Rk[2, a] * be_c + Rk[2, c] * be_a,
        base_only,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _add_cross(Y, col, k, z, q, b, p, R, j, base_only):
    """Y[:, col] += S_k^T x, x = q b - p R[:, j]: a body pair's column (each body's side)."""
    _add_st(
        Y, col, k, z,
        q * b[0] - p * R[0, j],
        q * b[1] - p * R[1, j],
        q * b[2] - p * R[2, j],
        base_only,
    )  # fmt: skip


@njit(cache=True, inline="always")
def body_block(R, theta, k, J, T1, X):
    """X = R_k J_k R_k^T: body k's inertia J_k (theta's entries 6k .. 6k + 5: xx, xy, xz, yy,
    yz, zz) in the inertial frame; J and T1 scratch (3x3, the dtype of X)."""
    for i in range(3):
        for j in range(3):
            J[i, j] = theta[6 * k + INERTIA_INDEX[i, j]]
    mm(R[k], J, T1)
    mmt(T1, R[k], X)


@njit(cache=True, inline="always")
def pair_block(R, theta, p, k, l, D, T1, X):
    """X = R_k D_kl R_l^T: the pair's 3x3 parameters D_kl (theta's entries p .. p + 8, row by
    row) between the frames of bodies k and l; D and T1 scratch (3x3)."""
    for i in range(3):
        for j in range(3):
            D[i, j] = theta[p + 3 * i + j]
    mm(R[k], D, T1)
    mmt(T1, R[l], X)


@njit(cache=True, inline="always")
def pair_coupling(X, Km):
    """Km = tr(X) E - X^T: the block S_k^T Km S_l of M for the pair block X (3x3)."""
    tr = X[0, 0] + X[1, 1] + X[2, 2]
    for i in range(3):
        for j in range(3):
            Km[i, j] = -X[j, i]
        Km[i, i] += tr


#: the entries :func:`ym` and :func:`add_ym` share
_YM_DOC = doc_entries(
    R_any="""
        R : ndarray (n+1, 3, 3)
            Body rotations R_k (real or complex).""",
    z=KERNEL_DOC["z"],
    a="""
        a : ndarray (N,)
            The vector M multiplies (an acceleration [rad/s^2], or w [rad/s] for the
            momentum rows).""",
    base_only="""
        base_only : bool
            Only the base rows 1-3 (Eq. 14's regressor of H_bb w_b + H_bm w_m).""",
    Y_set="""
        Y : ndarray (N, n_d), or (3, n_d) with ``base_only``
            The regressor Y_M(a), overwritten.""",
    Y_add="""
        Y : ndarray (N, n_d), or (3, n_d) with ``base_only``
            Y_M(a) is added to it.""",
    params_ym=("R_any", "z", "a", "Y_set", "base_only"),
    params_add_ym=("R_any", "z", "a", "Y_add", "base_only"),
)


@njit(cache=True)
@fill_doc(_YM_DOC)
def ym(R, z, a, Y, base_only):
    """Y with Y theta_d = M a (rows 1-3 only if base_only).

    %(params_ym)s
    """
    Y[:] = 0.0
    add_ym(R, z, a, Y, base_only)


@njit(cache=True)
@fill_doc(_YM_DOC)
def add_ym(R, z, a, Y, base_only):
    """Y += Y_M(a) in place (:func:`ym` without clearing ``Y`` first: a regressor added to
    another without a pass over a third array, as Eq. (50)'s filter input is).

    %(params_add_ym)s
    """
    nb = R.shape[0]
    b = np.zeros((nb, 3), dtype=R.dtype)
    body_rates(z, a, b)
    for k in range(nb):
        Rk = R[k]
        be0 = Rk[0, 0] * b[k, 0] + Rk[1, 0] * b[k, 1] + Rk[2, 0] * b[k, 2]
        be1 = Rk[0, 1] * b[k, 0] + Rk[1, 1] * b[k, 1] + Rk[2, 1] * b[k, 2]
        be2 = Rk[0, 2] * b[k, 0] + Rk[1, 2] * b[k, 1] + Rk[2, 2] * b[k, 2]
        c0 = 6 * k
        # Phi(beta) columns (xx, xy, xz, yy, yz, zz), mapped by R_k
        _add_st(Y, c0, k, z, Rk[0, 0] * be0, Rk[1, 0] * be0, Rk[2, 0] * be0, base_only)
        _add_pair(Y, c0 + 1, k, z, Rk, 0, 1, be0, be1, base_only)
        _add_pair(Y, c0 + 2, k, z, Rk, 0, 2, be0, be2, base_only)
        _add_st(Y, c0 + 3, k, z, Rk[0, 1] * be1, Rk[1, 1] * be1, Rk[2, 1] * be1, base_only)
        _add_pair(Y, c0 + 4, k, z, Rk, 1, 2, be1, be2, base_only)
        _add_st(Y, c0 + 5, k, z, Rk[0, 2] * be2, Rk[1, 2] * be2, Rk[2, 2] * be2, base_only)
    col = 6 * nb
    Q = np.empty((3, 3), dtype=R.dtype)
    u = np.empty(3, dtype=R.dtype)
    g = np.empty(3, dtype=R.dtype)
    for k in range(nb):
        Rk = R[k]
        for l in range(k + 1, nb):
            Rl = R[l]
            for i in range(3):
                u[i] = Rk[0, i] * b[l, 0] + Rk[1, i] * b[l, 1] + Rk[2, i] * b[l, 2]
                g[i] = Rl[0, i] * b[k, 0] + Rl[1, i] * b[k, 1] + Rl[2, i] * b[k, 2]
                for j in range(3):
                    Q[i, j] = Rk[0, i] * Rl[0, j] + Rk[1, i] * Rl[1, j] + Rk[2, i] * Rl[2, j]
            for i in range(3):
                for j in range(3):
                    q = Q[i, j]
                    _add_cross(Y, col, k, z, q, b[l], u[i], Rl, j, base_only)
                    _add_cross(Y, col, l, z, q, b[k], g[j], Rk, i, base_only)
                    col += 1


@njit(cache=True)
@fill_doc(KERNEL_DOC)
def mass_times(R, z, theta, a, out):
    """out = M(q, theta_d) a (Eq. 9a) without forming M: the body rates b_k = S_k a, each
    body's and each body pair's 3x3 inertia block applied to them, and the sums S_k^T y_k
    (real), for a product alone (the diagnostic e of Eq. 54): cheaper than forming M by
    :func:`mass_matrix_by_sums` and multiplying.

    %(params_R_z)s
    theta : ndarray (n_d,)
        Dynamic parameters theta_d of Eq. (12) [kg m^2].
    a : ndarray (N,)
        The vector M multiplies ([rad/s] or [rad/s^2]).
    out : ndarray (N,)
        M a, overwritten.
    """
    nb = R.shape[0]
    b = np.empty((nb, 3))
    body_rates(z, a, b)
    y = np.zeros((nb, 3))  # y_k: what body k's columns of S_k^T receive
    J = np.empty((3, 3))
    T1 = np.empty((3, 3))
    B = np.empty((3, 3))
    for k in range(nb):  # S_k^T (R_k J_k R_k^T) S_k a
        body_block(R, theta, k, J, T1, B)
        for i in range(3):
            y[k, i] += B[i, 0] * b[k, 0] + B[i, 1] * b[k, 1] + B[i, 2] * b[k, 2]
    p = 6 * nb
    D = np.empty((3, 3))
    X = np.empty((3, 3))
    for k in range(nb):  # S_k^T K S_l a + S_l^T K^T S_k a, K = tr(X) E - X^T
        for l in range(k + 1, nb):
            pair_block(R, theta, p, k, l, D, T1, X)
            p += 9
            tr = X[0, 0] + X[1, 1] + X[2, 2]
            for i in range(3):
                xl = X[0, i] * b[l, 0] + X[1, i] * b[l, 1] + X[2, i] * b[l, 2]  # X^T b_l
                xk = X[i, 0] * b[k, 0] + X[i, 1] * b[k, 1] + X[i, 2] * b[k, 2]  # X b_k
                y[k, i] += tr * b[l, i] - xl
                y[l, i] += tr * b[k, i] - xk
    s0 = s1 = s2 = 0.0  # out = sum_k S_k^T y_k: suffix sums over the bodies after joint j
    for k in range(nb - 1, 0, -1):
        s0 += y[k, 0]
        s1 += y[k, 1]
        s2 += y[k, 2]
        out[2 + k] = z[k - 1, 0] * s0 + z[k - 1, 1] * s1 + z[k - 1, 2] * s2
    out[0], out[1], out[2] = s0 + y[0, 0], s1 + y[0, 1], s2 + y[0, 2]


@njit(cache=True)
@fill_doc(KERNEL_DOC)
def mass_matrix_by_sums(R, z, theta, M):
    """M(q, theta_d) (Eq. 9a), N x N and real, by sums over the bodies: with K_kl the 3x3
    block of bodies k and l (R_k J_k R_k^T, and for k < l tr(X) E - X^T, X = R_k D_kl R_l^T,
    its transpose for l < k), M[r, c] = s_r . sum_{k >= k(r)} sum_{l >= k(c)} K_kl s_c, where
    s_c is M's column c of S (e_c for the base, z_j for joint j) and k(c) the first body it
    moves (0 for the base, j + 1 for joint j). Suffix sums over l and then over k form every
    entry from the 3x3 blocks once; symmetric bit for bit (the lower triangle mirrored). The
    one compiled M of the package: the control periods' M-hat and the model's
    :meth:`~ffsm_pin.model.spatial.SpatialBarycentricModel.mass_matrix` (numba backend); the
    numpy reference's M to rounding (tests/model).

    %(params_R_z)s
    theta : ndarray (n_d,)
        Dynamic parameters theta_d of Eq. (12) [kg m^2].
    M : ndarray (N, N)
        The mass matrix [kg m^2], overwritten.
    """
    nb = R.shape[0]
    N = nb + 2
    K = np.empty((nb, nb, 3, 3))  # K[k, l]: the block of bodies k, l
    J = np.empty((3, 3))
    T1 = np.empty((3, 3))
    X = np.empty((3, 3))
    for k in range(nb):
        body_block(R, theta, k, J, T1, X)
        K[k, k] = X
    p = 6 * nb
    for k in range(nb):
        for l in range(k + 1, nb):
            pair_block(R, theta, p, k, l, J, T1, X)
            p += 9
            pair_coupling(X, K[k, l])
            for i in range(3):
                for j in range(3):
                    K[l, k, j, i] = K[k, l, i, j]
    F = np.zeros((nb, N, 3))  # F[k, c] = sum_{l >= k(c)} K_kl s_c
    T = np.empty((3, 3))
    for k in range(nb):
        T[:] = 0.0
        for l in range(nb - 1, -1, -1):  # T = sum_{l' >= l} K_kl'
            for i in range(3):
                for j in range(3):
                    T[i, j] += K[k, l, i, j]
            if l > 0:  # joint l - 1 (first moving body l)
                c = 2 + l
                for i in range(3):
                    F[k, c, i] = (
                        T[i, 0] * z[l - 1, 0] + T[i, 1] * z[l - 1, 1] + T[i, 2] * z[l - 1, 2]
                    )
        for c in range(3):
            for i in range(3):
                F[k, c, i] = T[i, c]
    G = np.zeros((N, 3))  # sum_{k' >= k} F[k'], then the rows of body k's first joint
    for k in range(nb - 1, -1, -1):
        for c in range(N):
            for i in range(3):
                G[c, i] += F[k, c, i]
        if k > 0:
            r = 2 + k  # joint k - 1's row: z . G, columns c <= r
            for c in range(r + 1):
                M[r, c] = z[k - 1, 0] * G[c, 0] + z[k - 1, 1] * G[c, 1] + z[k - 1, 2] * G[c, 2]
    for r in range(3):
        for c in range(r + 1):
            M[r, c] = G[c, r]
    for r in range(N):
        for c in range(r + 1, N):
            M[r, c] = M[c, r]
