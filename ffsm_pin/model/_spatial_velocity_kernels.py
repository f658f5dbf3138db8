"""Compiled (numba) kernels of the spatial model's velocity regressors: Y_Mdot(w, s) with
Y_Mdot theta_d = dM/dt s, and Y_h(w) with Y_h theta_d = C(q, w) w (Eq. 8), i.e. its dM/dt w
part less the dT/dq_m rows (docs/spatial.md section 4).

The same expressions as the numpy reference of :mod:`ffsm_pin.model.spatial` (checked against
it in tests/model). dM/dt s and the dM/dt w part of C w are taken by forward-mode (value,
tangent) pairs with the closed-form tangents of R_k and z_j (exact for these bilinear
expressions), fused with Y_M a and the base rows of Y_M w in :func:`velocity_terms`; dT/dq_m
uses the structure of a joint's tangent (see :func:`subtract_dT`).

Shapes: R (n+1, 3, 3) body rotations, z (n, 3) inertial joint axes, N = n + 3 velocity
components, n_d = 6 (n+1) + 9 n (n+1) / 2 dynamic parameters.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._docstrings import fill_doc
from ._kernel_docs import KERNEL_DOC
from ._spatial_kinematics_kernels import body_rates


@njit(cache=True)
@fill_doc(KERNEL_DOC)
def subtract_dT(R, z, w, Y_h):
    """Y_h[3 + j] -= dT/dq_j regressor (T at fixed base attitude and w) for every joint j.

    Turning joint j rotates the bodies k >= j + 1 about z_j: dR_k = [z_j]x R_k and
    dw_k = [z_j]x w_k + c with c = -z_j x w_j (w_j of the parent body j). Terms between two
    turning bodies are invariant under the common rotation, so only c changes them (dQ = 0,
    d(R_k^T w_l) = R_k^T c); terms between a fixed body k and a turning body l change with
    dQ = R_k^T [z_j]x R_l, dw_l, and d(R_l^T w_k) = ([z_j]x R_l)^T w_k. Q, u, g and the dot
    products do not depend on j and are computed once.

    %(params_R_real_z)s
    w : ndarray (N,)
        Velocity ``(w_b, dq_m)`` [rad/s], w_b in the inertial frame.
    Y_h : ndarray (N, n_d)
        The dM/dt w part of Y_h(w) (from :func:`velocity_terms`); its joint rows 3.. are
        reduced in place, to Y_h(w) with Y_h theta_d = C(q, w) w.
    """
    nb, n = R.shape[0], z.shape[0]
    P = nb * (nb - 1) // 2
    om = np.zeros((nb, 3))
    body_rates(z, w, om)
    beta = np.empty((nb, 3))
    for k in range(nb):
        for i in range(3):
            beta[k, i] = R[k, 0, i] * om[k, 0] + R[k, 1, i] * om[k, 1] + R[k, 2, i] * om[k, 2]
    Q = np.empty((P, 3, 3))
    U = np.empty((P, 3))
    G = np.empty((P, 3))
    DOT = np.empty(P)
    p = 0
    for k in range(nb):
        for l in range(k + 1, nb):
            DOT[p] = om[k, 0] * om[l, 0] + om[k, 1] * om[l, 1] + om[k, 2] * om[l, 2]
            for i in range(3):
                U[p, i] = R[k, 0, i] * om[l, 0] + R[k, 1, i] * om[l, 1] + R[k, 2, i] * om[l, 2]
                G[p, i] = R[l, 0, i] * om[k, 0] + R[l, 1, i] * om[k, 1] + R[l, 2, i] * om[k, 2]
                for j in range(3):
                    Q[p, i, j] = (
                        R[k, 0, i] * R[l, 0, j] + R[k, 1, i] * R[l, 1, j] + R[k, 2, i] * R[l, 2, j]
                    )
            p += 1
    Rc = np.empty((nb, 3))  # R_k^T c
    ZR = np.empty((nb, 3, 3))  # [z_j]x R_l
    dl = np.empty((nb, 3))  # dw_l = z_j x w_l + c
    du = np.empty(3)
    dg = np.empty(3)
    dQ = np.empty((3, 3))
    for jj in range(n):
        f = jj + 1
        a0, a1, a2 = z[jj, 0], z[jj, 1], z[jj, 2]
        c0 = -(a1 * om[jj, 2] - a2 * om[jj, 1])
        c1 = -(a2 * om[jj, 0] - a0 * om[jj, 2])
        c2 = -(a0 * om[jj, 1] - a1 * om[jj, 0])
        row = 3 + jj
        for k in range(f, nb):
            for i in range(3):
                Rc[k, i] = R[k, 0, i] * c0 + R[k, 1, i] * c1 + R[k, 2, i] * c2
            for j in range(3):
                r0, r1, r2 = R[k, 0, j], R[k, 1, j], R[k, 2, j]
                ZR[k, 0, j] = a1 * r2 - a2 * r1
                ZR[k, 1, j] = a2 * r0 - a0 * r2
                ZR[k, 2, j] = a0 * r1 - a1 * r0
            o0, o1, o2 = om[k, 0], om[k, 1], om[k, 2]
            dl[k, 0] = a1 * o2 - a2 * o1 + c0
            dl[k, 1] = a2 * o0 - a0 * o2 + c1
            dl[k, 2] = a0 * o1 - a1 * o0 + c2
            b = beta[k]
            d = Rc[k]
            col = 6 * k
            Y_h[row, col] -= b[0] * d[0]
            Y_h[row, col + 1] -= d[0] * b[1] + b[0] * d[1]
            Y_h[row, col + 2] -= d[0] * b[2] + b[0] * d[2]
            Y_h[row, col + 3] -= b[1] * d[1]
            Y_h[row, col + 4] -= d[1] * b[2] + b[1] * d[2]
            Y_h[row, col + 5] -= b[2] * d[2]
        p = 0
        col = 6 * nb
        for k in range(nb):
            for l in range(k + 1, nb):
                if l < f:
                    pass
                elif k >= f:  # both turn: only c matters
                    ddot = (
                        c0 * (om[k, 0] + om[l, 0]) + c1 * (om[k, 1] + om[l, 1])
                        + c2 * (om[k, 2] + om[l, 2])
                    )  # fmt: skip
                    for i in range(3):
                        for j in range(3):
                            Y_h[row, col + 3 * i + j] -= (
                                Q[p, i, j] * ddot - Rc[k, i] * G[p, j] - U[p, i] * Rc[l, j]
                            )
                else:  # body k fixed, body l turns
                    ddot = om[k, 0] * dl[l, 0] + om[k, 1] * dl[l, 1] + om[k, 2] * dl[l, 2]
                    for i in range(3):
                        du[i] = (
                            R[k, 0, i] * dl[l, 0] + R[k, 1, i] * dl[l, 1] + R[k, 2, i] * dl[l, 2]
                        )
                        dg[i] = (
                            ZR[l, 0, i] * om[k, 0] + ZR[l, 1, i] * om[k, 1] + ZR[l, 2, i] * om[k, 2]
                        )
                        for j in range(3):
                            dQ[i, j] = (
                                R[k, 0, i] * ZR[l, 0, j] + R[k, 1, i] * ZR[l, 1, j]
                                + R[k, 2, i] * ZR[l, 2, j]
                            )  # fmt: skip
                    for i in range(3):
                        for j in range(3):
                            Y_h[row, col + 3 * i + j] -= (
                                dQ[i, j] * DOT[p] + Q[p, i, j] * ddot
                                - du[i] * G[p, j] - U[p, i] * dg[j]
                            )  # fmt: skip
                p += 1
                col += 9


# ---------------------------------------------------------------------- fused dual-number path
# The regressors Y_M a, Y_Mdot s and Y_h w share the rotations R_k, their products
# Q_kl = R_k^T R_l and the projections onto the joint axes. ``velocity_terms`` computes them
# once with forward-mode (value, tangent) pairs in real arithmetic: the tangent along the
# motion w is dR_k = [w_k]x R_k, dz_j = w_j x z_j (exact, like the complex step of ym_rate,
# without the complex products). Every column of S_k^T x with x = alpha R_l e_c or alpha b_l
# is a combination of the extended vectors
#   PR[k, c] = S^T R_k e_c = (R_k e_c, z_1 . R_k e_c, ..., z_n . R_k e_c)   (N,)
#   Pb[v, k] = S^T b_k(v)  (b_k(v) = S_k v for the vector v)                (N,)
# truncated to the first 3 + k rows (the rows of S_k^T).


@njit(cache=True)
def _extended(R, z, dR, dz, PR, dPR):
    """PR[k, c] = S^T R_k e_c and its tangent dPR (see the comment above)."""
    nb, n = R.shape[0], z.shape[0]
    for k in range(nb):
        for c in range(3):
            r0, r1, r2 = R[k, 0, c], R[k, 1, c], R[k, 2, c]
            d0, d1, d2 = dR[k, 0, c], dR[k, 1, c], dR[k, 2, c]
            PR[k, c, 0], PR[k, c, 1], PR[k, c, 2] = r0, r1, r2
            dPR[k, c, 0], dPR[k, c, 1], dPR[k, c, 2] = d0, d1, d2
            for j in range(n):
                PR[k, c, 3 + j] = z[j, 0] * r0 + z[j, 1] * r1 + z[j, 2] * r2
                dPR[k, c, 3 + j] = (
                    dz[j, 0] * r0 + dz[j, 1] * r1 + dz[j, 2] * r2
                    + z[j, 0] * d0 + z[j, 1] * d1 + z[j, 2] * d2
                )  # fmt: skip


@njit(cache=True)
def _vector_terms(R, z, dR, dz, v, b, db, Pb, dPb, beta, dbeta):
    """For one vector v: b_k = S_k v, db_k (dS_k v), Pb = S^T b_k, dPb, beta_k = R_k^T b_k,
    dbeta_k."""
    nb, n = R.shape[0], z.shape[0]
    b[0, 0], b[0, 1], b[0, 2] = v[0], v[1], v[2]
    db[0, 0] = db[0, 1] = db[0, 2] = 0.0
    for k in range(1, nb):
        vk = v[2 + k]
        for i in range(3):
            b[k, i] = b[k - 1, i] + z[k - 1, i] * vk
            db[k, i] = db[k - 1, i] + dz[k - 1, i] * vk
    for k in range(nb):
        b0, b1, b2 = b[k, 0], b[k, 1], b[k, 2]
        e0, e1, e2 = db[k, 0], db[k, 1], db[k, 2]
        Pb[k, 0], Pb[k, 1], Pb[k, 2] = b0, b1, b2
        dPb[k, 0], dPb[k, 1], dPb[k, 2] = e0, e1, e2
        for j in range(n):
            Pb[k, 3 + j] = z[j, 0] * b0 + z[j, 1] * b1 + z[j, 2] * b2
            dPb[k, 3 + j] = (
                dz[j, 0] * b0 + dz[j, 1] * b1 + dz[j, 2] * b2
                + z[j, 0] * e0 + z[j, 1] * e1 + z[j, 2] * e2
            )  # fmt: skip
        for i in range(3):
            beta[k, i] = R[k, 0, i] * b0 + R[k, 1, i] * b1 + R[k, 2, i] * b2
            dbeta[k, i] = (
                dR[k, 0, i] * b0 + dR[k, 1, i] * b1 + dR[k, 2, i] * b2
                + R[k, 0, i] * e0 + R[k, 1, i] * e1 + R[k, 2, i] * e2
            )  # fmt: skip


@njit(cache=True, inline="always")
def _tdot(A, i, x):
    """(A^T x)_i = column i of a 3x3 A dotted with the 3-vector x."""
    return A[0, i] * x[0] + A[1, i] * x[1] + A[2, i] * x[2]


# (c, first Phi index, second Phi index): column c of Phi(beta) mapped by R_k is
# beta[i1] R_k e_{i0} (+ beta[i0] R_k e_{i1} if i0 != i1), order (xx, xy, xz, yy, yz, zz)
_PHI_I0 = (0, 0, 0, 1, 1, 2)
_PHI_I1 = (0, 1, 2, 1, 2, 2)


@njit(cache=True)
@fill_doc(KERNEL_DOC)
def velocity_terms(R, z, w, a, s, YM, YMdot, Yh, Yb):
    """Y_M(a), Y_Mdot(w, s), the dM/dt w part of Y_h(w) (before :func:`subtract_dT`) and the
    base rows Yb of Y_M(w), in one pass with shared rotations (see the comment above).

    ``YM``, ``YMdot`` or ``Yh`` None: that regressor is not computed (numba compiles none of
    its code; ``a`` resp. ``s`` is then not read). The others are the same values either way:
    each entry is its own expression. (Y_Mdot(w, s) with ``s = w`` is the dM/dt w part of
    Y_h(w), so Y_Mdot(w, s) - Y_h(w) = -(Y_Mdot(w, w - s) less the dT/dq rows): one
    regressor, ``YMdot`` for the vector w - s and :func:`subtract_dT` on it, as the paper's
    spatial period forms it with s = w~, w - s = w-hat; docs/spatial.md section 4.)

    %(params_R_real_z)s
    w : ndarray (N,)
        Velocity ``(w_b, dq_m)`` [rad/s], w_b in the inertial frame: the motion along which
        M changes.
    a : ndarray (N,)
        The vector of Y_M(a) [rad/s^2].
    s : ndarray (N,)
        The vector of Y_Mdot(w, s) [rad/s].
    YM : ndarray (N, n_d) or None
        Y_M(a), with Y_M theta_d = M a; overwritten.
    YMdot : ndarray (N, n_d) or None
        Y_Mdot(w, s), with Y_Mdot theta_d = dM/dt s; overwritten.
    Yh : ndarray (N, n_d) or None
        The dM/dt w part of Y_h(w), overwritten (:func:`subtract_dT` completes it).
    Yb : ndarray (3, n_d)
        The base rows of Y_M(w) (Eq. 14 without its A_0 columns), overwritten.
    """
    nb, n = R.shape[0], z.shape[0]
    N = n + 3
    om = np.empty((nb, 3))
    body_rates(z, w, om)
    dR = np.empty((nb, 3, 3))
    for k in range(nb):
        o0, o1, o2 = om[k, 0], om[k, 1], om[k, 2]
        for j in range(3):
            r0, r1, r2 = R[k, 0, j], R[k, 1, j], R[k, 2, j]
            dR[k, 0, j] = o1 * r2 - o2 * r1
            dR[k, 1, j] = o2 * r0 - o0 * r2
            dR[k, 2, j] = o0 * r1 - o1 * r0
    dz = np.empty((n, 3))
    for j in range(n):  # body j + 1 carries joint j's axis
        o0, o1, o2 = om[j + 1, 0], om[j + 1, 1], om[j + 1, 2]
        r0, r1, r2 = z[j, 0], z[j, 1], z[j, 2]
        dz[j, 0] = o1 * r2 - o2 * r1
        dz[j, 1] = o2 * r0 - o0 * r2
        dz[j, 2] = o0 * r1 - o1 * r0
    # scratch in few allocations (each costs more than the loops over small arrays)
    P2 = np.empty((2, nb, 3, N))
    PR, dPR = P2[0], P2[1]
    _extended(R, z, dR, dz, PR, dPR)
    # vectors: 0 = a, 1 = s, 2 = w
    B4 = np.empty((4, 3, nb, 3))
    b, db, beta, dbeta = B4[0], B4[1], B4[2], B4[3]
    Pb2 = np.empty((2, 3, nb, N))
    Pb, dPb = Pb2[0], Pb2[1]
    if YM is not None:
        _vector_terms(R, z, dR, dz, a, b[0], db[0], Pb[0], dPb[0], beta[0], dbeta[0])
    if YMdot is not None:
        _vector_terms(R, z, dR, dz, s, b[1], db[1], Pb[1], dPb[1], beta[1], dbeta[1])
    _vector_terms(R, z, dR, dz, w, b[2], db[2], Pb[2], dPb[2], beta[2], dbeta[2])
    # ---- body columns: Jbar_k, Eq. (9a) first sum
    for k in range(nb):
        for c in range(6):
            i0, i1 = _PHI_I0[c], _PHI_I1[c]
            col = 6 * k + c
            ba, bs, bw = beta[0, k, i1], beta[1, k, i1], beta[2, k, i1]
            ds, dw = dbeta[1, k, i1], dbeta[2, k, i1]
            if i0 == i1:
                for r in range(3 + k):
                    p, dp = PR[k, i0, r], dPR[k, i0, r]
                    if YM is not None:
                        YM[r, col] = ba * p
                    if YMdot is not None:
                        YMdot[r, col] = ds * p + bs * dp
                    if Yh is not None:
                        Yh[r, col] = dw * p + bw * dp
                for r in range(3):
                    Yb[r, col] = bw * PR[k, i0, r]
            else:
                ba2, bs2, bw2 = beta[0, k, i0], beta[1, k, i0], beta[2, k, i0]
                ds2, dw2 = dbeta[1, k, i0], dbeta[2, k, i0]
                for r in range(3 + k):
                    p, dp = PR[k, i0, r], dPR[k, i0, r]
                    p2, dp2 = PR[k, i1, r], dPR[k, i1, r]
                    if YM is not None:
                        YM[r, col] = ba * p + ba2 * p2
                    if YMdot is not None:
                        YMdot[r, col] = ds * p + bs * dp + ds2 * p2 + bs2 * dp2
                    if Yh is not None:
                        Yh[r, col] = dw * p + bw * dp + dw2 * p2 + bw2 * dp2
                for r in range(3):
                    Yb[r, col] = bw * PR[k, i0, r] + bw2 * PR[k, i1, r]
            for r in range(3 + k, N):
                if YM is not None:
                    YM[r, col] = 0.0
                if YMdot is not None:
                    YMdot[r, col] = 0.0
                if Yh is not None:
                    Yh[r, col] = 0.0
    # ---- pair columns: D_kl, Eq. (9a) second sum, 9 columns (i, j) at a time
    # per body: PP[k, r, 3 i + j] = PR[k, i, r] (repeated over j), PT[k, r, 3 i + j] = PR[k, j, r]
    P4 = np.empty((4, nb, N, 9))
    PP, PT, dPP, dPT = P4[0], P4[1], P4[2], P4[3]
    for k in range(nb):
        for r in range(N):
            for i in range(3):
                for j in range(3):
                    PP[k, r, 3 * i + j] = PR[k, i, r]
                    dPP[k, r, 3 * i + j] = dPR[k, i, r]
                    PT[k, r, 3 * i + j] = PR[k, j, r]
                    dPT[k, r, 3 * i + j] = dPR[k, j, r]
    W4 = np.empty((4, 3, 9))
    U9, dU9, G9, dG9 = W4[0], W4[1], W4[2], W4[3]
    Q2 = np.empty((2, 9))
    q9, dq9 = Q2[0], Q2[1]
    col = 6 * nb
    for k in range(nb):
        for l in range(k + 1, nb):
            Rk, Rl, dRk, dRl = R[k], R[l], dR[k], dR[l]
            for v in range(3):
                # (only the vectors computed above: the scratch of the others is uninitialised
                # memory, whose leftover subnormal numbers made each product take a microcode
                # assist; benchmarks/README.md, "Uninitialised scratch")
                if (v == 0 and YM is None) or (v == 1 and YMdot is None):
                    continue
                bk, bl, dbk, dbl = b[v, k], b[v, l], db[v, k], db[v, l]
                for i in range(3):
                    ui = _tdot(Rk, i, bl)  # R_k^T b_l
                    dui = _tdot(dRk, i, bl) + _tdot(Rk, i, dbl)
                    gi = _tdot(Rl, i, bk)  # R_l^T b_k
                    dgi = _tdot(dRl, i, bk) + _tdot(Rl, i, dbk)
                    for j in range(3):
                        U9[v, 3 * i + j] = ui
                        dU9[v, 3 * i + j] = dui
                        G9[v, 3 * j + i] = gi
                        dG9[v, 3 * j + i] = dgi
            for i in range(3):
                for j in range(3):
                    q9[3 * i + j] = _tdot(Rk, i, Rl[:, j])  # Q_kl = R_k^T R_l
                    dq9[3 * i + j] = _tdot(dRk, i, Rl[:, j]) + _tdot(Rk, i, dRl[:, j])
            # rows of S_k^T x_k + S_l^T x_l, x_k = q b_l - u_i R_l e_j, x_l = q b_k - g_j R_k e_i
            for r in range(3 + k):
                p0 = Pb[0, l, r] + Pb[0, k, r]
                p1 = Pb[1, l, r] + Pb[1, k, r]
                p2 = Pb[2, l, r] + Pb[2, k, r]
                d1 = dPb[1, l, r] + dPb[1, k, r]
                d2 = dPb[2, l, r] + dPb[2, k, r]
                ptl, dptl, ppk, dppk = PT[l, r], dPT[l, r], PP[k, r], dPP[k, r]
                for c in range(9):
                    q, dq = q9[c], dq9[c]
                    pl, dpl, pk, dpk = ptl[c], dptl[c], ppk[c], dppk[c]
                    if YM is not None:
                        YM[r, col + c] = q * p0 - U9[0, c] * pl - G9[0, c] * pk
                    if YMdot is not None:
                        YMdot[r, col + c] = (
                            dq * p1 + q * d1
                            - dU9[1, c] * pl - U9[1, c] * dpl - dG9[1, c] * pk - G9[1, c] * dpk
                        )  # fmt: skip
                    if Yh is not None:
                        Yh[r, col + c] = (
                            dq * p2 + q * d2
                            - dU9[2, c] * pl - U9[2, c] * dpl - dG9[2, c] * pk - G9[2, c] * dpk
                        )  # fmt: skip
            for r in range(3):
                p2 = Pb[2, l, r] + Pb[2, k, r]
                for c in range(9):
                    Yb[r, col + c] = q9[c] * p2 - U9[2, c] * PT[l, r, c] - G9[2, c] * PP[k, r, c]
            for r in range(3 + k, 3 + l):
                p0, p1, p2 = Pb[0, k, r], Pb[1, k, r], Pb[2, k, r]
                d1, d2 = dPb[1, k, r], dPb[2, k, r]
                ppk, dppk = PP[k, r], dPP[k, r]
                for c in range(9):
                    q, dq = q9[c], dq9[c]
                    pk, dpk = ppk[c], dppk[c]
                    if YM is not None:
                        YM[r, col + c] = q * p0 - G9[0, c] * pk
                    if YMdot is not None:
                        YMdot[r, col + c] = dq * p1 + q * d1 - dG9[1, c] * pk - G9[1, c] * dpk
                    if Yh is not None:
                        Yh[r, col + c] = dq * p2 + q * d2 - dG9[2, c] * pk - G9[2, c] * dpk
            for r in range(3 + l, N):
                for c in range(9):
                    if YM is not None:
                        YM[r, col + c] = 0.0
                    if YMdot is not None:
                        YMdot[r, col + c] = 0.0
                    if Yh is not None:
                        Yh[r, col + c] = 0.0
            col += 9
