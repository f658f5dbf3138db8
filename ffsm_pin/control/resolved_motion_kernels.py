"""Compiled resolved motion through the generalized Jacobian, planar and spatial: the rates the
baselines' kernels build on (:mod:`.gjm_ct_kernels`, :mod:`.adaptive_ct_kernels`).

At a state that may be complex (a complex step along the measured motion and the estimates'
rates), with the model of the estimates theta_z, theta_b: the joint rates that make the task
error decay at k_z, ``w_md = J*^+ (dz_d/dt - d - k_z e_z)``, and the base rate momentum
conservation gives with them (the numpy reference: :func:`.resolved_motion.resolved_rates`).

``gains`` is any named bundle with ``k_z`` (per task component), ``threshold`` (the damped
pseudo-inverse's, [m]) and ``n_task``: each baseline passes its own (numba compiles per type).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._array_kernels import cmm, cmv, mv
from .._docstrings import fill_doc
from ..model import _planar_kernels as planar_kernels
from ._docs import CONTROL_DOC
from .fast_spatial import task_geometry
from .interface import Measurement
from .kernels import Estimates, damped_pinv, wrap_angle
from .reference_kernels import ReferenceArrays, reference_at


@njit(cache=True, inline="always")
def period_bundles(gains_class, gains_f, ref_f, meas_f, est_f):
    """A baseline period's bundles named again from the plain tuples of their fields: the
    gains (as ``gains_class``, the baseline's own), the reference, the measurement and the
    estimates.

    Parameters
    ----------
    gains_class : type
        The baseline's gains bundle (a NamedTuple class).
    gains_f, ref_f, meas_f, est_f : tuple
        The fields of the gains, the ``ReferenceArrays``, the ``Measurement`` and the
        ``Estimates``, as the period takes them from Python.
    """
    return gains_class(*gains_f), ReferenceArrays(*ref_f), Measurement(*meas_f), Estimates(*est_f)


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def rates_planar(geo, gains, ref, t, q_b, q_m, z_e, theta_z, theta_b):
    """(w_md, w_b, sigma_min, damping) of the resolved rates at complex arguments (planar).

    %(params_resolved_rates)s
    """
    S, off, K, L, ee_row, collinear = geo
    nt = gains.n_task
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
    err = z_e[:nt] - reference_at(ref, t, False)
    if nt > 2:
        err[2] = wrap_angle(err[2])
    pinv, sigma, damping = damped_pinv(Js, gains.threshold)
    rate = reference_at(ref, t, True)
    w_m = mv(pinv, rate - drift - gains.k_z * err)
    w_b = g0 - (G * w_m).sum()  # momentum conservation, Eq. (13)
    return w_m, w_b, sigma, damping


@njit(cache=True)
@fill_doc(CONTROL_DOC)
def rates_spatial(geo, gains, ref, t, q_b, q_m, z_e, theta_z, theta_b):
    """(w_md, w_b, sigma_min, damping) of the resolved rates at complex arguments (spatial).

    %(params_resolved_rates)s
    """
    jr, ax, er, m = geo
    nt = gains.n_task
    n = q_m.size
    J, Hbb, Hbm, _ = task_geometry(jr, ax, er, m, nt, q_b, q_m, theta_z, theta_b[3:])
    rhs = np.empty((3, n + 1), dtype=np.complex128)
    rhs[:, :n] = Hbm
    for i in range(3):
        rhs[i, n] = theta_b[i]  # A_0
    G = np.linalg.solve(Hbb, rhs)  # H_bb^-1 (H_bm, A_0)
    Jb = np.ascontiguousarray(J[:, :3])
    Js = np.ascontiguousarray(J[:, 3:]) - cmm(Jb, np.ascontiguousarray(G[:, :n]))
    drift = cmv(Jb, np.ascontiguousarray(G[:, n]))
    for i in range(3):
        drift[i] += theta_z[i]  # + v_0
    err = z_e[:nt] - reference_at(ref, t, False)
    pinv, sigma, damping = damped_pinv(Js, gains.threshold)
    target = reference_at(ref, t, True) - drift - gains.k_z * err
    w_m = cmv(pinv, target)
    w_b = np.ascontiguousarray(G[:, n]) - cmv(np.ascontiguousarray(G[:, :n]), w_m)
    return w_m, w_b, sigma, damping


__all__ = ["rates_planar", "rates_spatial"]
