"""Compiled (numba) kernels of the spatial model's kinematics: the body rotations R_k and
inertial joint axes z_j of a configuration, the body angular velocities S_k w, the position
rows of J and Y_z, and the MRP attitude rows of Eq. (3).

The same expressions as the numpy reference of :mod:`ffsm_pin.model.spatial` (checked against
it in tests/model). Shapes: R (n+1, 3, 3) body rotations, z (n, 3) inertial joint axes,
N = n + 3 velocity components; the 3x3 products :func:`mm` and :func:`mmt` are shared with the
other spatial kernels.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._docstrings import fill_doc
from ._kernel_docs import KERNEL_DOC


@njit(cache=True, inline="always")
def mm(A, B, out):
    """Set ``out = A @ B`` for 3x3 (no BLAS call).

    Parameters
    ----------
    A : ndarray (3, 3)
        Left factor (real or complex).
    B : ndarray (3, 3)
        Right factor.
    out : ndarray (3, 3)
        The product, overwritten; not ``A`` or ``B``.
    """
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(cache=True, inline="always")
def mmt(A, B, out):
    """Set ``out = A @ B^T`` for 3x3.

    Parameters
    ----------
    A : ndarray (3, 3)
        Left factor (real or complex).
    B : ndarray (3, 3)
        Right factor, transposed.
    out : ndarray (3, 3)
        The product, overwritten; not ``A`` or ``B``.
    """
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[j, 0] + A[i, 1] * B[j, 1] + A[i, 2] * B[j, 2]


@njit(cache=True)
def kinematics(s, q_m, joint_rot, axes, R, z):
    """Body rotations R_k and inertial joint axes z_j from the base MRP s and joint angles
    (real or complex: the scratch arrays take the dtype of R).

    Parameters
    ----------
    s : ndarray (3,)
        Base attitude, MRP.
    q_m : ndarray (n,)
        Joint angles [rad].
    joint_rot : ndarray (n, 3, 3)
        Rotation of each joint's placement in its parent body.
    axes : ndarray (n, 3)
        Joint axes (unit vectors) in their joint frames.
    R : ndarray (n+1, 3, 3)
        Body rotations R_k (body to inertial), overwritten.
    z : ndarray (n, 3)
        Inertial joint axes z_j, overwritten.
    """
    ss = s[0] * s[0] + s[1] * s[1] + s[2] * s[2]
    S = np.zeros((3, 3), dtype=R.dtype)
    S[0, 1], S[0, 2], S[1, 0], S[1, 2], S[2, 0], S[2, 1] = -s[2], s[1], s[2], -s[0], -s[1], s[0]
    S2 = np.empty((3, 3), dtype=R.dtype)
    mm(S, S, S2)
    d = (1.0 + ss) ** 2
    for i in range(3):
        for j in range(3):
            R[0, i, j] = (1.0 if i == j else 0.0) + (
                8.0 * S2[i, j] + 4.0 * (1.0 - ss) * S[i, j]
            ) / d
    U = np.zeros((3, 3), dtype=R.dtype)
    U2 = np.empty((3, 3), dtype=R.dtype)
    rot = np.empty((3, 3), dtype=R.dtype)
    tmp = np.empty((3, 3), dtype=R.dtype)
    for k in range(1, R.shape[0]):
        u = axes[k - 1]
        U[0, 1], U[0, 2], U[1, 0], U[1, 2], U[2, 0], U[2, 1] = -u[2], u[1], u[2], -u[0], -u[1], u[0]
        c, sn = np.cos(q_m[k - 1]), np.sin(q_m[k - 1])
        mm(U, U, U2)
        for i in range(3):
            for j in range(3):
                rot[i, j] = (1.0 if i == j else 0.0) + sn * U[i, j] + (1.0 - c) * U2[i, j]
        mm(R[k - 1], joint_rot[k - 1], tmp)
        mm(tmp, rot, R[k])
        for i in range(3):
            z[k - 1, i] = R[k, i, 0] * u[0] + R[k, i, 1] * u[1] + R[k, i, 2] * u[2]


@njit(cache=True)
def body_rates(z, a, out):
    """out[k] = S_k a (body angular velocities for the rates a).

    Parameters
    ----------
    z : ndarray (n, 3)
        Inertial joint axes z_j.
    a : ndarray (N,)
        Rates ``(a_b, a_m)`` [rad/s], a_b in the inertial frame (or any vector of that
        layout, e.g. accelerations [rad/s^2]).
    out : ndarray (n+1, 3)
        S_k a for each body k, overwritten (in the unit of ``a``).
    """
    out[0, 0], out[0, 1], out[0, 2] = a[0], a[1], a[2]
    for k in range(1, out.shape[0]):
        for i in range(3):
            out[k, i] = out[k - 1, i] + z[k - 1, i] * a[2 + k]


@njit(cache=True)
@fill_doc(KERNEL_DOC)
def position_jacobian(R, z, V, J):
    """J (3, N) = -sum_k [R_k V_k]x S_k (d(p_e - p_com)/dt = J w); real or complex (dtype of J).

    %(params_R_z)s
    V : ndarray (n+1, 3)
        Barycentric vectors V_k [m], each in body k's frame.
    J : ndarray (3, N)
        Position rows of Eq. (3) [m], overwritten.
    """
    nb = R.shape[0]
    J[:] = 0.0
    r = np.zeros(3, dtype=J.dtype)
    tot = np.zeros(3, dtype=J.dtype)
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
@fill_doc(KERNEL_DOC)
def y_z(R, z, w, Y):
    """Position rows of Y_z: (E_3, [w_k]x R_k for each V_k); Y (3, n_z).

    %(params_R_real_z)s
    w : ndarray (N,)
        Velocity ``(w_b, dq_m)`` [rad/s], w_b in the inertial frame.
    Y : ndarray (3, n_z)
        Position rows of Eq. (4), overwritten (columns of V_k in [rad/s]).
    """
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
    its MRP on the |s| <= 1 branch (quaternion by Shepperd's method, w >= 0; branches chosen on
    the real parts, so complex-step arguments pass through). Returns q_e.

    Parameters
    ----------
    R_m : ndarray (3, 3)
        Rotation of body m, the end effector's body.
    ee_rot : ndarray (3, 3)
        End-effector frame in body m.
    z : ndarray (n, 3)
        Inertial joint axes z_j.
    m : int
        The end effector's body (1..n): the joints 1..m move it.
    out : ndarray (3, N)
        Attitude rows of Eq. (3) [1/rad], overwritten (dtype of the computation).

    Returns
    -------
    ndarray (3,)
        q_e, the end-effector attitude (MRP, |q_e| <= 1).
    """
    Re = np.empty((3, 3), dtype=out.dtype)
    mm(R_m, ee_rot, Re)
    tr = Re[0, 0] + Re[1, 1] + Re[2, 2]
    if tr.real > 0.0:
        t = np.sqrt(tr + 1.0) * 2.0
        qw, qx = 0.25 * t, (Re[2, 1] - Re[1, 2]) / t
        qy, qz = (Re[0, 2] - Re[2, 0]) / t, (Re[1, 0] - Re[0, 1]) / t
    elif Re[0, 0].real > Re[1, 1].real and Re[0, 0].real > Re[2, 2].real:
        t = np.sqrt(1.0 + Re[0, 0] - Re[1, 1] - Re[2, 2]) * 2.0
        qw, qx = (Re[2, 1] - Re[1, 2]) / t, 0.25 * t
        qy, qz = (Re[0, 1] + Re[1, 0]) / t, (Re[0, 2] + Re[2, 0]) / t
    elif Re[1, 1].real > Re[2, 2].real:
        t = np.sqrt(1.0 + Re[1, 1] - Re[0, 0] - Re[2, 2]) * 2.0
        qw, qx = (Re[0, 2] - Re[2, 0]) / t, (Re[0, 1] + Re[1, 0]) / t
        qy, qz = 0.25 * t, (Re[1, 2] + Re[2, 1]) / t
    else:
        t = np.sqrt(1.0 + Re[2, 2] - Re[0, 0] - Re[1, 1]) * 2.0
        qw, qx = (Re[1, 0] - Re[0, 1]) / t, (Re[0, 2] + Re[2, 0]) / t
        qy, qz = (Re[1, 2] + Re[2, 1]) / t, 0.25 * t
    if qw.real < 0.0:
        qw, qx, qy, qz = -qw, -qx, -qy, -qz
    s = np.empty(3, dtype=out.dtype)
    s[0], s[1], s[2] = qx / (1.0 + qw), qy / (1.0 + qw), qz / (1.0 + qw)
    ss = s[0] * s[0] + s[1] * s[1] + s[2] * s[2]
    B = np.empty((3, 3), dtype=out.dtype)
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
    L = np.empty((3, 3), dtype=out.dtype)
    mmt(B, Re, L)
    out[:] = 0.0
    for i in range(3):
        for j in range(3):
            out[i, j] = 0.25 * L[i, j]
        for j in range(m):
            out[i, 3 + j] = 0.25 * (L[i, 0] * z[j, 0] + L[i, 1] * z[j, 1] + L[i, 2] * z[j, 2])
    return s
