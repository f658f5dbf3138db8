"""Compiled (numba) kernels of the spatial mass matrix's rates in real (value, tangent)
arithmetic: M_bb with dM_bb/dt along the motion (F_r of Eq. 7 after a run) and M's base
columns at a complex step (H_bb, H_bm of the kinematic law), where each body's rotation turns
at its angular velocity o_k (dR_k/dt = [o_k]x R_k), so that a block X = R_k J R_l^T changes at
[o_k]x X - X [o_l]x: exact, as a complex step through the numpy reference's M is, without
complex products (tests/model).

Shapes as in :mod:`._spatial_mass_kernels`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._docstrings import fill_doc
from ._kernel_docs import KERNEL_DOC
from ._spatial_kinematics_kernels import body_rates, mm, mmt
from ._spatial_mass_kernels import INERTIA_INDEX, body_block, pair_block, pair_coupling


@njit(cache=True, inline="always")
def _spin(a, b, X, out):
    """out += [a]x X - X [b]x (3x3): the rate of a block R_k ... R_l^T whose two sides turn at
    a and b ([rad/s], dR/dt = [a]x R)."""
    for j in range(3):
        out[0, j] += a[1] * X[2, j] - a[2] * X[1, j]
        out[1, j] += a[2] * X[0, j] - a[0] * X[2, j]
        out[2, j] += a[0] * X[1, j] - a[1] * X[0, j]
    for i in range(3):
        out[i, 0] -= X[i, 1] * b[2] - X[i, 2] * b[1]
        out[i, 1] -= X[i, 2] * b[0] - X[i, 0] * b[2]
        out[i, 2] -= X[i, 0] * b[1] - X[i, 1] * b[0]


@njit(cache=True)
@fill_doc(KERNEL_DOC)
def base_inertia_rate(R, z, w, theta, M, M_dot):
    """M_bb(q, theta_d) and its rate dM_bb/dt along the motion w, in real arithmetic: each
    body's rotation turns at its angular velocity o_k = S_k w (dR_k/dt = [o_k]x R_k), so a
    block X = R_k J R_l^T changes at [o_k]x X - X [o_l]x. Both equal the numpy reference's
    M_bb and its exact complex step along the motion to rounding (tests/model,
    tests/control/test_diagnostics.py).

    %(params_R_z)s
    w : ndarray (N,)
        (w_b inertial, dq_m/dt) [rad/s].
    theta : ndarray (n_d,)
        Dynamic parameters theta_d of Eq. (12) [kg m^2].
    M, M_dot : ndarray (3, 3)
        M_bb [kg m^2] and dM_bb/dt [kg m^2/s], overwritten.
    """
    nb = R.shape[0]
    o = np.empty((nb, 3))
    body_rates(z, w, o)
    M[:] = 0.0
    M_dot[:] = 0.0
    J = np.empty((3, 3))
    T1 = np.empty((3, 3))
    X = np.empty((3, 3))
    dX = np.empty((3, 3))
    for k in range(nb):  # R_k J_k R_k^T
        body_block(R, theta, k, J, T1, X)
        dX[:] = 0.0
        _spin(o[k], o[k], X, dX)
        for i in range(3):
            for j in range(3):
                M[i, j] += X[i, j]
                M_dot[i, j] += dX[i, j]
    p = 6 * nb
    Km = np.empty((3, 3))
    dK = np.empty((3, 3))
    for k in range(nb):  # + K + K^T, K = tr(X) E - X^T, X = R_k D R_l^T
        for l in range(k + 1, nb):
            pair_block(R, theta, p, k, l, J, T1, X)
            p += 9
            dX[:] = 0.0
            _spin(o[k], o[l], X, dX)
            pair_coupling(X, Km)
            pair_coupling(dX, dK)  # (linear: the rate of Km)
            for i in range(3):
                for j in range(3):
                    M[i, j] += Km[i, j]
                    M_dot[i, j] += dK[i, j]
            for i in range(3):
                for j in range(3):
                    M[i, j] += Km[j, i]
                    M_dot[i, j] += dK[j, i]


@njit(cache=True)
@fill_doc(KERNEL_DOC)
def base_columns(R, z, theta, M):
    """M's base columns (N, 3) at complex-step arguments x + i dx (dx a small multiple of a
    tangent, as the kinematic law of :mod:`ffsm_pin.control.fast_spatial` passes them): the
    numpy reference's M at those complex arguments, its first three columns, in real (value,
    tangent) arithmetic instead of complex products, to rounding (tests/model). R, z and
    theta complex, their imaginary parts the step.

    Each body's rotation turns at o_k, [o_k]x = Im(R_k) Re(R_k)^T (dR_k = [o_k]x R_k), so a
    block X = R_k D R_l^T has the tangent [o_k]x X - X [o_l]x + R_k dD R_l^T; the blocks are
    summed per body (C_k) before the joint rows z_j . sum_{k > j} C_k are formed.

    %(params_R_z)s
    theta : ndarray (n_d,)
        Dynamic parameters theta_d of Eq. (12) [kg m^2], complex.
    M : ndarray (N, 3)
        The base columns, overwritten (complex).
    """
    nb = R.shape[0]
    Rr = np.ascontiguousarray(R.real)
    o = np.empty((nb, 3))  # [o_k]x = Im(R_k) Re(R_k)^T, skew to rounding: its mean
    W = np.empty((3, 3))
    Ri = np.empty((3, 3))
    for k in range(nb):
        for i in range(3):
            for j in range(3):
                Ri[i, j] = R[k, i, j].imag
        mmt(Ri, Rr[k], W)
        o[k, 0] = 0.5 * (W[2, 1] - W[1, 2])
        o[k, 1] = 0.5 * (W[0, 2] - W[2, 0])
        o[k, 2] = 0.5 * (W[1, 0] - W[0, 1])
    C = np.zeros((nb, 3, 3))
    dC = np.zeros((nb, 3, 3))
    J = np.empty((3, 3))
    dJ = np.empty((3, 3))
    T1 = np.empty((3, 3))
    X = np.empty((3, 3))
    dX = np.empty((3, 3))
    for k in range(nb):  # R_k J_k R_k^T
        for i in range(3):
            for j in range(3):
                c = theta[6 * k + INERTIA_INDEX[i, j]]
                J[i, j], dJ[i, j] = c.real, c.imag
        mm(Rr[k], J, T1)
        mmt(T1, Rr[k], X)
        mm(Rr[k], dJ, T1)
        mmt(T1, Rr[k], dX)
        _spin(o[k], o[k], X, dX)
        for i in range(3):
            for j in range(3):
                C[k, i, j] += X[i, j]
                dC[k, i, j] += dX[i, j]
    p = 6 * nb
    for k in range(nb):  # K = tr(X) E - X^T to body k, K^T to body l
        for l in range(k + 1, nb):
            for i in range(3):
                for j in range(3):
                    c = theta[p + 3 * i + j]
                    J[i, j], dJ[i, j] = c.real, c.imag
            p += 9
            mm(Rr[k], J, T1)
            mmt(T1, Rr[l], X)
            mm(Rr[k], dJ, T1)
            mmt(T1, Rr[l], dX)
            _spin(o[k], o[l], X, dX)
            tr = X[0, 0] + X[1, 1] + X[2, 2]
            dtr = dX[0, 0] + dX[1, 1] + dX[2, 2]
            for i in range(3):
                for j in range(3):
                    C[k, i, j] -= X[j, i]
                    dC[k, i, j] -= dX[j, i]
                    C[l, i, j] -= X[i, j]
                    dC[l, i, j] -= dX[i, j]
                C[k, i, i] += tr
                dC[k, i, i] += dtr
                C[l, i, i] += tr
                dC[l, i, i] += dtr
    S = np.zeros((3, 3))  # sum_{k' >= k} C_k', and its tangent
    dS = np.zeros((3, 3))
    for k in range(nb - 1, -1, -1):
        for i in range(3):
            for j in range(3):
                S[i, j] += C[k, i, j]
                dS[i, j] += dC[k, i, j]
        if k == 0:
            break
        a0, a1, a2 = z[k - 1, 0].real, z[k - 1, 1].real, z[k - 1, 2].real
        d0, d1, d2 = z[k - 1, 0].imag, z[k - 1, 1].imag, z[k - 1, 2].imag
        for c in range(3):  # joint k - 1's row: z . S e_c
            v = a0 * S[0, c] + a1 * S[1, c] + a2 * S[2, c]
            t = d0 * S[0, c] + d1 * S[1, c] + d2 * S[2, c]
            t += a0 * dS[0, c] + a1 * dS[1, c] + a2 * dS[2, c]
            M[2 + k, c] = v + 1j * t
    for i in range(3):
        for c in range(3):
            M[i, c] = S[i, c] + 1j * dS[i, c]
