"""The spatial geometry's compiled (numba) kernels of the control period (m3 = 3, MRPs).

:func:`ffsm_pin.control.period.period` is the one compiled period of both geometries; for a
spatial robot (:class:`~ffsm_pin.model.spatial.SpatialKernelConstants`) it runs the three
steps here: :func:`geometry_terms` (rotations, regressors, Eqs. 28 and 42), :func:`kinematic_law`
(Eqs. 25+36 or 81, with the optional null-space term, at complex arguments) and
:func:`dynamic_level` (Eqs. 46, 49-52, 60-64). The readable reference is the numpy
implementation (:mod:`.controller`, :mod:`.kinematic`, :mod:`.adaptation`, :mod:`.manifold`,
:mod:`.null_space` on :class:`~ffsm_pin.model.spatial.SpatialBarycentricModel`); the test
suite checks that both give the same outputs and trajectories
(``tests/control/test_fast_spatial.py``).

* Regressors, M-hat and the Jacobians come from the compiled spatial kernels
  (:mod:`ffsm_pin.model._spatial_kinematics_kernels`,
  :mod:`~ffsm_pin.model._spatial_mass_kernels`,
  :mod:`~ffsm_pin.model._spatial_mass_tangent_kernels`,
  :mod:`~ffsm_pin.model._spatial_velocity_kernels`); the kinematic law is evaluated once with
  complex arguments ``x + i h dx/dt`` (the dtype-generic kinematics and Jacobian kernels; the
  momentum rows H_bb, H_bm carry the step in real (value, tangent) arithmetic,
  ``base_columns``), so that ``w_mc`` is the real part and the exact ``d w_mc/dt`` the
  imaginary part over h.
* Schemes ``ppc``, ``no-ppc``, ``no-attitude`` and ``known-model`` (``adaptive = False``:
  Pinocchio's M and C w passed in, no adaptation); tasks ``pose`` (6 rows) and
  ``position`` (3 rows); null-space objectives none, manipulability, joint-centering.

Status codes, the funnel and null-space bundles and the shared kernels: :mod:`.kernels`; the
bundles of the period (the law, the state, the outputs): :mod:`.period`.
"""

from __future__ import annotations

import numpy as np
from numba import njit, typeof, types

from .._array_kernels import (
    cmm,
    cmmt,
    cmtv,
    cmv,
    mm,
    mv,
    positive_definite,
    put,
    smallest_singular_value_above,
    solve,
    spd_solve,
    symmetric_solve_transposed,
)
from .._arrays import contiguous_rows as _rows
from .._docstrings import fill_doc
from .._symmetric_kernels import symmetric_eigen
from ..attitude._mrp_kernels import l_matrix
from ..model._spatial_kinematics_kernels import attitude_rows, kinematics, position_jacobian, y_z
from ..model._spatial_mass_kernels import add_ym, mass_matrix_by_sums, mass_times
from ..model._spatial_mass_tangent_kernels import base_columns, base_inertia_rate
from ..model._spatial_velocity_kernels import subtract_dT, velocity_terms
from . import kernels
from ._docs import CONTROL_DOC
from .physical import physical_increment
from .reference_kernels import reference_at

__all__ = [
    "base_velocity",
    "dynamic_level",
    "geometry_terms",
    "kinematic_law",
    "measured_kinematics",
    "reaction_rows",
    "reaction_rows_of",
    "task_geometry",
    "true_model_constants",
]


# ---------------------------------------------------------------------- kinematic level
@njit(cache=True, inline="always")
def measured_kinematics(jr, ax, q_b, q_m, w):
    """(R (n+1, 3, 3), z (n, 3), dq_b/dt of Eq. 1) at the real measurement (q_b, q_m, w): the
    body rotations, the inertial joint axes and the base attitude's MRP rate.

    Parameters
    ----------
    jr, ax : ndarray
        The spatial model's joint rotations and axes (``SpatialKernelConstants``).
    q_b, q_m, w : ndarray
        Base MRP (3,), joint angles (n,) [rad], (w_b inertial, dq_m) (n + 3,) [rad/s].
    """
    n = q_m.size
    R = np.empty((n + 1, 3, 3))
    z = np.empty((n, 3))
    kinematics(q_b, q_m, jr, ax, R, z)
    q_b_rate = np.ascontiguousarray(l_matrix(q_b, R[0]).real) @ w[:3]  # Eq. (1)
    return R, z, q_b_rate


