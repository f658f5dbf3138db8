"""Compiled (numba) kernels of the planar barycentric model.

The compiled counterparts of :class:`~ffsm_pin.model.planar.BarycentricModel`'s evaluators, on
the arrays of :meth:`~ffsm_pin.model.planar.BarycentricModel.kernel_constants` (S, the angle
offsets, the pair indices K < L, the end-effector row, the collinear flag): the body angles'
trigonometry, M_phi and M = S^T M_phi S (Eq. 12), the Jacobian [J_b J_m] (Eq. 3), the
regressors Y_M, Y_Mdot, Y_h and the position rows of Y_z (Eq. 4). They are dtype-generic where
the control period passes complex arguments (its complex step). The planar control steps
(:mod:`ffsm_pin.control.fast`) and the run's diagnostics use them; the tests compare them with
the numpy model through the compiled period (``tests/control/test_fast.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._array_kernels import mm, mv, put, put_rows


@njit(cache=True)
def xm(X, A):
    """X @ A for a real or complex matrix X and a real matrix A (dtype of X)."""
    out = np.zeros((X.shape[0], A.shape[1]), dtype=X.dtype)
    for i in range(X.shape[0]):
        for k in range(X.shape[1]):
            for j in range(A.shape[1]):
                out[i, j] += X[i, k] * A[k, j]
    return out


@njit(cache=True)
def trig(S, off, K, L, q_b, q_m):
    """(cos, sin) of the body angles phi = S (q_b, q_m) + offsets, and
    (cos, sin) of phi_l - phi_k for each pair k < l (K, L); real or complex."""
    nb = S.shape[0]
    q = np.empty(nb, dtype=q_m.dtype)
    q[0] = q_b
    put(q, 1, q_m)  # q[1:] = q_m (loops instead of slice assignments here and below: put)
    phi = mv(S, q) + off
    c = np.cos(phi)
    s = np.sin(phi)
    P = K.size
    pc = np.empty(P, dtype=phi.dtype)
    ps = np.empty(P, dtype=phi.dtype)
    for p in range(P):
        k, l = K[p], L[p]
        pc[p] = c[l] * c[k] + s[l] * s[k]  # cos(phi_l - phi_k)
        ps[p] = s[l] * c[k] - c[l] * s[k]  # sin(phi_l - phi_k)
    return c, s, pc, ps


@njit(cache=True)
def mass_phi(theta_d, pc, ps, K, L, nb, collinear):
    """M_phi of Eq. (12) (M = S^T M_phi S): Dc_kk on the diagonal, Dc_kl cos - Ds_kl sin
    (no Ds in the collinear layout) for each pair; the pair terms ``pc``, ``ps`` of :func:`trig`."""
    Mphi = np.zeros((nb, nb), dtype=pc.dtype)
    for k in range(nb):
        Mphi[k, k] = theta_d[k]
    P = K.size
    for p in range(P):
        v = theta_d[nb + p] * pc[p]
        if not collinear:
            v -= theta_d[nb + P + p] * ps[p]
        Mphi[K[p], L[p]] = v
        Mphi[L[p], K[p]] = v
    return Mphi


@njit(cache=True)
def mass_matrix(theta_d, pc, ps, K, L, S, collinear):
    """M = S^T M_phi S of Eq. (12), (nb, nb): :func:`mass_phi` and two products by loops
    (:func:`~ffsm_pin._array_kernels.mm`), the one planar M of the compiled periods."""
    return mm(mm(S.T, mass_phi(theta_d, pc, ps, K, L, S.shape[0], collinear)), S)


@njit(cache=True)
def jacobian(theta_z, c, s, S, ee_row, collinear):
    """(3, nb) [J_b J_m] of Eq. (3)."""
    nb = S.shape[0]
    dp = np.zeros((2, nb), dtype=c.dtype)
    for k in range(nb):
        if collinear:
            v = theta_z[2 + k]
            dp[0, k] = -s[k] * v
            dp[1, k] = c[k] * v
        else:
            vx, vy = theta_z[2 + 2 * k], theta_z[3 + 2 * k]
            dp[0, k] = -s[k] * vx - c[k] * vy
            dp[1, k] = c[k] * vx - s[k] * vy
    J = np.empty((3, nb), dtype=dp.dtype)
    put_rows(J, xm(dp, S))  # J[:2]
    for j in range(nb):
        J[2, j] = ee_row[j]
    return J


@njit(cache=True)
def column_sums(A):
    """``A.sum(axis=0)`` by a loop in numba's order (each row added in turn to zeros): the
    same values, without the code of numba's axis-bounds message (a second of a first run)."""
    out = np.zeros(A.shape[1], dtype=A.dtype)
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            out[j] += A[i, j]
    return out


