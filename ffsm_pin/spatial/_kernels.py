"""Compiled (numba) kernels of the spatial barycentric model.

The same expressions as the numpy reference in :mod:`ffsm_pin.spatial.barycentric` (checked
against it in tests/spatial), written as loops over bodies and pairs that exploit the structure
of ``S_k = [E_3, z_1, ..., z_k, 0, ...]``: ``S_k^T x = (x, z_1 . x, ..., z_k . x, 0, ...)``.
The kernels are generic over real and complex arrays; dM/dt s uses a complex step with the
closed-form tangents of R_k and z_j (exact for these bilinear expressions), dT/dq_m the
structure of a joint's tangent (see :func:`subtract_dT`).

Shapes: R (n+1, 3, 3) body rotations, z (n, 3) inertial joint axes, N = n + 3 velocity
components, n_d = 6 (n+1) + 9 n (n+1) / 2 dynamic parameters.
"""

from __future__ import annotations

import numpy as np
from numba import njit

H_STEP = 1e-20  # complex step


@njit(cache=True, inline="always")
def _mm(A, B, out):
    """out = A @ B for 3x3 (no BLAS call)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(cache=True, inline="always")
def _mmt(A, B, out):
    """out = A @ B^T for 3x3."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[j, 0] + A[i, 1] * B[j, 1] + A[i, 2] * B[j, 2]


@njit(cache=True)
def kinematics(s, q_m, joint_rot, axes, R, z):
    """Body rotations R_k and inertial joint axes z_j from the base MRP s and joint angles."""
    ss = s[0] * s[0] + s[1] * s[1] + s[2] * s[2]
    S = np.zeros((3, 3))
    S[0, 1], S[0, 2], S[1, 0], S[1, 2], S[2, 0], S[2, 1] = -s[2], s[1], s[2], -s[0], -s[1], s[0]
    S2 = np.empty((3, 3))
    _mm(S, S, S2)
    d = (1.0 + ss) ** 2
    for i in range(3):
        for j in range(3):
            R[0, i, j] = (1.0 if i == j else 0.0) + (
                8.0 * S2[i, j] + 4.0 * (1.0 - ss) * S[i, j]
            ) / d
    U = np.zeros((3, 3))
    U2 = np.empty((3, 3))
    rot = np.empty((3, 3))
    tmp = np.empty((3, 3))
    for k in range(1, R.shape[0]):
        u = axes[k - 1]
        U[0, 1], U[0, 2], U[1, 0], U[1, 2], U[2, 0], U[2, 1] = -u[2], u[1], u[2], -u[0], -u[1], u[0]
        c, sn = np.cos(q_m[k - 1]), np.sin(q_m[k - 1])
        _mm(U, U, U2)
        for i in range(3):
            for j in range(3):
                rot[i, j] = (1.0 if i == j else 0.0) + sn * U[i, j] + (1.0 - c) * U2[i, j]
        _mm(R[k - 1], joint_rot[k - 1], tmp)
        _mm(tmp, rot, R[k])
        for i in range(3):
            z[k - 1, i] = R[k, i, 0] * u[0] + R[k, i, 1] * u[1] + R[k, i, 2] * u[2]


@njit(cache=True)
def body_rates(z, a, out):
    """out[k] = S_k a (body angular velocities for the rates a)."""
    out[0, 0], out[0, 1], out[0, 2] = a[0], a[1], a[2]
    for k in range(1, out.shape[0]):
        for i in range(3):
            out[k, i] = out[k - 1, i] + z[k - 1, i] * a[2 + k]


@njit(cache=True, inline="always")
def _add_st(Y, col, k, z, x0, x1, x2, base_only):
    """Y[:, col] += S_k^T x."""
    Y[0, col] += x0
    Y[1, col] += x1
    Y[2, col] += x2
    if not base_only:
        for j in range(k):
            Y[3 + j, col] += z[j, 0] * x0 + z[j, 1] * x1 + z[j, 2] * x2