@njit(cache=True)
def task_geometry(jr, ax, er, m, nt, q_b, q_m, theta_z, theta_d):
    """(J (nt, n+3) of Eq. 3 for theta_z, H_bb (3x3), H_bm (3xn) of Eq. 13 for theta_d, R_0)
    at complex arguments.

    Parameters
    ----------
    jr, ax, er, m : ndarray or int
        The fields of :class:`~ffsm_pin.model.spatial.SpatialKernelConstants`.
    nt : int
        Task rows.
    q_b : ndarray, shape (3,)
        Base attitude (MRP); complex.
    q_m : ndarray, shape (n,)
        Joint angles [rad]; complex.
    theta_z, theta_d : ndarray
        Kinematic and dynamic parameters.
    """
    n = q_m.size
    nb = n + 1
    R = np.empty((nb, 3, 3), dtype=np.complex128)
    z = np.empty((n, 3), dtype=np.complex128)
    kinematics(q_b, q_m, jr, ax, R, z)
    V = np.empty((nb, 3), dtype=np.complex128)
    for k in range(nb):
        for i in range(3):
            V[k, i] = theta_z[3 + 3 * k + i]
    J = np.empty((nt, n + 3), dtype=np.complex128)
    position_jacobian(R, z, V, J[:3])
    if nt > 3:
        attitude_rows(R[m], er, z, m, J[3:6])
    Mc = np.empty((n + 3, 3), dtype=np.complex128)
    base_columns(R, z, theta_d, Mc)  # M's base columns, the step's tangent in real arithmetic
    Hbb = np.ascontiguousarray(Mc[:3].T)
    Hbm = np.ascontiguousarray(Mc[3:].T)
    return J, Hbb, Hbm, R[0].copy()


@njit(cache=True)
def _projector(Hbm):
    """(H_bm^+ = H^T (H H^T)^-1, U = E - H^+ H, smallest singular value of Re H)."""
    n = Hbm.shape[1]
    HH = cmmt(Hbm, Hbm)
    hnorm = np.sqrt(max(symmetric_eigen(HH.real)[0][0], 0.0))
    if not hnorm > 1e-9:
        return np.zeros((n, 3), dtype=np.complex128), np.zeros((n, n), dtype=np.complex128), hnorm
    Hp = symmetric_solve_transposed(HH, Hbm)  # (HH^-1 H)^T = H^T HH^-1
    U = -cmm(Hp, Hbm)
    for i in range(n):
        U[i, i] += 1.0
    return Hp, U, hnorm


@njit(cache=True)
def _reduced_jacobian(jr, ax, er, m, nt, q_b, q_m, theta_b, theta_z):
    """A = J_m-hat U-hat of Eq. (36) at (q_b, q_m), complex."""
    J, _, Hbm, _ = task_geometry(jr, ax, er, m, nt, q_b, q_m, theta_z, theta_b[3:])
    _, U, _ = _projector(Hbm)
    return cmm(np.ascontiguousarray(J[:, 3:]), U)