@njit(cache=True)
def _scatter_pair(Y, b, fc, fs, K, L, nb, collinear):
    """Add each pair's terms ``fc``, ``fs`` times ``b`` into the Dc_kl, Ds_kl columns of ``Y``."""
    P = K.size
    for p in range(P):
        k, l = K[p], L[p]
        Y[k, nb + p] += fc[p] * b[l]
        Y[l, nb + p] += fc[p] * b[k]
        if not collinear:
            Y[k, nb + P + p] += fs[p] * b[l]
            Y[l, nb + P + p] += fs[p] * b[k]


@njit(cache=True)
def y_m(pc, ps, K, L, S, a, nd, collinear):
    """Y_M(a) with Y_M(a) theta_d = M a (Eq. 12), (nb, nd)."""
    nb = S.shape[0]
    b = mv(S, a)
    Y = np.zeros((nb, nd))
    for k in range(nb):
        Y[k, k] = b[k]
    _scatter_pair(Y, b, pc, -ps, K, L, nb, collinear)
    return mm(S.T, Y)


@njit(cache=True)
def velocity_regressors(pc, ps, K, L, S, w, sv, nd, collinear):
    """(Y_Mdot, Y_h) at w: Y_Mdot(w, s) theta_d = dM/dt s (``sv`` = s) and
    Y_h(w) theta_d = C w, each (nb, nd)."""
    nb = S.shape[0]
    P = K.size
    dphi = mv(S, w)
    b = mv(S, sv)
    Ymd = np.zeros((nb, nd))
    Yh = np.zeros((nb, nd))
    fc = np.empty(P)
    fs = np.empty(P)
    for p in range(P):
        dd = dphi[L[p]] - dphi[K[p]]
        fc[p] = -ps[p] * dd
        fs[p] = -pc[p] * dd
    _scatter_pair(Ymd, b, fc, fs, K, L, nb, collinear)
    for p in range(P):
        k, l = K[p], L[p]
        dk2, dl2 = dphi[k] ** 2, dphi[l] ** 2
        Yh[k, nb + p] = -ps[p] * dl2
        Yh[l, nb + p] = ps[p] * dk2
        if not collinear:
            Yh[k, nb + P + p] = -pc[p] * dl2
            Yh[l, nb + P + p] = pc[p] * dk2
    ST = S.T
    return mm(ST, Ymd), mm(ST, Yh)


@njit(cache=True)
def position_regressor(c, s, S, w, nz, collinear):
    """The position rows of Y_z (Eq. 4), (2, nz), at the body angles' cos ``c``, sin ``s``."""
    nb = S.shape[0]
    Yz = np.zeros((2, nz))
    Yz[0, 0] = 1.0
    Yz[1, 1] = 1.0
    dphi = mv(S, w)
    for k in range(nb):
        if collinear:
            Yz[0, 2 + k] = -s[k] * dphi[k]
            Yz[1, 2 + k] = c[k] * dphi[k]
        else:
            Yz[0, 2 + 2 * k] = -s[k] * dphi[k]
            Yz[1, 2 + 2 * k] = c[k] * dphi[k]
            Yz[0, 3 + 2 * k] = -c[k] * dphi[k]
            Yz[1, 3 + 2 * k] = -s[k] * dphi[k]
    return Yz


__all__ = [
    "column_sums",
    "jacobian",
    "mass_matrix",
    "mass_phi",
    "position_regressor",
    "trig",
    "velocity_regressors",
    "xm",
    "y_m",
]
