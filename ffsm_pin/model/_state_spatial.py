"""The paper's reduced quantities of a spatial robot for one plant state, from Pinocchio.

The free-flyer root's part of :class:`~ffsm_pin.model.state.State`, which owns a Pinocchio
``Data`` and computes everything for a state in one :meth:`~ffsm_pin.model.state.State.update`
call; the results are read-only arrays.

Velocities (docs/spatial.md section 1): Pinocchio's free-flyer has v = (v_B, w_B, dq_m) with
the base twist in the *base* frame. The controller's velocity is w = (w_b, dq_m) with
``w_b = R_0 w_B`` in the *inertial* frame. With ``x = (p_dot_B, w_b, dq_m) = T^-1 v``,
``T = diag(R_0^T, R_0^T, E)``, the dynamics read ``T^T M T x_dot + T^T (h + M T_dot x) = T^T tau``
and the base translation is eliminated through the conserved linear momentum:

* ``M = M_rr - M_rt M_tt^-1 M_tr`` (Schur complement over translation), Eq. (9a);
* ``h = h_r - M_rt M_tt^-1 h_t`` = C(q, w) w, Eq. (8), so that ``M dw/dt + h = (0_3, u_m)``;
* ``H_bb, H_bm`` = angular rows of the centroidal momentum matrix (about the system CoM,
  inertial frame), Eq. (13): ``H_bb w_b + H_bm w_m = A_0`` (constant);
* ``J_b, J_m``: rows 1-3 ``d(p_e - p_com)/dt``, rows 4-6 the MRP rate of the end-effector
  attitude ``1/4 B(q_e) R_e^T w_e``, Eq. (3);
* ``L_b = 1/4 B(q_b) R_0^T`` (Eq. 1), ``v_0 = P / m``, ``A_0 = L`` about the CoM.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .._arrays import read_only
from ..attitude import mrp
from ._common import end_effector_at

_T = slice(0, 3)  # translational block of x
_R = slice(3, None)  # (w_b, dq_m)


def reaction_torque(M_bb, M_bb_dot, w_b, w_b_dot) -> np.ndarray:
    """Reaction torque of the manipulator on the base, Eqs. (6)-(7) [N m], 3-vector.

    ``F_r = M_bb dw_b/dt + C_bb w_b`` with ``C_bb w_b = 1/2 dM_bb/dt w_b + 1/2 w_b x (M_bb w_b)``:
    the Christoffel term of the arm's coordinates (as in the planar model) plus the
    gyroscopic term of the base rotation. For a frozen arm (w_m = dw_m/dt = 0) it is Euler's
    equation of the locked system, ``M_bb dw_b/dt + w_b x (M_bb w_b)``; for planar motion it
    reduces to the planar ``M_bb dw_b/dt + 1/2 dM_bb/dt w_b``.
    """
    M_bb = np.asarray(M_bb)
    w_b = np.asarray(w_b)
    return (
        M_bb @ np.asarray(w_b_dot)
        + 0.5 * (np.asarray(M_bb_dot) @ w_b)
        + 0.5 * (mrp.skew(w_b) @ (M_bb @ w_b))
    )


def fill_dynamics(st, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Set only ``st.M``, ``st.h`` (Eqs. 9a, 8), ``st.mass_matrix`` and
    ``st.nonlinear_effects`` for the plant state (q, v), and return R_0: what a controller
    that is given the true model needs each period
    (:meth:`ffsm_pin.model.state.State.update_dynamics`)."""
    model, data = st.model, st.data
    nv = model.nv
    R0 = _rotation(q)
    v_B, w_B = v[:3], v[3:6]

    M = pin.crba(model, data, q).copy()  # upper triangle filled
    M[st.lower_triangle] = M.T[st.lower_triangle]
    # T_dot x = (-w_B x v_B, 0, 0): d/dt (R_0^T p_dot) = R_0^T p_ddot - w_B x v_B
    a_corr = np.zeros(nv)
    a_corr[:3] = mrp.skew(v_B) @ w_B
    h = pin.rnea(model, data, q, v, a_corr).copy()  # M T_dot x + h, Pinocchio rows

    # x-coordinates: M_x = T^T M T, h_x = T^T h
    Mx = M.copy()
    Mx[:3] = R0 @ Mx[:3]
    Mx[3:6] = R0 @ Mx[3:6]
    Mx[:, :3] = Mx[:, :3] @ R0.T
    Mx[:, 3:6] = Mx[:, 3:6] @ R0.T
    hx = h.copy()
    hx[:3] = R0 @ hx[:3]
    hx[3:6] = R0 @ hx[3:6]
    # the translational block of M_x is m E_3 (linear momentum = m v_com): no solve needed
    sol = np.column_stack((Mx[_T, _R], hx[_T])) / st.total_mass
    st.mass_matrix = read_only(M)  # full CRBA matrix (nv x nv), Pinocchio velocities
    st.nonlinear_effects = read_only(h - M[:, :3] @ a_corr[:3])  # RNEA(q, v, 0) (nv)
    st.M = read_only(Mx[_R, _R] - Mx[_R, _T] @ sol[:, :-1])  # Eq. (9a)
    st.h = read_only(hx[_R] - Mx[_R, _T] @ sol[:, -1])  # C(q, w) w, Eq. (8)
    return R0


def _rotation(q: np.ndarray) -> np.ndarray:
    """R_0, base to inertial, from the base quaternion of q."""
    return pin.Quaternion(q[3:7]).normalized().toRotationMatrix()