@njit(cache=True)
def _null_space_gradient(jr, ax, er, m, nt, ns, q_b, q_m, theta_b, theta_z):
    """The spatial geometry's part of :func:`.kernels.objective_gradient`, complex."""
    Q = kernels.objective_points(ns, q_m)
    A = np.empty((Q.shape[0], nt, q_m.size), dtype=np.complex128)
    for i in range(Q.shape[0]):
        A[i] = _reduced_jacobian(jr, ax, er, m, nt, q_b, Q[i], theta_b, theta_z)
    return kernels.objective_gradient(ns, q_m, A)


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def kinematic_law(geo, law, ref, ns, t, q_b, q_m, z_e, theta_b, theta_z, w_b):
    """w_mc of Eqs. (25)+(36) or (81) at complex arguments (:func:`.period.kinematic_law`);
    returns (w_mc, d w_mc/d w_b, sigma_min, damping, |H_bm|, err_b, err_z, status, exit index).
    ``geo`` the model's :class:`~ffsm_pin.model.spatial.SpatialKernelConstants`, ``law`` the
    :class:`~.period.PeriodLaw`, ``ns`` its ``null_space``.

    %(params_kinematic_law)s
    """
    jr, ax, er, m = geo
    nt, g = law.n_task, law.gains
    n = q_m.size
    z_d = reference_at(ref, t, False)
    err_z = np.empty(nt, dtype=np.complex128)
    for i in range(nt):
        err_z[i] = z_e[i] - z_d[i]  # Eq. (17)
    err_b = np.empty(3, dtype=np.complex128)
    for i in range(3):
        err_b[i] = q_b[i] - law.q_bd[i]  # Eq. (16), MRP components
    w_mc = np.zeros(n, dtype=np.complex128)
    sens = np.zeros((n, 3))
    psi_z, Phi_z, iz = kernels.funnel_terms(law.funnel_z, t, err_z, law.identity)
    if iz >= 0:
        return w_mc, sens, 0.0, 0.0, 0.0, err_b, err_z, kernels.STATUS_FUNNEL_Z, iz
    J, Hbb, Hbm, R0 = task_geometry(jr, ax, er, m, nt, q_b, q_m, theta_z, theta_b[3:])
    Jb = np.ascontiguousarray(J[:, :3])
    Jm = np.ascontiguousarray(J[:, 3:])
    target = reference_at(ref, t, True) - g.k_z * Phi_z * psi_z
    for i in range(3):
        target[i] -= theta_z[i]  # -v0bar-hat
    if not law.attitude:  # Eq. (81)
        pinv, sigma, damping = kernels.damped_pinv(Jm, law.threshold)
        w_mc = cmv(pinv, target - cmv(Jb, w_b))
        sens = np.ascontiguousarray(-cmm(pinv, Jb).real)
        return w_mc, sens, sigma, damping, 0.0, err_b, err_z, kernels.STATUS_OK, -1
    psi_b, Phi_b, ib = kernels.funnel_terms(law.funnel_b, t, err_b, law.identity)
    if ib >= 0:
        return w_mc, sens, 0.0, 0.0, 0.0, err_b, err_z, kernels.STATUS_FUNNEL_B, ib
    Hp, U, hnorm = _projector(Hbm)
    if not hnorm > 1e-9:
        return w_mc, sens, 0.0, 0.0, hnorm, err_b, err_z, kernels.STATUS_H_COLLAPSE, -1
    L_b = l_matrix(q_b, R0)
    a_b = theta_b[:3] + g.k_b * cmv(Hbb, cmtv(L_b, Phi_b * psi_b))  # Eq. (25)
    A = cmm(Jm, U)
    pinv, sigma, damping = kernels.damped_pinv(A, law.threshold)
    Hp_ab = cmv(Hp, a_b)
    xi = cmv(pinv, target - cmv(Jm, Hp_ab))  # Eq. (36)
    if ns is not None:  # beyond the paper: xi_n = (E - A^+ A) k_s grad mu
        # (ns None, no null-space term: numba compiles none of this)
        grad = _null_space_gradient(jr, ax, er, m, nt, ns, q_b, q_m, theta_b, theta_z)
        xi = xi + ns.gain * (grad - cmv(pinv, cmv(A, grad)))
    w_mc = Hp_ab + cmv(U, xi)  # Eq. (25)
    return w_mc, sens, sigma, damping, hnorm, err_b, err_z, kernels.STATUS_OK, -1


