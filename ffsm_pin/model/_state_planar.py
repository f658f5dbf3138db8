"""The paper's reduced quantities for one plant state, computed by Pinocchio's algorithms.

The planar root's part of :class:`~ffsm_pin.model.state.State`, which owns a Pinocchio ``Data``
and computes everything for a state in one :meth:`~ffsm_pin.model.state.State.update` call;
the results are read-only arrays.

Conventions (docs/model.md section 1): Pinocchio's planar root has q = (x, y, cos q_b, sin q_b,
q_m) and v = (v_x, v_y, w_b, w_m) with (v_x, v_y) in the *base* frame. The paper's
velocity is w = (w_b, w_m); base translation is eliminated through the conserved linear
momentum, so every reduced quantity is about the system centre of mass:

* ``M = M_rr - M_rt M_tt^-1 M_tr`` (Schur complement of CRBA's translational block), Eq. (9a);
* ``h = h_r - M_rt M_tt^-1 h_t`` = C(q, w) w from RNEA's velocity terms, Eq. (8);
* ``H_bb, H_bm`` = angular row of the centroidal momentum matrix, Eq. (13);
* ``J_b, J_m`` = Jacobians of (p_e - p_com, q_e) w.r.t. (q_b, q_m), Eq. (3);
* ``v_0 = P / m`` and ``A_0 = L`` (angular momentum about the CoM).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from .._arrays import read_only
from ._common import end_effector_at

_T = slice(0, 2)  # translational velocity block (base frame)
_R = slice(2, None)  # (w_b, w_m)


def base_twist_to_world(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(v_x, v_y, w_b) with the linear part in the inertial frame [m/s, m/s, rad/s]."""
    c, s = q[2], q[3]
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]])


def base_twist_to_local(q: np.ndarray, twist_world) -> np.ndarray:
    """Inverse of :func:`base_twist_to_world`: inertial-frame base twist to Pinocchio's."""
    c, s = q[2], q[3]
    vx, vy, wb = (float(x) for x in twist_world)
    return np.array([c * vx + s * vy, -s * vx + c * vy, wb])


def fill_dynamics(st, q: np.ndarray, v: np.ndarray) -> None:
    """Set only ``st.M``, ``st.h`` (Eqs. 9a, 8), ``st.mass_matrix`` and
    ``st.nonlinear_effects`` for the plant state (q, v): what a controller that is given the
    true model needs each period (:meth:`ffsm_pin.model.state.State.update_dynamics`)."""
    model, data = st.model, st.data
    M = pin.crba(model, data, q).copy()  # upper triangle filled
    M[st.lower_triangle] = M.T[st.lower_triangle]
    M += 0.0  # the bits of triu(M) + triu(M, 1).T, zeros' signs included: x + 0.0 == 0.0 + x
    h = pin.rnea(model, data, q, v, np.zeros(model.nv)).copy()
    Mtt_inv_Mtr = np.linalg.solve(M[_T, _T], np.column_stack((M[_T, _R], h[_T])))
    st.mass_matrix = read_only(M)  # full CRBA matrix (nv x nv)
    st.nonlinear_effects = read_only(h)  # full RNEA velocity terms (nv)
    st.M = read_only(M[_R, _R] - M[_R, _T] @ Mtt_inv_Mtr[:, :-1])  # Eq. (9a)
    st.h = read_only(h[_R] - M[_R, _T] @ Mtt_inv_Mtr[:, -1])  # C(q, w) w, Eq. (8)


def fill_kinematics(st, q: np.ndarray, v: np.ndarray) -> tuple:
    """Set only ``st.H_bb``, ``st.H_bm`` (Eq. 13), ``st.J_b`` and ``st.J_m`` (Eq. 3) for the
    plant state (q, v), the numbers :func:`fill` sets
    (:meth:`ffsm_pin.model.state.State.update_kinematics`); return what :func:`fill` goes on
    with: ``(Ag, hg, com, oMe)``."""
    model, data = st.model, st.data
    pin.ccrba(model, data, q, v)  # Ag, hg, com about the CoM (world-aligned)
    Ag = data.Ag.copy()
    hg = data.hg.copy()
    com = data.com[0].copy()
    J_ee, oMe = end_effector_at(model, data, q, st.ee_frame_id)
    J_com = pin.jacobianCenterOfMass(model, data, q, False)

    st.H_bb = read_only(Ag[5:6, 2:3].copy())  # Eq. (13)
    st.H_bm = read_only(Ag[5:6, 3:].copy())
    Jr = np.empty((3, model.nv - 2))
    Jr[:2] = (J_ee[:2] - J_com[:2])[:, _R]  # d(p_e - p_com)
    Jr[2] = J_ee[5, _R]
    st.J_b = read_only(Jr[:, :1].copy())  # Eq. (3)
    st.J_m = read_only(Jr[:, 1:].copy())
    return Ag, hg, com, oMe


def fill(st, q: np.ndarray, v: np.ndarray) -> None:
    """Set every reduced quantity of ``st`` (a :class:`ffsm_pin.model.state.State`) for the
    plant state (q, v), already checked and stored as ``st.q``, ``st.v``."""
    fill_dynamics(st, q, v)
    Ag, hg, com, oMe = fill_kinematics(st, q, v)
    st.centroidal_map = read_only(Ag)
    st.linear_momentum = read_only(hg.linear[:2].copy())  # P, inertial frame [kg m/s]
    st.angular_momentum = float(hg.angular[2])  # L about the CoM [kg m^2/s]
    st.com_position = read_only(com[:2].copy())  # [m]
    st.com_velocity = read_only(st.linear_momentum / st.total_mass)  # v_0 [m/s]
    rot = oMe.rotation
    st.base_attitude = math.atan2(q[3], q[2])  # q_b in (-pi, pi] [rad]
    st.ee_pose = read_only(
        np.array([oMe.translation[0], oMe.translation[1], math.atan2(rot[1, 0], rot[0, 0])])
    )  # z_e with q_e in (-pi, pi]
    st.w = read_only(v[_R].copy())  # (w_b, w_m) [rad/s]
    st.base_twist_world = read_only(base_twist_to_world(q, v))


def state_reaction_torque(st, w_dot: np.ndarray) -> np.ndarray:
    """F_r of Eq. (7), (1,) [N m]: ``M_bb dw_b/dt + 1/2 dM_bb/dt w_b`` (Christoffel C), with
    dM_bb/dt the time derivative of the centroidal map's angular entry (``pin.dccrba``)."""
    pin.dccrba(st.model, st.data, st.q, st.v)
    M_bb_dot = float(st.data.dAg[5, 2])
    return read_only(np.array([st.H_bb[0, 0] * w_dot[0] + 0.5 * M_bb_dot * st.w[0]]))


def w_dot(st, a: np.ndarray) -> np.ndarray:
    """dw/dt = (dw_b/dt, ddq_m) from Pinocchio's acceleration ``a``: its rotational rows."""
    return np.array(a[2:], dtype=float)
