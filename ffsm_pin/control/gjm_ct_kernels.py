"""Compiled control period of the ``gjm-ct`` baseline (:mod:`ffsm_pin.control.gjm_ct`).

One period, planar and spatial: the resolved rates through the generalized Jacobian
(:mod:`.resolved_motion_kernels`) at the measurement advanced by a complex step along the
measured motion (value and exact time derivative in one evaluation), then the computed torque
on the estimates' model. The numpy reference is
:meth:`~ffsm_pin.control.gjm_ct.GjmComputedTorque.step_numpy`; the two are tested against each
other (``tests/control/test_gjm_ct.py``, ``tests/control/test_conformance.py``). The building
blocks are the models' compiled kernels (the barycentric Jacobian, momentum rows, mass matrix
and velocity regressors of :mod:`ffsm_pin.model._planar_kernels` and of the spatial
:mod:`ffsm_pin.model._spatial_kinematics_kernels`, :mod:`ffsm_pin.model._spatial_mass_kernels`
and :mod:`ffsm_pin.model._spatial_velocity_kernels`).

A period takes named bundles: the model's kernel constants, :class:`GjmKernelGains`, the
reference (:class:`~.reference_kernels.ReferenceArrays`), the measurement
(:class:`~.interface.Measurement`) and the estimates (:class:`~.kernels.Estimates`, not
adapted); it returns (u_m, w_md, sigma_min, damping). Called from Python every period, it takes
all but the model's constants as the plain tuples of their fields and names them again on
entry (numba types a plain tuple at a fraction of a named one's cost; :func:`.period.period`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit

from .._array_kernels import mv, spd_solve
from .._docstrings import fill_doc
from ..model import _planar_kernels as planar_kernels
from ..model._spatial_mass_kernels import mass_matrix_by_sums
from ..model._spatial_velocity_kernels import subtract_dT, velocity_terms
from ._docs import CONTROL_DOC
from .fast_spatial import measured_kinematics
from .kernels import COMPLEX_STEP
from .resolved_motion_kernels import period_bundles, rates_planar, rates_spatial


class GjmKernelGains(NamedTuple):
    """The gjm-ct gains as its period reads them (:class:`~.gjm_ct.GjmGains`)."""

    k_z: np.ndarray  # [1/s] one per task component
    k_v: float  # [1/s]
    threshold: float  # [m] damped least squares below this sigma_min of J*
    n_task: int


# ---------------------------------------------------------------------- planar
@njit(cache=True)
@fill_doc(CONTROL_DOC)
def period_planar(geo, gains_f, ref_f, meas_f, est_f):
    """(u_m, w_md, sigma_min, damping) of one gjm-ct period (planar); estimates not adapted.

    %(params_baseline_period)s
    """
    # (the bundles named again: module docstring)
    gains, ref, meas, est = period_bundles(GjmKernelGains, gains_f, ref_f, meas_f, est_f)
    S, off, K, L, ee_row, collinear = geo
    q_b, q_m, w = meas.q_b, meas.q_m, meas.w
    theta_d = est.theta_d
    hj = 1j * COMPLEX_STEP
    w_c, _, sigma, damping = rates_planar(
        geo, gains, ref, meas.t + hj, q_b + hj * w[0], q_m + hj * w[1:],
        meas.z_e + hj * meas.z_e_dot, est.theta_z + 0j, est.theta_b + 0j,
    )  # fmt: skip
    w_md = w_c.real.copy()
    a_m = w_c.imag / COMPLEX_STEP + gains.k_v * (w_md - w[1:])
    c, s, pc, ps = planar_kernels.trig(S, off, K, L, q_b, q_m)
    M = planar_kernels.mass_matrix(theta_d, pc, ps, K, L, S, collinear)
    _, Yh = planar_kernels.velocity_regressors(pc, ps, K, L, S, w, w, theta_d.size, collinear)
    h = mv(Yh, theta_d)  # C w
    a_b = -((M[0, 1:] * a_m).sum() + h[0]) / M[0, 0]  # base rows unactuated, Eq. (9a)
    u = M[1:, 0] * a_b + mv(M[1:, 1:], a_m) + h[1:]
    return u, w_md, sigma, damping


# ---------------------------------------------------------------------- spatial
@njit(cache=True)
@fill_doc(CONTROL_DOC)
def period_spatial(geo, gains_f, ref_f, meas_f, est_f):
    """(u_m, w_md, sigma_min, damping) of one gjm-ct period (spatial); estimates not adapted.

    %(params_baseline_period)s
    """
    gains, ref, meas, est = period_bundles(GjmKernelGains, gains_f, ref_f, meas_f, est_f)
    jr, ax, er, m = geo
    q_b, q_m, w = meas.q_b, meas.q_m, meas.w
    theta_d = est.theta_d
    N, nd = q_m.size + 3, theta_d.size
    R, z, q_b_rate = measured_kinematics(jr, ax, q_b, q_m, w)
    hj = 1j * COMPLEX_STEP
    w_c, _, sigma, damping = rates_spatial(
        geo, gains, ref, meas.t + hj, q_b + hj * q_b_rate, q_m + hj * w[3:],
        meas.z_e + hj * meas.z_e_dot, est.theta_z + 0j, est.theta_b + 0j,
    )  # fmt: skip
    w_md = w_c.real.copy()
    a_m = w_c.imag / COMPLEX_STEP + gains.k_v * (w_md - w[3:])
    M = np.empty((N, N))
    mass_matrix_by_sums(R, z, theta_d, M)
    Yh = np.empty((N, nd))
    Yb = np.empty((3, nd))  # (Y_b, not used; Y_M and Y_Mdot not computed)
    velocity_terms(R, z, w, w, w, None, None, Yh, Yb)
    subtract_dT(R, z, w, Yh)
    h = Yh @ theta_d  # C w
    Mbm = np.ascontiguousarray(M[:3, 3:])
    a_b = -spd_solve(np.ascontiguousarray(M[:3, :3]), mv(Mbm, a_m) + h[:3])  # (M_bb: SPD)
    u = mv(M[3:, :3], a_b) + mv(M[3:, 3:], a_m) + h[3:]
    return u, w_md, sigma, damping


#: The compiled period by attitude dimension m3 (planar 1, spatial 3).
PERIOD: dict[int, Callable[..., tuple]] = {1: period_planar, 3: period_spatial}

__all__ = ["PERIOD", "GjmKernelGains", "period_planar", "period_spatial"]