# ---------------------------------------------------------------------- one period
@njit(cache=True)
@fill_doc(CONTROL_DOC)
def theta_b_step(theta_b, Yb, gamma_1, dt):
    """Eq. (28) by its exact zero-order hold, exp(-g dt Y^T Y) through the 3x3 G = Y Y^T
    (as :func:`ffsm_pin.control.adaptation.theta_b_step`); ``Yb`` (3, nd + 3) holds the base
    rows of Y_M(w) in its columns 3: (the first three are set to -E_3 here).

    Parameters
    ----------
    theta_b : ndarray
        theta_b-hat at t.
    Yb : ndarray
        The base rows of Y_M(w), in its columns 3:.
    %(gain_dt)s
    """
    for i in range(3):
        for j in range(3):
            Yb[i, j] = -1.0 if i == j else 0.0
    G = np.zeros((3, 3))  # G = Y Y^T and y = Y theta_b in one pass over the columns
    y0 = y1 = y2 = 0.0
    for j in range(theta_b.size):
        a0, a1, a2, t = Yb[0, j], Yb[1, j], Yb[2, j], theta_b[j]
        G[0, 0] += a0 * a0
        G[0, 1] += a0 * a1
        G[0, 2] += a0 * a2
        G[1, 1] += a1 * a1
        G[1, 2] += a1 * a2
        G[2, 2] += a2 * a2
        y0 += a0 * t
        y1 += a1 * t
        y2 += a2 * t
    lam, V = symmetric_eigen(G)  # (its upper triangle)
    c = np.empty(3)
    for i in range(3):  # f(lam) V^T y
        f = -np.expm1(-gamma_1 * dt * lam[i]) / lam[i] if lam[i] > 0 else gamma_1 * dt
        c[i] = f * (V[0, i] * y0 + V[1, i] * y1 + V[2, i] * y2)
    c0 = V[0, 0] * c[0] + V[0, 1] * c[1] + V[0, 2] * c[2]
    c1 = V[1, 0] * c[0] + V[1, 1] * c[1] + V[1, 2] * c[2]
    c2 = V[2, 0] * c[0] + V[2, 1] * c[1] + V[2, 2] * c[2]
    out = np.empty(theta_b.size)
    for j in range(theta_b.size):  # theta_b - Y^T V f V^T Y theta_b
        out[j] = theta_b[j] - (Yb[0, j] * c0 + Yb[1, j] * c1 + Yb[2, j] * c2)
    return out


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def geometry_terms(geo, law, dt, meas, state):
    """The body rotations and joint axes, the regressors of the dynamic level and Eqs. (28),
    (42) over the period (:func:`.period.geometry_terms`; the estimates unchanged when
    ``law.adaptive`` is False), and dq_b/dt of Eq. (1).

    %(params_geometry_terms)s
    """
    jr, ax, er, m = geo
    q_b, q_m, w, w_hat = meas.q_b, meas.q_m, meas.w, state.w_hat
    theta_b, theta_z, theta_d = state.theta_b, state.theta_z, state.theta_d
    n = q_m.size
    N = n + 3
    nd = theta_d.size
    nz = theta_z.size
    R, z, q_b_rate = measured_kinematics(jr, ax, q_b, q_m, w)
    tb_new = theta_b.copy()
    tz_new = theta_z.copy()
    Yc = np.empty((N, nd))
    w_tilde = np.zeros(N)
    if law.adaptive:
        g = law.gains
        w_tilde = w - w_hat
        Yb = np.empty((3, nd + 3))
        # Y_c with Y_c theta_d = dM/dt w-hat - dT/dq: Y_Mdot(w, w~) - Y_h(w) = -Y_c, one
        # regressor where there were two (Y_h(w) is Y_Mdot(w, w) less the dT/dq rows)
        velocity_terms(R, z, w, w, w_hat, None, Yc, None, Yb[:, 3:])
        subtract_dT(R, z, w, Yc)
        tb_new = theta_b_step(theta_b, Yb, g.gamma_1, dt)
        Yz = np.empty((3, nz))
        y_z(R, z, w, Yz)
        tz_new = kernels.theta_z_step(theta_z, Yz, meas.z_e_dot, g.gamma_2, dt)  # Eq. (42)
    return (R, z, Yc, w_tilde), tb_new, tz_new, q_b_rate, w[:3]


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def dynamic_level(geo, terms, law, dt, meas, w_mc, w_mc_dot, sens, state):
    """Eqs. (46), (50)-(52), (60)-(64) with 3x3 base rows (:func:`.period.dynamic_level`):
    returns (status, exit value, u_m, w_mc_dot + sens dw_b/dt, w~, e) and, when the status is
    ``STATUS_OK``, advances theta_d-hat, w-hat and Y_df of ``state`` in place. ``meas.M``,
    ``meas.h``: Pinocchio's reduced M and C w (known-model scheme, ``law.adaptive`` False;
    not read otherwise). ``law.theta_d_true``: the true theta_d for the diagnostic e of
    Eq. (54), never read by the law; empty: e is not computed (an empty ``e``).

    %(params_dynamic_level)s
    """
    R, z, Yc, w_tilde = terms
    g, adaptive, w = law.gains, law.adaptive, meas.w
    M_true, h_true, theta_d_true = meas.M, meas.h, law.theta_d_true
    theta_d, w_hat, Y_df = state.theta_d, state.w_hat, state.Y_df
    n = w_mc.size
    N = n + 3
    nd = theta_d.size
    none = np.empty(0)
    if adaptive:
        M_hat = np.empty((N, N))
        mass_matrix_by_sums(R, z, theta_d, M_hat)
        if not positive_definite(M_hat):
            return kernels.STATUS_M_NOT_PD, 0.0, none, none, none, none
        cg = g.gamma_3 * dt  # Eq. (51), linearly implicit; projected if physical (physical.py)
        Mw = mv(M_hat, w_tilde)
        d_theta_d = -cg * (Y_df.T @ spd_solve(M_hat + cg * (Y_df @ Y_df.T), Mw))
        d_theta_d, physical = physical_increment(law.physical, theta_d, d_theta_d)
        if not physical:
            return kernels.STATUS_NOT_PHYSICAL, 0.0, none, none, none, none
        eta_x = -(Y_df @ d_theta_d) / dt  # Eq. (52)
        rr = g.k_de * Mw + eta_x - Yc @ theta_d  # (Y_Mdot(w, w~) - Y_h(w)) theta_d + ...
        wh = w_hat
    else:  # known model: computed torque on the true reduced dynamics
        M_hat = np.ascontiguousarray(M_true)
        rr = -h_true
        wh = w
        d_theta_d = np.zeros(nd)
    tgt = w_mc_dot - g.k_d * (wh[3:] - w_mc)  # Eqs. (60a), (64)-(65), base rows 3x3
    Mbb = np.ascontiguousarray(M_hat[:3, :3])
    Mbm = np.ascontiguousarray(M_hat[:3, 3:])
    denom = Mbb + mm(Mbm, sens)
    regular, smallest = smallest_singular_value_above(denom, 1e-12 * np.max(np.abs(Mbb)))
    if not regular:
        return kernels.STATUS_BASE_ROW, smallest, none, none, none, none
    wb_dot = solve(denom, rr[:3] - mv(Mbm, tgt))
    w_hat_dot = np.empty(N)
    put(w_hat_dot, 0, wb_dot)  # (loops instead of slice assignments: see put)
    sens_wb = mv(sens, wb_dot)
    put(w_hat_dot, 3, tgt + sens_wb)
    u_m = mv(M_hat[3:], w_hat_dot) - rr[3:]
    if not np.all(np.isfinite(u_m)):
        return kernels.STATUS_NONFINITE, 0.0, none, none, none, none
    e = none  # Eq. (54) with the true M and theta_d, before the estimates advance
    if theta_d_true.size:
        if adaptive:  # M w~ without forming the true M
            Mw_true = np.empty(N)
            mass_times(R, z, theta_d_true, w_tilde, Mw_true)
            e = Mw_true + Y_df @ (theta_d_true - theta_d)
        else:  # w~ = 0, Y_df = 0 and theta_d-hat = theta_d
            e = np.zeros(N)
    if adaptive:  # advance the controller's states to t + dt
        # Eq. (49)'s Y_dc = Y_M(dw-hat/dt - k_de w~) - Y_Mdot(w, w~) + Y_h(w) = Y_M(.) + Y_c,
        # Y_M added into Y_c in place
        add_ym(R, z, w_hat_dot - g.k_de * w_tilde, Yc, False)
        decay = np.exp(-g.k_de * dt)
        gain = -np.expm1(-g.k_de * dt) / g.k_de
        kernels.filter_input_update(Y_df, decay, gain, Yc)  # Eq. (50)
        theta_d += d_theta_d  # Eq. (51)
        w_hat += dt * w_hat_dot  # Eq. (46)
    else:
        put(w_hat, 0, w + dt * w_hat_dot)
    return kernels.STATUS_OK, 0.0, u_m, w_mc_dot + sens_wb, w_tilde, e


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def base_inertia(jr, ax, q_b, q_m, w, theta_d):
    """(M_bb, dM_bb/dt) of the true model, the base block of M alone; dM_bb/dt along the motion
    w in real arithmetic (:func:`~ffsm_pin.model._spatial_mass_tangent_kernels.base_inertia_rate`).

    Parameters
    ----------
    jr, ax : ndarray
        Joint rotations (n, 3, 3) and axes (n, 3), as in ``SpatialKernelConstants``.
    q_b : ndarray, shape (3,)
        Base attitude (MRP).
    q_m : ndarray, shape (n,)
        Joint angles [rad].
    w : ndarray, shape (n + 3,)
        (w_b, w_m) [rad/s].
    %(theta_d_true)s
    """
    n = q_m.size
    R = np.empty((n + 1, 3, 3))
    z = np.empty((n, 3))
    kinematics(q_b, q_m, jr, ax, R, z)
    M = np.empty((3, 3))
    M_dot = np.empty((3, 3))
    base_inertia_rate(R, z, w, theta_d, M, M_dot)
    return M, M_dot


