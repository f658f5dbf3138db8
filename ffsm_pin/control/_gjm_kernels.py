"""Compiled control period of the ``gjm-ct`` baseline (:mod:`ffsm_pin.control.gjm_ct`).

One period, planar and spatial: the resolved rates through the generalized Jacobian at the
measurement advanced by a complex step along the measured motion (value and exact time
derivative in one evaluation), then the computed torque on the estimates' model. The numpy
reference is :func:`ffsm_pin.control.gjm_ct.resolved_rates` and
:meth:`~ffsm_pin.control.gjm_ct.GjmComputedTorque.step_numpy`; the two are tested against
each other (``tests/control/test_gjm_ct.py``). The building blocks are the models' compiled
kernels (the barycentric Jacobian, momentum rows, mass matrix and velocity regressors of
:mod:`ffsm_pin.model._planar_kernels` and :mod:`ffsm_pin.model._spatial_kernels`) and the
paper's controller's (:mod:`.fast`, :mod:`.fast_spatial`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import njit

from ..model import _planar_kernels as planar_kernels
from ..model._spatial_kernels import kinematics, mass_matrix, subtract_dT, velocity_terms
from . import fast, fast_spatial
from ._shared_kernels import _reference, damped_pinv
from .fast import _H  # the complex step (control.kinematic.COMPLEX_STEP)


# ---------------------------------------------------------------------- planar
@njit(cache=True)
def _rates_planar(S, off, K, L, ee_row, collinear, rc, rA, ramp, rfreq, rphase, rpp,
                  k_z, thr, nt, t, q_b, q_m, z_e, theta_z, theta_b):  # fmt: skip
    """(w_md, w_b, sigma_min, damping) of resolved_rates at complex arguments (planar)."""
    nb = S.shape[0]
    c, s, pc, ps = planar_kernels.trig(S, off, K, L, q_b, q_m)
    J = planar_kernels.jacobian(theta_z, c, s, S, ee_row, collinear)
    Mphi = planar_kernels.mass_phi(theta_b[1:], pc, ps, K, L, nb, collinear)
    row = planar_kernels.xm(Mphi.sum(axis=0).reshape(1, nb), S)[0]  # (H_bb, H_bm), Eq. (13)
    G = row[1:] / row[0]  # H_bb^-1 H_bm
    g0 = theta_b[0] / row[0]  # H_bb^-1 A_0
    Js = np.empty((nt, nb - 1), dtype=J.dtype)  # the generalized Jacobian J*
    drift = np.empty(nt, dtype=J.dtype)
    for i in range(nt):
        for j in range(nb - 1):
            Js[i, j] = J[i, 1 + j] - J[i, 0] * G[j]
        drift[i] = J[i, 0] * g0
    drift[0] += theta_z[0]  # + v_0
    drift[1] += theta_z[1]
    err = z_e[:nt] - _reference(rc, rA, ramp, rfreq, rphase, rpp, t, False)
    if nt > 2:
        err[2] = fast._wrap(err[2])
    pinv, sigma, damping = damped_pinv(Js, thr)
    rate = _reference(rc, rA, ramp, rfreq, rphase, rpp, t, True)
    w_m = pinv @ (rate - drift - k_z * err)
    w_b = g0 - (G * w_m).sum()  # momentum conservation, Eq. (13)
    return w_m, w_b, sigma, damping


@njit(cache=True)
def period_planar(S, off, K, L, ee_row, collinear, rc, rA, ramp, rfreq, rphase, rpp,
                  k_z, k_v, thr, nt, t, q_b, q_m, w, z_e, z_e_dot,
                  theta_z, theta_d, theta_b):  # fmt: skip
    """(u_m, w_md, sigma_min, damping) of one gjm-ct period (planar)."""
    hj = 1j * _H
    w_c, _, sigma, damping = _rates_planar(
        S, off, K, L, ee_row, collinear, rc, rA, ramp, rfreq, rphase, rpp, k_z, thr, nt,
        t + hj, q_b + hj * w[0], q_m + hj * w[1:], z_e + hj * z_e_dot,
        theta_z + 0j, theta_b + 0j,
    )  # fmt: skip
    w_md = w_c.real.copy()
    a_m = w_c.imag / _H + k_v * (w_md - w[1:])
    nb = S.shape[0]
    c, s, pc, ps = planar_kernels.trig(S, off, K, L, q_b, q_m)
    M = S.T @ planar_kernels.mass_phi(theta_d, pc, ps, K, L, nb, collinear) @ S
    _, Yh = planar_kernels.velocity_regressors(pc, ps, K, L, S, w, w, theta_d.size, collinear)
    h = Yh @ theta_d  # C w
    a_b = -((M[0, 1:] * a_m).sum() + h[0]) / M[0, 0]  # base rows unactuated, Eq. (9a)
    u = M[1:, 0] * a_b + np.ascontiguousarray(M[1:, 1:]) @ a_m + h[1:]
    return u, w_md, sigma, damping


# ---------------------------------------------------------------------- spatial
@njit(cache=True)
def _rates_spatial(jr, ax, er, m, rc, rA, ramp, rfreq, rphase, rpp, k_z, thr, nt,
                   t, q_b, q_m, z_e, theta_z, theta_b):  # fmt: skip
    """(w_md, w_b, sigma_min, damping) of resolved_rates at complex arguments (spatial)."""
    n = q_m.size
    J, Hbb, Hbm, _ = fast_spatial._geometry(jr, ax, er, m, nt, q_b, q_m, theta_z, theta_b[3:])
    rhs = np.empty((3, n + 1), dtype=np.complex128)
    rhs[:, :n] = Hbm
    for i in range(3):
        rhs[i, n] = theta_b[i]  # A_0
    G = np.linalg.solve(Hbb, rhs)  # H_bb^-1 (H_bm, A_0)
    Jb = np.ascontiguousarray(J[:, :3])
    Js = np.ascontiguousarray(J[:, 3:]) - fast_spatial._cmm(Jb, np.ascontiguousarray(G[:, :n]))
    drift = fast_spatial._cmv(Jb, np.ascontiguousarray(G[:, n]))
    for i in range(3):
        drift[i] += theta_z[i]  # + v_0
    err = z_e[:nt] - _reference(rc, rA, ramp, rfreq, rphase, rpp, t, False)
    pinv, sigma, damping = damped_pinv(Js, thr)
    target = _reference(rc, rA, ramp, rfreq, rphase, rpp, t, True) - drift - k_z * err
    w_m = fast_spatial._cmv(pinv, target)
    w_b = np.ascontiguousarray(G[:, n]) - fast_spatial._cmv(np.ascontiguousarray(G[:, :n]), w_m)
    return w_m, w_b, sigma, damping


@njit(cache=True)
def period_spatial(jr, ax, er, m, rc, rA, ramp, rfreq, rphase, rpp,
                   k_z, k_v, thr, nt, t, q_b, q_m, w, z_e, z_e_dot,
                   theta_z, theta_d, theta_b):  # fmt: skip
    """(u_m, w_md, sigma_min, damping) of one gjm-ct period (spatial)."""
    n = q_m.size
    nb, N, nd = n + 1, n + 3, theta_d.size
    R = np.empty((nb, 3, 3))
    z = np.empty((n, 3))
    kinematics(q_b, q_m, jr, ax, R, z)
    q_b_rate = np.ascontiguousarray(fast_spatial._l_matrix(q_b, R[0]).real) @ w[:3]  # Eq. (1)
    hj = 1j * _H
    w_c, _, sigma, damping = _rates_spatial(
        jr, ax, er, m, rc, rA, ramp, rfreq, rphase, rpp, k_z, thr, nt,
        t + hj, q_b + hj * q_b_rate, q_m + hj * w[3:], z_e + hj * z_e_dot,
        theta_z + 0j, theta_b + 0j,
    )  # fmt: skip
    w_md = w_c.real.copy()
    a_m = w_c.imag / _H + k_v * (w_md - w[3:])
    M = np.empty((N, N))
    mass_matrix(R, z, theta_d, M)
    Yh = np.empty((N, nd))
    Yb = np.empty((3, nd))  # (Y_b, not used; Y_M and Y_Mdot not computed)
    velocity_terms(R, z, w, w, w, None, None, Yh, Yb)
    subtract_dT(R, z, w, Yh)
    h = Yh @ theta_d  # C w
    Mbm = np.ascontiguousarray(M[:3, 3:])
    a_b = -np.linalg.solve(np.ascontiguousarray(M[:3, :3]), Mbm @ a_m + h[:3])
    u = np.ascontiguousarray(M[3:, :3]) @ a_b + np.ascontiguousarray(M[3:, 3:]) @ a_m + h[3:]
    return u, w_md, sigma, damping


#: The compiled period by attitude dimension m3 (planar 1, spatial 3).
PERIOD: dict[int, Callable[..., tuple]] = {1: period_planar, 3: period_spatial}

__all__ = ["PERIOD", "period_planar", "period_spatial"]