@njit(cache=True)
def ym(R, z, a, Y, base_only):
    """Y with Y theta_d = M a (rows 1-3 only if base_only)."""
    nb = R.shape[0]
    Y[:] = 0.0
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
        _add_st(
            Y, c0 + 1, k, z,
            Rk[0, 0] * be1 + Rk[0, 1] * be0,
            Rk[1, 0] * be1 + Rk[1, 1] * be0,
            Rk[2, 0] * be1 + Rk[2, 1] * be0,
            base_only,
        )  # fmt: skip
        _add_st(
            Y, c0 + 2, k, z,
            Rk[0, 0] * be2 + Rk[0, 2] * be0,
            Rk[1, 0] * be2 + Rk[1, 2] * be0,
            Rk[2, 0] * be2 + Rk[2, 2] * be0,
            base_only,
        )  # fmt: skip
        _add_st(Y, c0 + 3, k, z, Rk[0, 1] * be1, Rk[1, 1] * be1, Rk[2, 1] * be1, base_only)
        _add_st(
            Y, c0 + 4, k, z,
            Rk[0, 1] * be2 + Rk[0, 2] * be1,
            Rk[1, 1] * be2 + Rk[1, 2] * be1,
            Rk[2, 1] * be2 + Rk[2, 2] * be1,
            base_only,
        )  # fmt: skip
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
                    _add_st(
                        Y, col, k, z,
                        q * b[l, 0] - u[i] * Rl[0, j],
                        q * b[l, 1] - u[i] * Rl[1, j],
                        q * b[l, 2] - u[i] * Rl[2, j],
                        base_only,
                    )  # fmt: skip
                    _add_st(
                        Y, col, l, z,
                        q * b[k, 0] - g[j] * Rk[0, i],
                        q * b[k, 1] - g[j] * Rk[1, i],
                        q * b[k, 2] - g[j] * Rk[2, i],
                        base_only,
                    )  # fmt: skip
                    col += 1


@njit(cache=True)
def motion_step(R, z, w, Rc, zc):
    """Rc = R + i h dR/dt, zc = z + i h dz/dt along w: dR_k = [w_k]x R_k, dz_j = w_j x z_j."""
    nb, n = R.shape[0], z.shape[0]
    h = H_STEP
    om = np.zeros((nb, 3))
    body_rates(z, w, om)
    for k in range(nb):
        o0, o1, o2 = om[k, 0], om[k, 1], om[k, 2]
        for j in range(3):
            r0, r1, r2 = R[k, 0, j], R[k, 1, j], R[k, 2, j]
            Rc[k, 0, j] = r0 + 1j * h * (o1 * r2 - o2 * r1)
            Rc[k, 1, j] = r1 + 1j * h * (o2 * r0 - o0 * r2)
            Rc[k, 2, j] = r2 + 1j * h * (o0 * r1 - o1 * r0)
    for j in range(n):  # body j + 1 carries joint j's axis
        o0, o1, o2 = om[j + 1, 0], om[j + 1, 1], om[j + 1, 2]
        r0, r1, r2 = z[j, 0], z[j, 1], z[j, 2]
        zc[j, 0] = r0 + 1j * h * (o1 * r2 - o2 * r1)
        zc[j, 1] = r1 + 1j * h * (o2 * r0 - o0 * r2)
        zc[j, 2] = r2 + 1j * h * (o0 * r1 - o1 * r0)


@njit(cache=True)
def ym_rate(Rc, zc, a, Yc, out):
    """out = Im(ym(Rc, zc, a)) / h: dM/dt a regressor, from motion_step's Rc, zc."""
    ym(Rc, zc, a.astype(np.complex128), Yc, False)
    N, nd = out.shape
    for r in range(N):
        for c in range(nd):
            out[r, c] = Yc[r, c].imag / H_STEP