def fill_kinematics(st, q: np.ndarray, v: np.ndarray, R0: np.ndarray | None = None) -> tuple:
    """Set only ``st.H_bb``, ``st.H_bm`` (Eq. 13), ``st.J_b`` and ``st.J_m`` (Eq. 3) for the
    plant state (q, v), the numbers :func:`fill` sets
    (:meth:`ffsm_pin.model.state.State.update_kinematics`); return what :func:`fill` goes on
    with: ``(R0, H, Ag, dAg, com, oMe, q_e, Jw)``, ``H = (H_bb, H_bm)``."""
    model, data = st.model, st.data
    nv = model.nv
    R0 = _rotation(q) if R0 is None else R0
    pin.dccrba(model, data, q, v)  # Ag and its time derivative dAg, about the CoM
    dAg = data.dAg.copy()
    Ag = data.Ag.copy()
    com = data.com[0].copy()
    J_ee, oMe = end_effector_at(model, data, q, st.ee_frame_id)

    # angular momentum rows about the CoM, in w = (w_b inertial, dq_m): Eq. (13)
    H = np.empty((3, nv - 3))
    H[:, :3] = Ag[3:6, 3:6] @ R0.T
    H[:, 3:] = Ag[3:6, 6:]
    st.H_bb = read_only(H[:, :3].copy())
    st.H_bm = read_only(H[:, 3:].copy())

    # Jacobians of (p_e - p_com, q_e) w.r.t. w; J_com = linear rows of Ag / m
    Jx = np.empty((6, nv - 3))
    Jd = J_ee[:3] - Ag[:3] / st.total_mass
    Jx[:3, :3] = Jd[:, 3:6] @ R0.T
    Jx[:3, 3:] = Jd[:, 6:]
    R_e = oMe.rotation
    q_e = mrp.from_rotation(R_e)
    Jw = np.empty((3, nv - 3))
    Jw[:, :3] = J_ee[3:6, 3:6] @ R0.T
    Jw[:, 3:] = J_ee[3:6, 6:]
    Jx[3:] = mrp.L_matrix(q_e, R_e) @ Jw  # Eq. (3), attitude rows
    st.J_b = read_only(Jx[:, :3].copy())
    st.J_m = read_only(Jx[:, 3:].copy())
    return R0, H, Ag, dAg, com, oMe, q_e, Jw


def fill(st, q: np.ndarray, v: np.ndarray) -> None:
    """Set every reduced quantity of ``st`` (a :class:`ffsm_pin.model.state.State`) for the
    plant state (q, v), already checked and stored as ``st.q``, ``st.v``."""
    nv = st.model.nv
    R0, H, Ag, dAg, com, oMe, q_e, Jw = fill_kinematics(st, q, v, fill_dynamics(st, q, v))
    v_B, w_B = v[:3], v[3:6]
    hg = Ag @ v  # centroidal momentum (P, L about the CoM)
    # dM_bb/dt from the time variation of the centroidal map:
    # d/dt (M_bb R_0) = dAg_bb  ->  dM_bb/dt = (dAg_bb - M_bb R_0 [w_B]x) R_0^T
    st.M_bb_dot = read_only((dAg[3:6, 3:6] - H[:, :3] @ R0 @ mrp.skew(w_B)) @ R0.T)
    st.centroidal_map = read_only(Ag)
    st.linear_momentum = read_only(hg[:3].copy())  # P, inertial [kg m/s]
    st.angular_momentum = read_only(hg[3:].copy())  # A_0 about the CoM [kg m^2/s]
    st.com_position = read_only(com)  # [m]
    st.com_velocity = read_only(st.linear_momentum / st.total_mass)  # v_0 [m/s]
    st.ee_angular_jacobian = read_only(Jw)  # w_e = Jw w, inertial [rad/s]

    st.base_rotation = read_only(R0)
    st.base_attitude = read_only(mrp.from_quaternion(q[3:7]))  # q_b, |q_b| <= 1
    st.L_b = read_only(mrp.L_matrix(st.base_attitude, R0))  # Eq. (1)
    st.ee_rotation = read_only(np.array(oMe.rotation))
    st.ee_pose = read_only(np.concatenate((oMe.translation, q_e)))  # z_e = (p_e, q_e)
    w = np.empty(nv - 3)
    w[:3] = R0 @ w_B
    w[3:] = v[6:]
    st.w = read_only(w)  # (w_b inertial, dq_m) [rad/s]
    st.base_velocity_world = read_only(R0 @ v_B)  # base origin velocity [m/s]
    # (v, w) of the base in the inertial frame [m/s, rad/s] (planar: base_twist_world)
    st.base_twist_world = read_only(np.concatenate((st.base_velocity_world, w[:3])))


def state_reaction_torque(st, w_dot: np.ndarray) -> np.ndarray:
    """F_r of Eq. (7), (3,) [N m], at the state's (q, v); see :func:`reaction_torque`."""
    return read_only(reaction_torque(st.H_bb, st.M_bb_dot, st.w[:3], w_dot[:3]))


def w_dot(st, a: np.ndarray) -> np.ndarray:
    """dw/dt = (R_0 dw_B/dt, ddq_m) from Pinocchio's acceleration ``a`` (docs/spatial.md
    section 1: the rotation term vanishes)."""
    return np.concatenate((st.base_rotation @ a[3:6], a[6:]))
