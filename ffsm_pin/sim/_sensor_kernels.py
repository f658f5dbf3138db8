"""The spatial sensor's arithmetic in one compiled call (:class:`~.measurement.Sensor`):
what it derives from the plant state and Pinocchio's end-effector frame each step.

A first run compiles it in ``prepare`` (the initial measurement), about 1 s, before the
controller's kernels; a planar run never compiles it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..attitude._mrp_kernels import from_quaternion, from_rotation, kinematics_rate, to_rotation


@njit(cache=True)
def spatial_measurement(q, v, placement, twist):
    """(q_b, R_0, z_e, dz_e/dt, w) of a free-flyer state (docs/spatial.md section 1).

    ``q`` (7 + n,) and ``v`` (6 + n,) Pinocchio's configuration and velocity (base twist in the
    base frame); ``placement`` (4, 4) the end-effector frame's homogeneous placement (R_e,
    p_e [m]), ``twist`` (6,) its velocity (v_e [m/s], w_e [rad/s]), world-aligned: one array
    each, as Pinocchio gives them (each array it makes costs a call). q_b the base MRP, R_0 its
    rotation, z_e = (p_e, q_e) with q_e the end-effector MRP, dz_e/dt = (v_e, 1/4 B(q_e)
    R_e^T w_e), w = (R_0 w_B, dq_m) with the base's angular velocity in the inertial frame.
    """
    R_e = placement[:3, :3]
    p_e, v_e, w_e = placement[:3, 3], twist[:3], twist[3:]
    q_b = from_quaternion(q[3], q[4], q[5], q[6])
    R0 = to_rotation(q_b)
    q_e = from_rotation(R_e)
    rate = kinematics_rate(q_e, R_e, w_e)
    z_e = np.empty(6)
    z_e_dot = np.empty(6)
    for i in range(3):
        z_e[i], z_e[3 + i] = p_e[i], q_e[i]
        z_e_dot[i], z_e_dot[3 + i] = v_e[i], rate[i]
    w = np.empty(v.size - 3)
    for i in range(3):
        w[i] = R0[i, 0] * v[3] + R0[i, 1] * v[4] + R0[i, 2] * v[5]
    for i in range(6, v.size):
        w[i - 3] = v[i]
    return q_b, R0, z_e, z_e_dot, w