@njit(cache=True)
def mass_matrix(R, z, theta, M):
    """M(q, theta_d) (Eq. 9a)."""
    nb = R.shape[0]
    M[:] = 0.0
    N = M.shape[0]
    J = np.empty((3, 3))
    sc = np.zeros((N, 3))  # columns of S: e_0, e_1, e_2, z_1, ..., z_n
    for i in range(3):
        sc[i, i] = 1.0
    for j in range(nb - 1):
        sc[3 + j] = z[j]
    x = np.empty(3)
    T1 = np.empty((3, 3))
    B = np.empty((3, 3))
    for k in range(nb):
        t = theta[6 * k : 6 * k + 6]
        J[0, 0], J[0, 1], J[0, 2] = t[0], t[1], t[2]
        J[1, 0], J[1, 1], J[1, 2] = t[1], t[3], t[4]
        J[2, 0], J[2, 1], J[2, 2] = t[2], t[4], t[5]
        _mm(R[k], J, T1)
        _mmt(T1, R[k], B)
        for c in range(3 + k):
            for i in range(3):
                x[i] = B[i, 0] * sc[c, 0] + B[i, 1] * sc[c, 1] + B[i, 2] * sc[c, 2]
            _add_st(M, c, k, z, x[0], x[1], x[2], False)
    p = 6 * nb
    D = np.empty((3, 3))
    X = np.empty((3, 3))
    Km = np.empty((3, 3))
    for k in range(nb):
        for l in range(k + 1, nb):
            for i in range(3):
                for j in range(3):
                    D[i, j] = theta[p + 3 * i + j]
            p += 9
            _mm(R[k], D, T1)
            _mmt(T1, R[l], X)
            tr = X[0, 0] + X[1, 1] + X[2, 2]
            for i in range(3):
                for j in range(3):
                    Km[i, j] = -X[j, i]
                Km[i, i] += tr
            for c in range(3 + l):  # S_k^T K S_l
                for i in range(3):
                    x[i] = Km[i, 0] * sc[c, 0] + Km[i, 1] * sc[c, 1] + Km[i, 2] * sc[c, 2]
                _add_st(M, c, k, z, x[0], x[1], x[2], False)
            for c in range(3 + k):  # S_l^T K^T S_k
                for i in range(3):
                    x[i] = Km[0, i] * sc[c, 0] + Km[1, i] * sc[c, 1] + Km[2, i] * sc[c, 2]
                _add_st(M, c, l, z, x[0], x[1], x[2], False)


@njit(cache=True)
def position_jacobian(R, z, V, J):
    """J (3, N) = -sum_k [R_k V_k]x S_k (d(p_e - p_com)/dt = J w)."""
    nb = R.shape[0]
    J[:] = 0.0
    r = np.zeros(3)
    tot = np.zeros(3)
    # column c of S_k is shared by all k >= (c - 2): accumulate r from the tip down
    for k in range(nb - 1, -1, -1):
        for i in range(3):
            r[i] = R[k, i, 0] * V[k, 0] + R[k, i, 1] * V[k, 1] + R[k, i, 2] * V[k, 2]
        tot += r
        if k >= 1:  # joint column of z_k multiplies sum_{l >= k} R_l V_l
            zk = z[k - 1]
            J[0, 2 + k] = zk[1] * tot[2] - zk[2] * tot[1]
            J[1, 2 + k] = zk[2] * tot[0] - zk[0] * tot[2]
            J[2, 2 + k] = zk[0] * tot[1] - zk[1] * tot[0]
    # base columns: e_c x tot
    J[0, 1], J[0, 2] = tot[2], -tot[1]
    J[1, 0], J[1, 2] = -tot[2], tot[0]
    J[2, 0], J[2, 1] = tot[1], -tot[0]


@njit(cache=True)
def y_z(R, z, w, Y):
    """Position rows of Y_z: (E_3, [w_k]x R_k for each V_k); Y (3, n_z)."""
    nb = R.shape[0]
    om = np.zeros((nb, 3))
    body_rates(z, w, om)
    Y[:] = 0.0
    Y[0, 0] = Y[1, 1] = Y[2, 2] = 1.0
    for k in range(nb):
        o0, o1, o2 = om[k, 0], om[k, 1], om[k, 2]
        for j in range(3):
            r0, r1, r2 = R[k, 0, j], R[k, 1, j], R[k, 2, j]
            c = 3 + 3 * k + j
            Y[0, c] = o1 * r2 - o2 * r1
            Y[1, c] = o2 * r0 - o0 * r2
            Y[2, c] = o0 * r1 - o1 * r0


