"""Modified Rodrigues parameters (MRP), the attitude coordinates of the spatial model.

``s = e tan(phi / 4)`` for a rotation by ``phi`` [rad] about the unit axis ``e``. Rotation
matrices map body-frame vectors to the inertial frame (``R = R_inertial_body``), quaternions
are ``(x, y, z, w)`` as in Pinocchio's configuration vector. Kinematics (docs/spatial.md
section 5): ``ds/dt = 1/4 B(s) w_body`` with ``B(s) = (1 - s^T s) E + 2 [s]x + 2 s s^T``; with
the angular velocity in the inertial frame, Eq. (1) reads ``dq_b/dt = L_b w_b`` with
``L_b = 1/4 B(q_b) R^T``. The shadow set ``-s / (s^T s)`` describes the same attitude; every
attitude this package reports is on the ``|s| <= 1`` branch.

The functions are rational in ``s`` (no norms, no square roots on the MRP side), so they
accept complex arguments (complex-step derivatives).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def skew(v) -> np.ndarray:
    """[v]x, the 3x3 cross-product matrix: ``skew(a) @ b == cross(a, b)``."""
    x, y, z = v
    return np.array([[0 * x, -z, y], [z, 0 * x, -x], [-y, x, 0 * x]])


def B_matrix(s) -> np.ndarray:
    """B(s) = (1 - s^T s) E_3 + 2 [s]x + 2 s s^T, with ``ds/dt = 1/4 B(s) w_body``."""
    s0, s1, s2 = (x.item() if hasattr(x, "item") else x for x in s)
    d = 1 - (s0 * s0 + s1 * s1 + s2 * s2)
    return np.array(
        [
            [d + 2 * s0 * s0, 2 * (s0 * s1 - s2), 2 * (s0 * s2 + s1)],
            [2 * (s1 * s0 + s2), d + 2 * s1 * s1, 2 * (s1 * s2 - s0)],
            [2 * (s2 * s0 - s1), 2 * (s2 * s1 + s0), d + 2 * s2 * s2],
        ]
    )


def to_rotation(s) -> np.ndarray:
    """Rotation matrix (body to inertial) of the MRP ``s``."""
    s = np.asarray(s)
    ss = s @ s
    S = skew(s)
    return np.eye(3) + (8 * S @ S + 4 * (1 - ss) * S) / (1 + ss) ** 2


def shadow(s) -> np.ndarray:
    """The MRP on the ``|s| <= 1`` branch describing the same attitude as ``s``."""
    s = np.asarray(s, dtype=float)
    ss = float(s @ s)
    return -s / ss if ss > 1.0 else s.copy()


def from_quaternion(quat) -> np.ndarray:
    """MRP (on the ``|s| <= 1`` branch) of a unit quaternion ``(x, y, z, w)``."""
    x, y, z, w = (float(c) for c in quat)
    if w < 0:  # -quat is the same rotation; w >= 0 gives |s| <= 1
        x, y, z, w = -x, -y, -z, -w
    return np.array([x, y, z]) / (1.0 + w)


def to_quaternion(s) -> np.ndarray:
    """Unit quaternion ``(x, y, z, w)`` of the MRP ``s``."""
    s = np.asarray(s, dtype=float)
    ss = float(s @ s)
    return np.concatenate((2 * s, [1 - ss])) / (1 + ss)


def angles_from(s_rows: np.ndarray, s0: np.ndarray) -> np.ndarray:
    """Per row of ``s_rows`` (N, 3), the angle of the rotation from the attitude ``s0`` to the
    row's [rad], 2 acos |<quat_0, quat>| (in [0, pi]).

    Parameters
    ----------
    s_rows : ndarray, shape (N, 3)
        Attitudes (MRP).
    s0 : ndarray, shape (3,)
        The attitude the angles are measured from (MRP).

    Returns
    -------
    ndarray, shape (N,)
        The angles [rad].
    """

    def quat(s):  # MRP -> unit quaternion (w, x, y, z), rows
        n2 = np.sum(s * s, axis=-1, keepdims=True)
        return np.concatenate(((1 - n2) / (1 + n2), 2 * s / (1 + n2)), axis=-1)

    dot = np.abs(quat(s_rows) @ quat(s0[None, :])[0])
    return 2 * np.arccos(np.minimum(dot, 1.0))


def from_rotation(R) -> np.ndarray:
    """MRP (on the ``|s| <= 1`` branch) of a rotation matrix (body to inertial).

    Shepperd's method (the branch is chosen on the real parts), then ``s = q_v / (1 + q_w)``
    with ``q_w >= 0``; analytic in R, so a complex-step perturbation of R is carried through.
    """
    R = np.asarray(R)
    if R.dtype == np.float64:  # real: Pinocchio's quaternion (same branch choice, faster)
        return from_quaternion(pin.Quaternion(R).coeffs())
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    d = np.real(np.array([tr, R[0, 0], R[1, 1], R[2, 2]]))
    if d[0] > 0.0:
        t = np.sqrt(tr + 1.0) * 2.0
        qw = 0.25 * t
        qx, qy, qz = ((R[k, j] - R[j, k]) / t for j, k in ((1, 2), (2, 0), (0, 1)))
    else:  # the largest diagonal entry i, (i, j, k) cyclic
        i = 0 if d[1] > d[2] and d[1] > d[3] else (1 if d[2] > d[3] else 2)
        j, k = (i + 1) % 3, (i + 2) % 3
        others = sorted((j, k))
        t = np.sqrt(1.0 + R[i, i] - R[others[0], others[0]] - R[others[1], others[1]]) * 2.0
        q_v = [0.0 * t] * 3
        q_v[i], q_v[j], q_v[k] = 0.25 * t, (R[i, j] + R[j, i]) / t, (R[i, k] + R[k, i]) / t
        qw, (qx, qy, qz) = (R[k, j] - R[j, k]) / t, q_v
    if np.real(qw) < 0.0:
        qw, qx, qy, qz = -qw, -qx, -qy, -qz
    return np.array([qx, qy, qz]) / (1.0 + qw)


def from_rpy(rpy) -> np.ndarray:
    """MRP of roll-pitch-yaw angles [rad] (URDF convention, ``R = Rz(y) Ry(p) Rx(r)``)."""
    return from_rotation(pin.rpy.rpyToMatrix(*(float(a) for a in rpy)))


def L_matrix(s, R=None) -> np.ndarray:
    """L_b = 1/4 B(s) R^T of Eq. (1) (``dq_b/dt = L_b w_b``, w_b inertial) [1/rad].

    Parameters
    ----------
    s : array_like, shape (3,)
        The base attitude's MRP.
    R : array_like, shape (3, 3), optional
        Its rotation matrix, when known (computed from ``s`` otherwise).

    Returns
    -------
    ndarray, shape (3, 3)
        L_b [1/rad].
    """
    if R is None:
        R = to_rotation(s)
    return 0.25 * B_matrix(s) @ np.asarray(R).T
