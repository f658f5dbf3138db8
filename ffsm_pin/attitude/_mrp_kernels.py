"""Compiled twins of :mod:`ffsm_pin.attitude.mrp` for real arguments (the sensor's per-step
attitude arithmetic), tested against it in ``tests/attitude/test_mrp_kernels.py``.

The same formulas written out by entries: a 3 x 3 product here adds its terms left to right
where numpy's goes through BLAS, so results agree to rounding, not bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["from_quaternion", "from_rotation", "kinematics_rate", "l_matrix", "to_rotation"]


@njit(cache=True)
def from_quaternion(x, y, z, w):
    """MRP (on the ``|s| <= 1`` branch) of the unit quaternion ``(x, y, z, w)``
    (:func:`ffsm_pin.attitude.mrp.from_quaternion`)."""
    if w < 0:  # -quat is the same rotation; w >= 0 gives |s| <= 1
        x, y, z, w = -x, -y, -z, -w
    d = 1.0 + w
    out = np.empty(3)
    out[0], out[1], out[2] = x / d, y / d, z / d
    return out


@njit(cache=True)
def to_rotation(s):
    """Rotation matrix (body to inertial) of the MRP ``s``
    (:func:`ffsm_pin.attitude.mrp.to_rotation`):
    ``E + (8 [s]x^2 + 4 (1 - s^T s) [s]x) / (1 + s^T s)^2``."""
    s0, s1, s2 = s[0], s[1], s[2]
    ss = s0 * s0 + s1 * s1 + s2 * s2
    S = np.zeros((3, 3))
    S[0, 1], S[0, 2], S[1, 0], S[1, 2], S[2, 0], S[2, 1] = -s2, s1, s2, -s0, -s1, s0
    c = 4.0 * (1.0 - ss)
    den = (1.0 + ss) * (1.0 + ss)
    R = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            S2 = S[i, 0] * S[0, j] + S[i, 1] * S[1, j] + S[i, 2] * S[2, j]
            R[i, j] = (1.0 if i == j else 0.0) + (8.0 * S2 + c * S[i, j]) / den
    return R


@njit(cache=True)
def from_rotation(R):
    """MRP (on the ``|s| <= 1`` branch) of a rotation matrix, Shepperd's method
    (:func:`ffsm_pin.attitude.mrp.from_rotation`)."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    if tr > 0.0:
        t = np.sqrt(tr + 1.0) * 2.0
        qw, qx, qy, qz = (
            0.25 * t,
            (R[2, 1] - R[1, 2]) / t,
            (R[0, 2] - R[2, 0]) / t,
            (R[1, 0] - R[0, 1]) / t,
        )
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        t = np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2.0
        qw, qx, qy, qz = (
            (R[2, 1] - R[1, 2]) / t,
            0.25 * t,
            (R[0, 1] + R[1, 0]) / t,
            (R[0, 2] + R[2, 0]) / t,
        )
    elif R[1, 1] > R[2, 2]:
        t = np.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2.0
        qw, qx, qy, qz = (
            (R[0, 2] - R[2, 0]) / t,
            (R[0, 1] + R[1, 0]) / t,
            0.25 * t,
            (R[1, 2] + R[2, 1]) / t,
        )
    else:
        t = np.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2.0
        qw, qx, qy, qz = (
            (R[1, 0] - R[0, 1]) / t,
            (R[0, 2] + R[2, 0]) / t,
            (R[1, 2] + R[2, 1]) / t,
            0.25 * t,
        )
    return from_quaternion(qx, qy, qz, qw)


@njit(cache=True)
def kinematics_rate(s, R, w):
    """ds/dt = L(s) w = 1/4 B(s) R^T w for the angular velocity ``w`` in the inertial frame
    [rad/s] (Eq. (1); :func:`ffsm_pin.attitude.mrp.L_matrix`)."""
    s0, s1, s2 = s[0], s[1], s[2]
    d = 1.0 - (s0 * s0 + s1 * s1 + s2 * s2)
    wb = np.empty(3)  # R^T w: the body-frame angular velocity
    for j in range(3):
        wb[j] = R[0, j] * w[0] + R[1, j] * w[1] + R[2, j] * w[2]
    out = np.empty(3)
    out[0] = (d + 2 * s0 * s0) * wb[0] + 2 * (s0 * s1 - s2) * wb[1] + 2 * (s0 * s2 + s1) * wb[2]
    out[1] = 2 * (s1 * s0 + s2) * wb[0] + (d + 2 * s1 * s1) * wb[1] + 2 * (s1 * s2 - s0) * wb[2]
    out[2] = 2 * (s2 * s0 - s1) * wb[0] + 2 * (s2 * s1 + s0) * wb[1] + (d + 2 * s2 * s2) * wb[2]
    for i in range(3):
        out[i] *= 0.25
    return out


@njit(cache=True)
def l_matrix(s, R0):
    """L_b = 1/4 B(s) R0^T of Eq. (1) (:func:`ffsm_pin.attitude.mrp.L_matrix`) as complex128,
    for real or complex ``s`` and ``R0`` (a complex step through the attitude); the product
    with R0^T adds its terms in ascending order."""
    s0, s1, s2 = s[0], s[1], s[2]
    d = 1.0 - (s0 * s0 + s1 * s1 + s2 * s2)
    B = np.empty((3, 3), dtype=np.complex128)
    B[0, 0], B[0, 1], B[0, 2] = d + 2 * s0 * s0, 2 * (s0 * s1 - s2), 2 * (s0 * s2 + s1)
    B[1, 0], B[1, 1], B[1, 2] = 2 * (s1 * s0 + s2), d + 2 * s1 * s1, 2 * (s1 * s2 - s0)
    B[2, 0], B[2, 1], B[2, 2] = 2 * (s2 * s0 - s1), 2 * (s2 * s1 + s0), d + 2 * s2 * s2
    BR = np.zeros((3, 3), dtype=np.complex128)  # B R0^T
    for i in range(3):
        for j in range(3):
            acc = 0j
            for k in range(3):
                acc += B[i, k] * R0[j, k]
            BR[i, j] = acc
    return 0.25 * BR