@njit(cache=True, nogil=True)  # rows in two threads: control/diagnostics.rows_beside
@fill_doc(CONTROL_DOC)
def reaction_rows(jr, ax, q_b, q_m, w, dw_b, theta_d):
    """F_r of Eq. (7) on recorded rows, after a run: ``M_bb dw_b/dt + 1/2 dM_bb/dt w_b +
    1/2 w_b x (M_bb w_b)`` (as :func:`ffsm_pin.model._state_spatial.reaction_torque`) with
    (M_bb, dM_bb/dt) of :func:`base_inertia`; q_b (N, 3), q_m (N, n), w (N, n + 3), dw_b (N, 3)
    the base's angular acceleration in the inertial frame.

    Parameters
    ----------
    jr, ax : ndarray
        Joint rotations (n, 3, 3) and axes (n, 3), as in ``SpatialKernelConstants``.
    %(rows)s
    %(theta_d_true)s
    """
    N = q_b.shape[0]
    out = np.empty((N, 3))
    for i in range(N):
        M, Md = base_inertia(jr, ax, q_b[i], q_m[i], w[i], theta_d)
        wb = w[i, :3].copy()
        sk = np.array([[0.0 * wb[0], -wb[2], wb[1]], [wb[2], 0.0 * wb[0], -wb[0]],
                       [-wb[1], wb[0], 0.0 * wb[0]]])  # fmt: skip
        out[i] = M @ dw_b[i].copy() + 0.5 * (Md @ wb) + 0.5 * (sk @ (M @ wb))
    return out


