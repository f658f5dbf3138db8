"""One controller period's terms of the spatial model: what
:meth:`~ffsm_pin.model.spatial.SpatialBarycentricModel.controller_terms` returns
(:class:`ControllerTerms`) and the compiled call that computes them all at once
(:func:`controller_terms`, writing into a :class:`TermsBuffers`), from the kinematics, mass
and velocity kernels.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ._spatial_kinematics_kernels import attitude_rows, kinematics, position_jacobian, y_z
from ._spatial_mass_kernels import mass_matrix_by_sums
from ._spatial_velocity_kernels import subtract_dT, velocity_terms


class TermsBuffers(NamedTuple):
    """Where the compiled ``controller_terms`` writes (the arrays of
    :class:`ControllerTerms`, J whole)."""

    J: np.ndarray  # (6, n+3)
    Y_z: np.ndarray
    Y_b: np.ndarray
    Y_M: np.ndarray
    Y_Mdot: np.ndarray
    Y_h: np.ndarray
    M: np.ndarray


class ControllerTerms(NamedTuple):
    """Everything the controller needs for one period (see
    :meth:`~ffsm_pin.model.spatial.SpatialBarycentricModel.controller_terms`)."""

    J_b: np.ndarray  # (6, 3) Eq. (3)
    J_m: np.ndarray  # (6, n)
    Y_z: np.ndarray  # (6, n_z) Eq. (4), attitude rows zero
    Y_b: np.ndarray  # (3, n_b) Eq. (14)
    Y_M: np.ndarray  # (n+3, n_d): Y_M theta_d = M a
    Y_Mdot: np.ndarray  # (n+3, n_d): Y theta_d = dM/dt s
    Y_h: np.ndarray  # (n+3, n_d): Y theta_d = C w, Eq. (8)
    M: np.ndarray  # (n+3, n+3) M(q, theta_d), Eq. (9a)


@njit(cache=True)
def controller_terms(geo, s_b, q_m, theta_z, theta_d, w, a, sv, out):
    """Everything of one controller period in one call (one dispatch, every output written in
    full into ``out``): kinematics, J (6, N) with position rows for the barycentric vectors V_k
    of theta_z and MRP attitude rows, Y_z (6, n_z), Y_b (3, n_b), Y_M(a), Y_Mdot(w, s), Y_h(w)
    and M(theta_d); the same values as the separate kernels.

    Parameters
    ----------
    geo : SpatialKernelConstants
        The robot's :class:`~ffsm_pin.model.spatial.SpatialKernelConstants` (joint
        placements' rotations (n, 3, 3), joint axes (n, 3), end-effector frame (3, 3), the
        end effector's body).
    s_b : ndarray (3,)
        Base attitude, MRP.
    q_m : ndarray (n,)
        Joint angles [rad].
    theta_z : ndarray (n_z,)
        Kinematic parameters of Eq. (4): (v_0 [m/s], V_0, ..., V_n [m] in body frames).
    theta_d : ndarray (n_d,)
        Dynamic parameters of Eq. (12) [kg m^2].
    w : ndarray (N,)
        Velocity ``(w_b, dq_m)`` [rad/s], w_b in the inertial frame.
    a : ndarray (N,)
        The vector of Y_M(a) [rad/s^2].
    sv : ndarray (N,)
        The vector s of Y_Mdot(w, s) [rad/s].
    out : TermsBuffers
        The outputs, each written in full: J (6, N), Y_z (6, n_z), Y_b (3, n_b), Y_M, Y_Mdot,
        Y_h (N, n_d) and M (N, N).
    """
    joint_rot, axes, ee_rot, m = geo
    J, Yz, Yb, YM, YMdot, Yh, M = out
    nb, n = joint_rot.shape[0] + 1, joint_rot.shape[0]
    R = np.empty((nb, 3, 3))
    z = np.empty((n, 3))
    V = np.empty((nb, 3))
    for k in range(nb):
        for i in range(3):
            V[k, i] = theta_z[3 + 3 * k + i]
    kinematics(s_b, q_m, joint_rot, axes, R, z)
    position_jacobian(R, z, V, J[:3])
    attitude_rows(R[m], ee_rot, z, m, J[3:])
    y_z(R, z, w, Yz[:3])
    Yz[3:] = 0.0
    for i in range(3):
        for j in range(3):
            Yb[i, j] = -1.0 if i == j else 0.0
    velocity_terms(R, z, w, a, sv, YM, YMdot, Yh, Yb[:, 3:])
    subtract_dT(R, z, w, Yh)
    mass_matrix_by_sums(R, z, theta_d, M)
