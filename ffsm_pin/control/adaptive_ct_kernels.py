"""Compiled control period of the ``adaptive-ct`` baseline (:mod:`ffsm_pin.control.adaptive_ct`).

One period, planar and spatial, as
:meth:`~ffsm_pin.control.adaptive_ct.AdaptiveComputedTorque.step_numpy` (the readable
reference; tested against each other in ``tests/control/test_adaptive_ct.py``): the
kinematic estimates by the paper's Eqs. (28) and (42), the reference motion of gjm-ct
(:mod:`.resolved_motion_kernels`) at the measurement and the estimates advanced by a complex
step, the Slotine & Li torque with C(q, w) w_r by polarization, and the gradient law of theta_d
stepped linearly implicitly. A period takes named bundles (the model's kernel constants,
:class:`AdaptiveCtKernelGains`, the reference, the measurement and the estimates,
:class:`~.kernels.Estimates`; all but the model's constants as the plain tuples of their
fields, named again on entry, as in :func:`.period.period`); the estimates are updated in
place; the period returns (u_m, w_mr, sigma_min, damping, finite, physical): physical False
when the projection of ``adaptation = "physical"`` (:mod:`.physical`) reached its cap.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit

from .._array_kernels import add_scaled, mv, spd_solve
from .._docstrings import fill_doc
from ..model import _planar_kernels as planar_kernels
from ..model._spatial_kinematics_kernels import y_z
from ..model._spatial_mass_kernels import mass_matrix_by_sums, ym
from ..model._spatial_velocity_kernels import subtract_dT, velocity_terms
from . import fast, fast_spatial
from ._docs import CONTROL_DOC
from .fast_spatial import measured_kinematics
from .kernels import COMPLEX_STEP, theta_z_step
from .physical import PhysicalTerm, physical_increment
from .resolved_motion_kernels import period_bundles, rates_planar, rates_spatial


class AdaptiveCtKernelGains(NamedTuple):
    """The adaptive-ct gains as its period reads them (:class:`~.adaptive_ct.AdaptiveCtGains`),
    with the period's constants."""

    k_z: np.ndarray  # [1/s] one per task component
    k_s: float  # [1/s]
    gamma_b: float
    gamma_z: float
    gamma_d: float
    threshold: float  # [m] damped least squares below this sigma_min of J*
    n_task: int
    dt: float  # [s] the control period
    physical: PhysicalTerm | None  # adaptation = "physical" (physical.py); None: gradient


@njit(cache=True)
def _theta_d_increment(Y_m, s_m, M_mm, gamma_d, dt):
    """The gradient law -gamma_d Y_m^T s_m, linearly implicit in its stiff mode (as
    :func:`ffsm_pin.control.adaptation.theta_d_increment`)."""
    c = gamma_d * dt
    return -c * (Y_m.T @ spd_solve(M_mm + c * (Y_m @ Y_m.T), mv(M_mm, s_m)))