@njit(cache=True)
def attitude_rows(R_m, ee_rot, z, m, out):
    """Rows 4-6 of Eq. (3): out (3, N) = 1/4 B(q_e) R_e^T S_m with R_e = R_m ee_rot and q_e
    its MRP on the |s| <= 1 branch (quaternion by Shepperd's method, w >= 0). Returns q_e."""
    Re = np.empty((3, 3))
    _mm(R_m, ee_rot, Re)
    tr = Re[0, 0] + Re[1, 1] + Re[2, 2]
    if tr > 0.0:
        t = np.sqrt(tr + 1.0) * 2.0
        qw, qx = 0.25 * t, (Re[2, 1] - Re[1, 2]) / t
        qy, qz = (Re[0, 2] - Re[2, 0]) / t, (Re[1, 0] - Re[0, 1]) / t
    elif Re[0, 0] > Re[1, 1] and Re[0, 0] > Re[2, 2]:
        t = np.sqrt(1.0 + Re[0, 0] - Re[1, 1] - Re[2, 2]) * 2.0
        qw, qx = (Re[2, 1] - Re[1, 2]) / t, 0.25 * t
        qy, qz = (Re[0, 1] + Re[1, 0]) / t, (Re[0, 2] + Re[2, 0]) / t
    elif Re[1, 1] > Re[2, 2]:
        t = np.sqrt(1.0 + Re[1, 1] - Re[0, 0] - Re[2, 2]) * 2.0
        qw, qx = (Re[0, 2] - Re[2, 0]) / t, (Re[0, 1] + Re[1, 0]) / t
        qy, qz = 0.25 * t, (Re[1, 2] + Re[2, 1]) / t
    else:
        t = np.sqrt(1.0 + Re[2, 2] - Re[0, 0] - Re[1, 1]) * 2.0
        qw, qx = (Re[1, 0] - Re[0, 1]) / t, (Re[0, 2] + Re[2, 0]) / t
        qy, qz = (Re[1, 2] + Re[2, 1]) / t, 0.25 * t
    if qw < 0.0:
        qw, qx, qy, qz = -qw, -qx, -qy, -qz
    s = np.empty(3)
    s[0], s[1], s[2] = qx / (1.0 + qw), qy / (1.0 + qw), qz / (1.0 + qw)
    ss = s[0] * s[0] + s[1] * s[1] + s[2] * s[2]
    B = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            B[i, j] = 2.0 * s[i] * s[j]
        B[i, i] += 1.0 - ss
    B[0, 1] -= 2.0 * s[2]
    B[0, 2] += 2.0 * s[1]
    B[1, 0] += 2.0 * s[2]
    B[1, 2] -= 2.0 * s[0]
    B[2, 0] -= 2.0 * s[1]
    B[2, 1] += 2.0 * s[0]
    L = np.empty((3, 3))
    _mmt(B, Re, L)
    out[:] = 0.0
    for i in range(3):
        for j in range(3):
            out[i, j] = 0.25 * L[i, j]
        for j in range(m):
            out[i, 3 + j] = 0.25 * (L[i, 0] * z[j, 0] + L[i, 1] * z[j, 1] + L[i, 2] * z[j, 2])
    return s


@njit(cache=True)
def controller_terms(
    s_b, q_m, joint_rot, axes, ee_rot, m, V, theta_d, w, a, sv,
    R, z, J, Yz, Yb, YM, YMdot, Yh, M,
):  # fmt: skip
    """Everything of one controller period in one call (one dispatch): kinematics, J (6, N)
    with position rows for the barycentric vectors V and MRP attitude rows, the position rows
    of Y_z, the base rows of Y_M(w) (for Y_b), Y_M(a), Y_Mdot(w, s), Y_h(w) and M(theta_d)."""
    kinematics(s_b, q_m, joint_rot, axes, R, z)
    position_jacobian(R, z, V, J[:3])
    attitude_rows(R[m], ee_rot, z, m, J[3:])
    y_z(R, z, w, Yz)
    ym(R, z, a, YM, False)
    nb, n = R.shape[0], z.shape[0]
    Rc = np.empty((nb, 3, 3), dtype=np.complex128)
    zc = np.empty((n, 3), dtype=np.complex128)
    Yc = np.empty(YM.shape, dtype=np.complex128)
    motion_step(R, z, w, Rc, zc)
    ym_rate(Rc, zc, sv, Yc, YMdot)
    ym_rate(Rc, zc, w, Yc, Yh)
    # the real part of that complex step is Y_M(w) to O(h^2): its base rows are Y_b's
    for r in range(3):
        for c in range(Yb.shape[1]):
            Yb[r, c] = Yc[r, c].real
    subtract_dT(R, z, w, Yh)
    mass_matrix(R, z, theta_d, M)


@njit(cache=True)
def subtract_dT(R, z, w, Y_h):
    """Y_h[3 + j] -= dT/dq_j regressor (T at fixed base attitude and w) for every joint j.

    Turning joint j rotates the bodies k >= j + 1 about z_j: dR_k = [z_j]x R_k and
    dw_k = [z_j]x w_k + c with c = -z_j x w_j (w_j of the parent body j). Terms between two
    turning bodies are invariant under the common rotation, so only c changes them (dQ = 0,
    d(R_k^T w_l) = R_k^T c); terms between a fixed body k and a turning body l change with
    dQ = R_k^T [z_j]x R_l, dw_l, and d(R_l^T w_k) = ([z_j]x R_l)^T w_k. Q, u, g and the dot
    products do not depend on j and are computed once.
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
