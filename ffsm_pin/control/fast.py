"""The planar geometry's compiled (numba) kernels of the control period.

:func:`ffsm_pin.control.period.period` is the one compiled period of both geometries; for a
planar robot (:class:`~ffsm_pin.model.planar.PlanarKernelConstants`) it runs the three steps
here: :func:`geometry_terms` (the body angles' trigonometry, Eqs. 28 and 42),
:func:`kinematic_law` (Eqs. 25+36 or 81, complex-step safe) and :func:`dynamic_level`
(Eqs. 46, 49-52, 60-64). The readable reference is the numpy implementation
(:mod:`ffsm_pin.model.planar`, :mod:`.funnel`, :mod:`.kinematic`, :mod:`.adaptation`,
:mod:`.manifold`, :mod:`.controller`); a period is a few hundred operations on 5-vectors where
interpreter overhead dominates (about 300 us in numpy, see ``benchmarks/bench_closed_loop.py``).
The test suite checks that both give the same trajectory (``tests/control/test_fast.py``).
Also here: the run's reaction torque on the true model (:func:`reaction_rows`); the
diagnostic e of Eq. (54) is computed in :func:`dynamic_level`.

Layout conventions are those of :class:`~ffsm_pin.model.planar.BarycentricModel`:
theta_d = (Dc_kk, Dc_kl (k<l), [Ds_kl (k<l)]), theta_z = (v_0, V_0..V_n) with scalar or
2-vector V_k. Status codes: ``STATUS_*`` of :mod:`.kernels`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._array_kernels import difference, gram, mm, mv, positive_definite, put, spd_solve
from .._arrays import contiguous_rows as _rows
from .._docstrings import fill_doc
from ..model._planar_kernels import (
    column_sums,
    jacobian,
    mass_matrix,
    mass_phi,
    position_regressor,
    trig,
    velocity_regressors,
    xm,
    y_m,
)
from . import kernels
from ._docs import CONTROL_DOC
from .physical import physical_increment
from .reference_kernels import reference_at


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def kinematic_law(geo, law, ref, ns, t, q_b, q_m, z_e, theta_b, theta_z, w_b):
    """w_mc of Eqs. (25)+(36) or (81) (complex-step safe; :func:`.period.kinematic_law`);
    ``geo`` the model's :class:`~ffsm_pin.model.planar.PlanarKernelConstants`, ``law`` the
    :class:`~.period.PeriodLaw` (its ``n_task``: 3 the pose task, 2 the position task),
    ``ns`` its ``null_space``.

    %(params_kinematic_law)s
    """
    S, off, K, L, ee_row, collinear = geo
    nt, g = law.n_task, law.gains
    nb = S.shape[0]
    n = nb - 1
    c, s, pc, ps = trig(S, off, K, L, q_b, q_m)
    z_d = reference_at(ref, t, False)
    err_z = np.empty(nt, dtype=z_e.dtype)
    for i in range(nt):
        err_z[i] = z_e[i] - z_d[i]  # Eq. (17): the task's components of z_e
    if nt > 2:  # the end-effector angle
        err_z[2] = kernels.wrap_angle(err_z[2])
    err_b = np.empty(1, dtype=err_z.dtype)
    err_b[0] = kernels.wrap_angle(q_b - law.q_bd[0])
    psi_z, Phi_z, iz = kernels.funnel_terms(law.funnel_z, t, err_z, law.identity)
    w_mc = np.zeros(n, dtype=err_z.dtype)
    sens = np.zeros(n)
    if iz >= 0:
        return w_mc, sens, 0.0, 0.0, 0.0, err_b, err_z, kernels.STATUS_FUNNEL_Z, iz
    J = jacobian(theta_z, c, s, S, ee_row, collinear)[:nt]  # the task's rows
    Jm = np.ascontiguousarray(J[:, 1:])
    target = reference_at(ref, t, True) - g.k_z * Phi_z * psi_z
    target[0] -= theta_z[0]
    target[1] -= theta_z[1]
    if not law.attitude:  # Eq. (81)
        pinv, sigma, damping = kernels.damped_pinv(Jm, law.threshold)
        Jb = J[:, 0].copy()
        w_mc = mv(pinv, target - Jb * w_b)
        sens = -mv(pinv, Jb).real
        return w_mc, sens, sigma, damping, 0.0, err_b, err_z, kernels.STATUS_OK, -1
    psi_b, Phi_b, ib = kernels.funnel_terms(law.funnel_b, t, err_b, law.identity)
    if ib >= 0:
        return w_mc, sens, 0.0, 0.0, 0.0, err_b, err_z, kernels.STATUS_FUNNEL_B, ib
    Mphi = mass_phi(theta_b[1:], pc, ps, K, L, nb, collinear)
    row = xm(column_sums(Mphi).reshape(1, nb), S)[0]  # first row of S^T M_phi S: (H_bb, H_bm)
    Hbm = row[1:].copy()
    hh = (Hbm * Hbm).sum()
    hnorm = np.sqrt(hh.real)
    if not hnorm > 1e-9:
        return w_mc, sens, 0.0, 0.0, hnorm, err_b, err_z, kernels.STATUS_H_COLLAPSE, -1
    a_b = theta_b[0] + g.k_b * row[0] * Phi_b[0] * psi_b[0]  # Eq. (25)
    Hp = Hbm / hh  # pseudo-inverse of the row H_bm
    U = _eye_minus_outer(Hp, Hbm)
    A = mm(Jm, U)
    pinv, sigma, damping = kernels.damped_pinv(A, law.threshold)
    Hp_ab = Hp * a_b
    xi = mv(pinv, target - mv(Jm, Hp_ab))  # Eq. (36)
    if ns is not None:  # beyond the paper: xi_n = (E - A^+ A) k_s grad mu (null_space.py)
        # (ns None, no null-space term: numba compiles none of this)
        grad = _null_space_gradient(S, off, K, L, ee_row, collinear, nt, ns,
                                    q_b, q_m, theta_b, theta_z)  # fmt: skip
        xi = xi + ns.gain * (grad - pinv @ (A @ grad))
    w_mc = Hp_ab + mv(U, xi)  # Eq. (25)
    return w_mc, sens, sigma, damping, hnorm, err_b, err_z, kernels.STATUS_OK, -1


@njit(cache=True)
def _eye_minus_outer(x, y):
    """``np.eye(n) - np.outer(x, y)`` by loops: the same values (each entry the same one
    product and one subtraction), without compiling numba's ``np.eye`` and ``np.outer``
    (about 0.7 s of the complex kinematic law, a first run's critical path)."""
    n = x.size
    U = np.empty((n, n), dtype=x.dtype)
    for i in range(n):
        for j in range(n):
            e = 1.0 if i == j else 0.0
            U[i, j] = e - x[i] * y[j]
    return U


@njit(cache=True)
def _reduced_jacobian(S, off, K, L, ee_row, collinear, nt, q_b, q_m, theta_b, theta_z):
    """A = J_m-hat U-hat of Eq. (36) at (q_b, q_m) (complex-step safe)."""
    nb = S.shape[0]
    n = nb - 1
    c, s, pc, ps = trig(S, off, K, L, q_b, q_m)
    J = jacobian(theta_z, c, s, S, ee_row, collinear)[:nt]
    Mphi = mass_phi(theta_b[1:], pc, ps, K, L, nb, collinear)
    row = xm(column_sums(Mphi).reshape(1, nb), S)[0]
    Hbm = row[1:].copy()
    U = np.eye(n) - np.outer(Hbm / (Hbm * Hbm).sum(), Hbm)
    return np.ascontiguousarray(J[:, 1:]) @ U


@njit(cache=True)
def _null_space_gradient(S, off, K, L, ee_row, collinear, nt, ns, q_b, q_m, theta_b, theta_z):
    """grad_{q_m} mu of the null-space objective, planar (:func:`_reduced_jacobian`)."""
    Q = kernels.objective_points(ns, q_m)
    A = np.empty((Q.shape[0], nt, q_m.size), dtype=np.complex128)
    for i in range(Q.shape[0]):
        A[i] = _reduced_jacobian(S, off, K, L, ee_row, collinear, nt, q_b, Q[i], theta_b, theta_z)
    return kernels.objective_gradient(ns, q_m, A)


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def theta_b_step(theta_b, Yb, gamma_1, dt):
    """Eq. (28) by its exact zero-order hold for the rank-one planar Y_b = [-1, Yb] (``Yb`` the
    base row of Y_M(w)), as :func:`ffsm_pin.control.adaptation.theta_b_step`.

    Parameters
    ----------
    theta_b : ndarray
        theta_b-hat at t.
    Yb : ndarray
        The base row of Y_M(w).
    %(gain_dt)s
    """
    yy = 1.0 + (Yb * Yb).sum()
    yth = -theta_b[0] + (Yb * theta_b[1:]).sum()
    fac = -np.expm1(-gamma_1 * dt * yy) / yy * yth
    tb_new = theta_b.copy()
    tb_new[0] += fac
    for i in range(Yb.size):  # tb_new[1:] -= fac * Yb, without numba's shape-message code
        tb_new[1 + i] -= fac * Yb[i]
    return tb_new


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def geometry_terms(geo, law, dt, meas, state):
    """The body angles' trigonometry and Eqs. (28), (42) over the period
    (:func:`.period.geometry_terms`; the estimates unchanged when ``law.adaptive`` is False,
    the known-model scheme). ``state.w_hat`` is not read.

    %(params_geometry_terms)s
    """
    S, off, K, L, ee_row, collinear = geo
    q_b, q_m, w = meas.q_b, meas.q_m, meas.w
    theta_b, theta_z = state.theta_b, state.theta_z
    nd = state.theta_d.size
    c, s, pc, ps = trig(S, off, K, L, q_b, q_m)
    if not law.adaptive:  # known model: no adaptation
        return (pc, ps), theta_b.copy(), theta_z.copy(), w[0], w[0]
    g = law.gains
    tb_new = theta_b_step(theta_b, y_m(pc, ps, K, L, S, w, nd, collinear)[0], g.gamma_1, dt)
    Yz = position_regressor(c, s, S, w, theta_z.size, collinear)
    tz_new = kernels.theta_z_step(theta_z, Yz, meas.z_e_dot, g.gamma_2, dt)  # Eq. (42)
    return (pc, ps), tb_new, tz_new, w[0], w[0]


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def dynamic_level(geo, terms, law, dt, meas, w_mc, w_mc_dot, sens, state):
    """The dynamic level (Eqs. 46, 49-52, 60a, 64-65; :func:`.period.dynamic_level`): returns
    (status, exit value, u_m, w_mc_dot + sens dw_b/dt, w~, e) and, when the status is
    ``STATUS_OK``, advances theta_d-hat, w-hat and Y_df of ``state`` in place. ``terms`` those
    of :func:`geometry_terms`. ``meas.M``, ``meas.h``: Pinocchio's reduced M and C w
    (known-model scheme, ``law.adaptive`` False: computed torque on the true dynamics; not
    read otherwise). ``law.theta_d_true``: the true theta_d for the diagnostic e of Eq. (54),
    never read by the law; empty: e is not computed (an empty ``e``).

    %(params_dynamic_level)s
    """
    S, off, K, L, ee_row, collinear = geo
    pc, ps = terms
    g, adaptive, w = law.gains, law.adaptive, meas.w
    M_true, h_true, theta_d_true = meas.M, meas.h, law.theta_d_true
    theta_d, w_hat, Y_df = state.theta_d, state.w_hat, state.Y_df
    nb = S.shape[0]
    nd = theta_d.size
    none = np.empty(0)
    if not adaptive:  # known model: no filter estimate, no adaptation
        status, value, w_hat_dot, u_m = _manifold(
            np.ascontiguousarray(M_true), -h_true, w, w_mc, w_mc_dot, sens, g.k_d
        )
        if status != kernels.STATUS_OK:
            return status, value, none, none, none, none
        put(w_hat, 0, w + dt * w_hat_dot)
        e = np.zeros(nb if theta_d_true.size else 0)  # w~ = 0, Y_df = 0, theta_d-hat = theta_d
        return kernels.STATUS_OK, 0.0, u_m, w_mc_dot + sens * w_hat_dot[0], np.zeros(nb), e
    w_tilde = w - w_hat
    M_hat = mass_matrix(theta_d, pc, ps, K, L, S, collinear)
    if not positive_definite(M_hat):
        return kernels.STATUS_M_NOT_PD, 0.0, none, none, none, none
    Ymd, Yh = velocity_regressors(pc, ps, K, L, S, w, w_tilde, nd, collinear)
    cg = g.gamma_3 * dt
    Mw = mv(M_hat, w_tilde)
    d_theta_d = -cg * mv(Y_df.T, spd_solve(M_hat + cg * gram(Y_df), Mw))
    d_theta_d, physical = physical_increment(law.physical, theta_d, d_theta_d)  # physical.py
    if not physical:
        return kernels.STATUS_NOT_PHYSICAL, 0.0, none, none, none, none
    eta_x = -mv(Y_df, d_theta_d) / dt  # Eq. (52)
    rr = mv(difference(Ymd, Yh), theta_d) + g.k_de * Mw + eta_x
    status, value, w_hat_dot, u_m = _manifold(M_hat, rr, w_hat, w_mc, w_mc_dot, sens, g.k_d)
    if status != kernels.STATUS_OK:
        return status, value, none, none, none, none
    e = none  # Eq. (54) with the true M and theta_d, before the estimates advance
    if theta_d_true.size:
        M = mass_matrix(theta_d_true, pc, ps, K, L, S, collinear)
        e = mv(M, w_tilde) + mv(Y_df, theta_d_true - theta_d)
    # Eq. (49)-(50): filtered regressor; Eq. (51); Eq. (46)
    YM = y_m(pc, ps, K, L, S, w_hat_dot - g.k_de * w_tilde, nd, collinear)
    decay = np.exp(-g.k_de * dt)
    kernels.filter_regressor_update(Y_df, decay, -np.expm1(-g.k_de * dt) / g.k_de, YM, Ymd, Yh)
    theta_d += d_theta_d
    w_hat += dt * w_hat_dot
    return kernels.STATUS_OK, 0.0, u_m, w_mc_dot + sens * w_hat_dot[0], w_tilde, e


@njit(cache=True)
def _manifold(M_hat, rr, wh, w_mc, w_mc_dot, sens, k_d):
    """Eqs. (60a), (64)-(65) with the scalar base row (:func:`.manifold.manifold_input`):
    (status, exit value, dw-hat/dt, u_m) for the filter's M-hat, right-hand side ``rr`` and
    state ``wh`` (w-hat; the measured w for the known model)."""
    nb = M_hat.shape[0]
    none = np.empty(0)
    tgt = w_mc_dot - k_d * (wh[1:] - w_mc)
    denom = M_hat[0, 0] + (M_hat[0, 1:] * sens).sum()
    if not abs(denom) > 1e-12 * abs(M_hat[0, 0]):
        return kernels.STATUS_BASE_ROW, abs(denom), none, none
    wb_dot = (rr[0] - (M_hat[0, 1:] * tgt).sum()) / denom
    w_hat_dot = np.empty(nb)
    w_hat_dot[0] = wb_dot
    put(w_hat_dot, 1, tgt + sens * wb_dot)
    u_m = mv(M_hat[1:], w_hat_dot) - rr[1:]
    if not np.all(np.isfinite(u_m)):
        return kernels.STATUS_NONFINITE, 0.0, none, none
    return kernels.STATUS_OK, 0.0, w_hat_dot, u_m


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def base_inertia(S, off, K, L, collinear, q_b, q_m, w, theta_d):
    """(M_bb, dM_bb/dt) of the true model, for the reaction torque of Eq. (7).

    The base entries alone of M = S^T M_phi S (Eq. 12) and of dM/dt e_0 = Y_Mdot(w, e_0)
    theta_d, with the values of the whole products (``(S.T @ M_phi @ S)[0, 0]`` and
    ``(velocity_regressors(..., e_0)[0] @ theta_d)[0]``), about twice as fast (no C w
    regressor; one BLAS call). S's entries are 0 and +-1 and its base column is ones: M_bb
    below adds the terms of the two products in ascending order (the same bits as OpenBLAS's
    products here; tested to rounding, since a BLAS picks its order); the body rates S w are
    the loop of :func:`~ffsm_pin.model._planar_kernels.velocity_regressors`, S^T Y_Mdot_phi
    has at most two terms per entry (the same bits in any order), and its product with
    theta_d is the same BLAS call on the same matrix (tested bit for bit).

    Parameters
    ----------
    S, off, K, L, collinear : ndarray or bool
        Fields of :class:`~ffsm_pin.model.planar.PlanarKernelConstants`.
    q_b : float
        Base angle [rad].
    q_m : ndarray, shape (n,)
        Joint angles [rad].
    w : ndarray, shape (n + 1,)
        (w_b, w_m) [rad/s].
    %(theta_d_true)s
    """
    nb = S.shape[0]
    c, s, pc, ps = trig(S, off, K, L, q_b, q_m)
    Mphi = mass_phi(theta_d, pc, ps, K, L, nb, collinear)
    M_bb = 0.0
    for k in range(nb):  # (S^T M_phi S)[0, 0], row 0 of S^T M_phi first
        row = 0.0
        for j in range(nb):
            row += S[j, 0] * Mphi[j, k]
        M_bb += row * S[k, 0]
    P = K.size
    dphi = mv(S, w)  # (as velocity_regressors)
    Y = np.zeros((nb, theta_d.size))  # S^T Y_Mdot_phi(w, e_0): only the pair columns
    for p in range(P):
        k, l = K[p], L[p]
        dd = dphi[l] - dphi[k]
        fc = -ps[p] * dd  # as velocity_regressors' fc, fs with b = S e_0 = ones
        fs = -pc[p] * dd
        bk, bl = S[k, 0], S[l, 0]
        for i in range(nb):
            Y[i, nb + p] = S[k, i] * (fc * bl) + S[l, i] * (fc * bk)
            if not collinear:
                Y[i, nb + P + p] = S[k, i] * (fs * bl) + S[l, i] * (fs * bk)
    return M_bb, (Y @ theta_d)[0]


@njit(cache=True, nogil=True)  # rows in two threads: control/diagnostics.rows_beside
@fill_doc(CONTROL_DOC)
def reaction_rows(S, off, K, L, collinear, q_b, q_m, w, dw_b, theta_d):
    """F_r of Eq. (7) on recorded rows, after a run: ``M_bb dw_b/dt + 1/2 dM_bb/dt w_b`` with
    (M_bb, dM_bb/dt) of :func:`base_inertia`; q_b (N,), q_m (N, n), w (N, n + 1), dw_b (N,).

    Parameters
    ----------
    S, off, K, L, collinear : ndarray or bool
        Fields of :class:`~ffsm_pin.model.planar.PlanarKernelConstants`.
    %(rows)s
    %(theta_d_true)s
    """
    N = q_b.shape[0]
    out = np.empty(N)
    for i in range(N):
        Mbb, Mbb_dot = base_inertia(S, off, K, L, collinear, q_b[i], q_m[i], w[i], theta_d)
        out[i] = Mbb * dw_b[i] + 0.5 * Mbb_dot * w[i, 0]
    return out


def base_velocity(w):
    """w_b, the base's part of w = (w_b, w_m) as the period passes it: a number [rad/s]."""
    return w[0]


def true_model_constants(geo) -> tuple:
    """The constant arguments :func:`reaction_rows` takes first."""
    return geo.S, geo.phi_offset, geo.K, geo.L, geo.collinear


@fill_doc(CONTROL_DOC)
def reaction_rows_of(q_b, q_m, w, dw_b) -> tuple:
    """The recorded rows q_b (N, 1), q_m, w, dw_b (N, 1) as :func:`reaction_rows` takes them
    (contiguous; q_b and dw_b as (N,)).

    %(sections_reaction_rows_of)s
    """
    return _rows(q_b[:, 0], q_m, w, dw_b.reshape(-1))


def compile_beside_law(meas, state) -> None:
    """Nothing: the planar kernels the second process compiles take about as long as the
    kinematic law (:func:`.fast_spatial.compile_beside_law` balances the spatial ones).

    Parameters
    ----------
    meas : Measurement
        The run's measurement.
    state : PeriodState
        The period's state.
    """