@njit(cache=True)
def _torque_and_update(Y, s, M_hat, m3, gains, theta_d, theta_b, theta_z, tb_new, tz_new):
    """u_m = [Y theta_d-hat]_m - k_s M-hat_mm s_m from the joint rows (after the m3 base rows),
    then, if it is finite, the gradient law (projected when ``gains.physical`` is a
    projection) and the kinematic estimates of this period. Returns (u_m, finite, physical):
    physical False when the projection reached its cap (nothing advanced)."""
    Y_m = np.ascontiguousarray(Y[m3:])
    s_m = s[m3:].copy()
    M_mm = np.ascontiguousarray(M_hat[m3:, m3:])
    u = Y_m @ theta_d - gains.k_s * mv(M_mm, s_m)
    if not np.all(np.isfinite(u)):
        return u, False, True
    d = _theta_d_increment(Y_m, s_m, M_mm, gains.gamma_d, gains.dt)
    d, physical = physical_increment(gains.physical, theta_d, d)
    if not physical:
        return u, True, False
    theta_d += d
    theta_b[:] = tb_new
    theta_z[:] = tz_new
    return u, True, True


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def period_planar(geo, gains_f, ref_f, meas_f, est_f):
    """One adaptive-ct period (planar); updates the estimates (``est_f``) in place.

    %(params_baseline_period)s
    """
    S, off, K, L, ee_row, collinear = geo
    gains, ref, meas, est = period_bundles(AdaptiveCtKernelGains, gains_f, ref_f, meas_f, est_f)
    theta_z, theta_d, theta_b = est
    q_b, q_m, w, dt = meas.q_b, meas.q_m, meas.w, gains.dt
    nb = S.shape[0]
    nd = theta_d.size
    c, s, pc, ps = planar_kernels.trig(S, off, K, L, q_b, q_m)
    tb_new = fast.theta_b_step(
        theta_b, planar_kernels.y_m(pc, ps, K, L, S, w, nd, collinear)[0], gains.gamma_b, dt
    )
    Yz = planar_kernels.position_regressor(c, s, S, w, theta_z.size, collinear)
    tz_new = theta_z_step(theta_z, Yz, meas.z_e_dot, gains.gamma_z, dt)
    hj = 1j * COMPLEX_STEP
    w_mc, w_bc, sigma, damping = rates_planar(
        geo, gains, ref, meas.t + hj, q_b + hj * w[0], q_m + hj * w[1:],
        meas.z_e + hj * meas.z_e_dot, theta_z + hj * (tz_new - theta_z) / dt,
        theta_b + hj * (tb_new - theta_b) / dt,
    )  # fmt: skip
    w_r = np.empty(nb)
    w_r_dot = np.empty(nb)
    w_r[0], w_r_dot[0] = w_bc.real, w_bc.imag / COMPLEX_STEP
    w_r[1:], w_r_dot[1:] = w_mc.real, w_mc.imag / COMPLEX_STEP
    _, Yh_plus = planar_kernels.velocity_regressors(
        pc, ps, K, L, S, w + w_r, w + w_r, nd, collinear
    )
    _, Yh_minus = planar_kernels.velocity_regressors(
        pc, ps, K, L, S, w - w_r, w - w_r, nd, collinear
    )
    Y = planar_kernels.y_m(pc, ps, K, L, S, w_r_dot, nd, collinear) + 0.25 * (Yh_plus - Yh_minus)
    M_hat = planar_kernels.mass_matrix(theta_d, pc, ps, K, L, S, collinear)
    u, finite, physical = _torque_and_update(Y, w - w_r, M_hat, 1, gains, theta_d, theta_b,
                                             theta_z, tb_new, tz_new)  # fmt: skip
    return u, w_r[1:].copy(), sigma, damping, finite, physical


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def period_spatial(geo, gains_f, ref_f, meas_f, est_f):
    """One adaptive-ct period (spatial); updates the estimates (``est_f``) in place.

    %(params_baseline_period)s
    """
    jr, ax, er, m = geo
    gains, ref, meas, est = period_bundles(AdaptiveCtKernelGains, gains_f, ref_f, meas_f, est_f)
    theta_z, theta_d, theta_b = est
    q_b, q_m, w, dt = meas.q_b, meas.q_m, meas.w, gains.dt
    n = q_m.size
    N, nd = n + 3, theta_d.size
    R, z, q_b_rate = measured_kinematics(jr, ax, q_b, q_m, w)
    Yw = np.empty((3, nd))
    ym(R, z, w, Yw, True)  # the base rows of Y_M(w)
    Yb = np.empty((3, nd + 3))
    Yb[:, 3:] = Yw
    tb_new = fast_spatial.theta_b_step(theta_b, Yb, gains.gamma_b, dt)
    Yz = np.empty((3, theta_z.size))
    y_z(R, z, w, Yz)
    tz_new = theta_z_step(theta_z, Yz, meas.z_e_dot, gains.gamma_z, dt)
    hj = 1j * COMPLEX_STEP
    w_mc, w_bc, sigma, damping = rates_spatial(
        geo, gains, ref, meas.t + hj, q_b + hj * q_b_rate, q_m + hj * w[3:],
        meas.z_e + hj * meas.z_e_dot, theta_z + hj * (tz_new - theta_z) / dt,
        theta_b + hj * (tb_new - theta_b) / dt,
    )  # fmt: skip
    w_r = np.empty(N)
    w_r_dot = np.empty(N)
    for i in range(3):
        w_r[i], w_r_dot[i] = w_bc[i].real, w_bc[i].imag / COMPLEX_STEP
    for j in range(n):
        w_r[3 + j], w_r_dot[3 + j] = w_mc[j].real, w_mc[j].imag / COMPLEX_STEP
    # Y = Y_M(dw_r/dt) + 1/4 (Y_h(w + w_r) - Y_h(w - w_r)) (polarization); the first pass of
    # velocity_terms also gives Y_M(dw_r/dt), the second none (Y_Mdot not used: not computed)
    Y = np.empty((N, nd))
    Yh = np.empty((N, nd))
    x = w + w_r
    velocity_terms(R, z, x, w_r_dot, x, Y, None, Yh, Yw)
    subtract_dT(R, z, x, Yh)
    add_scaled(Y, 0.25, Yh)  # (Y += 0.25 Yh without a 10 x 300 temporary: the same bits)
    x = w - w_r
    velocity_terms(R, z, x, w_r_dot, x, None, None, Yh, Yw)
    subtract_dT(R, z, x, Yh)
    add_scaled(Y, -0.25, Yh)
    M_hat = np.empty((N, N))
    mass_matrix_by_sums(R, z, theta_d, M_hat)
    u, finite, physical = _torque_and_update(Y, w - w_r, M_hat, 3, gains, theta_d, theta_b,
                                             theta_z, tb_new, tz_new)  # fmt: skip
    return u, w_r[3:].copy(), sigma, damping, finite, physical


#: The compiled period by attitude dimension m3 (planar 1, spatial 3).
PERIOD: dict[int, Callable[..., tuple]] = {1: period_planar, 3: period_spatial}

__all__ = ["PERIOD", "AdaptiveCtKernelGains", "period_planar", "period_spatial"]