def base_velocity(w):
    """w_b, the base's part of w = (w_b, w_m) as the period passes it: (3,) [rad/s]."""
    return w[:3]


def true_model_constants(geo) -> tuple:
    """The constant arguments :func:`reaction_rows` takes first."""
    return geo.joint_rot, geo.axes


@fill_doc(CONTROL_DOC)
def reaction_rows_of(q_b, q_m, w, dw_b) -> tuple:
    """The recorded rows q_b (N, 3), q_m, w, dw_b (N, 3) as :func:`reaction_rows` takes them
    (contiguous).

    %(sections_reaction_rows_of)s
    """
    return _rows(q_b, q_m, w, dw_b)


def compile_beside_law(meas, state) -> None:
    """On a first run, before the kinematic law: compile the dynamic level's two largest real
    kernels, the estimated mass matrix and Y_M of Eq. (49) (about 2.7 s), with the argument
    types :func:`dynamic_level` passes (the values do not matter: zeros), so that the second
    process, which compiles the period's real kernels meanwhile, loads them from the cache
    (:func:`.period.compile_in_parallel`): the two processes then finish about together.

    Parameters
    ----------
    meas : Measurement
        The run's measurement (its shapes).
    state : PeriodState
        The period's state (its shapes).
    """
    n, nd = meas.q_m.size, state.theta_d.size
    R, z, M = np.zeros((n + 1, 3, 3)), np.zeros((n, 3)), np.zeros((n + 3, n + 3))
    mass_matrix_by_sums(R, z, np.zeros(nd), M)
    a, Y = np.zeros(n + 3), np.zeros((n + 3, nd))  # add_ym(..., False): a literal in the period
    add_ym.compile((typeof(R), typeof(z), typeof(a), typeof(Y), types.literal(False)))
