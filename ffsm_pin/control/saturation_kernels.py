"""The auxiliary (anti-windup) system of ``controller.saturation = "auxiliary"``, compiled
(the numpy reference and the equations: :mod:`.saturation`).

What is the same for every robot (the excess, the deficits' rates and steps, the relaxed
inputs of the kinematic law) is written once here. What a geometry gives is a table of three
matrices at the measured state, :func:`auxiliary_maps`: M-hat (the true M for the known-model
scheme), the task Jacobian J-hat of Eq. (3) over (w_b, w_m) and L_b of Eq. (1); numba compiles
the call as the geometry's own function (:func:`planar_maps`, :func:`spatial_maps`), chosen by
the type of the model's kernel constants as the period's steps are (:mod:`._dispatch`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._array_kernels import put
from ..attitude._mrp_kernels import l_matrix
from ..model._planar_kernels import jacobian, mass_phi, trig
from ..model._spatial_kinematics_kernels import attitude_rows, kinematics, position_jacobian
from ..model._spatial_mass_kernels import mass_matrix_by_sums
from ..model.planar import PlanarKernelConstants
from ..model.spatial import SpatialKernelConstants
from ._dispatch import overload_for_geometry


def auxiliary_maps(geo, law, meas, state):
    """(M (nb, nb), J (n_task, nb), L_b (m3, m3)) at the measured state with the estimates at
    t (a compiled period's stub: numba compiles the geometry's function, module docstring).

    Parameters
    ----------
    geo : PlanarKernelConstants or SpatialKernelConstants
        The model's kernel constants.
    law : PeriodLaw
        The run's constants (``n_task``, ``adaptive``).
    meas : Measurement
        The measurement at t (its true M for the known-model scheme).
    state : PeriodState
        The estimates at t.
    """
    raise NotImplementedError


def planar_maps(geo, law, meas, state):
    """:func:`auxiliary_maps` of a planar robot (L_b = 1).

    Parameters
    ----------
    geo, law, meas, state
        As :func:`auxiliary_maps`.
    """
    S, off, K, L, ee_row, collinear = geo
    nb = S.shape[0]
    c, s, pc, ps = trig(S, off, K, L, meas.q_b, meas.q_m)
    if law.adaptive:
        M = S.T @ mass_phi(state.theta_d, pc, ps, K, L, nb, collinear) @ S
    else:
        M = meas.M.copy()
    J = np.ascontiguousarray(jacobian(state.theta_z, c, s, S, ee_row, collinear)[: law.n_task])
    return M, J, np.ones((1, 1))


def spatial_maps(geo, law, meas, state):
    """:func:`auxiliary_maps` of a spatial robot (L_b of the base MRP).

    Parameters
    ----------
    geo, law, meas, state
        As :func:`auxiliary_maps`.
    """
    jr, ax, er, m = geo
    q_b, q_m, theta_z = meas.q_b, meas.q_m, state.theta_z
    n = q_m.size
    N = n + 3
    R = np.empty((n + 1, 3, 3))
    z = np.empty((n, 3))
    kinematics(q_b, q_m, jr, ax, R, z)
    if law.adaptive:
        M = np.empty((N, N))
        mass_matrix_by_sums(R, z, state.theta_d, M)
    else:
        M = meas.M.copy()
    V = np.empty((n + 1, 3))
    for k in range(n + 1):
        for i in range(3):
            V[k, i] = theta_z[3 + 3 * k + i]
    J = np.empty((law.n_task, N))
    position_jacobian(R, z, V, J[:3])
    if law.n_task > 3:
        attitude_rows(R[m], er, z, m, J[3:6])
    return M, J, np.ascontiguousarray(l_matrix(q_b, R[0]).real)


overload_for_geometry(auxiliary_maps, PlanarKernelConstants, planar_maps)
overload_for_geometry(auxiliary_maps, SpatialKernelConstants, spatial_maps)


@njit(cache=True)
def _parts(x, nb, m3):
    return x[:nb], x[nb : nb + m3], x[nb + m3 :]


@njit(cache=True)
def auxiliary_rates(term, x, J, L_b):
    """(-k_v chi_v, chi_b', chi_z') at t (:meth:`.saturation.AuxiliarySystem.rates`); ``x``
    the state (chi_v, chi_b, chi_z).

    Parameters
    ----------
    term : AuxiliaryTerm
        The constants.
    x : ndarray, shape (nb + m3 + n_task,)
        The auxiliary state (chi_v, chi_b, chi_z).
    J, L_b : ndarray, shapes (n_task, nb) and (m3, m3)
        The task Jacobian and L_b at t.
    """
    m3 = L_b.shape[0]
    chi_v, chi_b, chi_z = _parts(x, J.shape[1], m3)
    return (-term.rate_v * chi_v, -term.rate_chi * chi_b + L_b @ chi_v[:m3],
            -term.rate_chi * chi_z + J @ chi_v)  # fmt: skip


@njit(cache=True)
def feasible_command(term, u_c, a, M, S):
    """The command with its feedforward scaled to what the actuators deliver
    (:func:`.saturation.feasible_command`, the same steps; ``u_c`` itself within the limits).

    Parameters
    ----------
    term : AuxiliaryTerm
        The constants (the limits).
    u_c : ndarray, shape (n,)
        The law's command [N m].
    a : ndarray, shape (n,)
        Its feedforward [rad/s^2].
    M : ndarray
        M-hat (:func:`auxiliary_maps`).
    S : ndarray, shape (n,) or (n, m3)
        d w_mc / d w_b.
    """
    n = u_c.size
    if np.all(np.abs(u_c) <= term.limit):
        return u_c
    m3 = M.shape[0] - n
    Sm = np.ascontiguousarray(S.real).reshape((n, m3))
    Mbm = np.ascontiguousarray(M[:m3, m3:])
    Mmb, Mmm = np.ascontiguousarray(M[m3:, :m3]), np.ascontiguousarray(M[m3:, m3:])
    G = Mmm - (Mmb + Mmm @ Sm) @ np.linalg.solve(np.ascontiguousarray(M[:m3, :m3]) + Mbm @ Sm,
                                                  Mbm)  # fmt: skip
    g = G @ a
    u0 = u_c - g
    s = 1.0
    for j in range(n):
        if g[j] != 0.0:
            bound = max(term.limit[j], abs(u0[j]))
            s = min(s, max(0.0, (np.copysign(bound, g[j]) - u0[j]) / g[j]))
    return u0 + s * g


@njit(cache=True)
def auxiliary_advance(term, x, u_c, u_f, M, J, L_b):
    """The excess clip(u_f) - u_c and the state at t + dt, in place; returns dw
    (:meth:`.saturation.AuxiliarySystem.advance`, the same steps).

    Parameters
    ----------
    term : AuxiliaryTerm
        The constants.
    x : ndarray
        The auxiliary state, advanced in place.
    u_c : ndarray, shape (n,)
        The law's command [N m].
    u_f : ndarray, shape (n,)
        The command of :func:`feasible_command`.
    M, J, L_b : ndarray
        :func:`auxiliary_maps` at t.
    """
    nb, m3 = M.shape[0], L_b.shape[0]
    chi_v, chi_b, chi_z = _parts(x, nb, m3)
    du = np.minimum(np.maximum(u_f, -term.limit), term.limit) - u_c
    new_dw = np.zeros(nb)
    if np.any(du != 0.0):
        rhs = np.zeros(nb)
        put(rhs, m3, du)
        new_dw = np.linalg.solve(M, rhs)
    drive_b = L_b @ chi_v[:m3]
    drive_z = J @ chi_v
    put(chi_b, 0, term.decay_chi * chi_b + term.gain_chi * drive_b)
    put(chi_z, 0, term.decay_chi * chi_z + term.gain_chi * drive_z)
    put(chi_v, 0, term.decay_v * chi_v + term.gain_v * new_dw)
    return new_dw


@njit(cache=True)
def relaxed(term, x, J, L_b, q_bd, z_e, z_e_dot, hj):
    """The kinematic law's relaxed inputs: (q_bd + chi_b, z_e - chi_z), complex with their
    rates along ``hj`` (i h), and (chi_v, chi_v') for the dynamic level's target.

    Parameters
    ----------
    term : AuxiliaryTerm
        The constants.
    x : ndarray
        The auxiliary state, as :func:`auxiliary_rates` reads it.
    J, L_b : ndarray
        The task Jacobian and L_b at t (:func:`auxiliary_maps`).
    q_bd : ndarray
        The desired base attitude.
    z_e, z_e_dot : ndarray
        The measured pose and its rate.
    hj : complex
        i h, the complex step.
    """
    v_dot, b_dot, z_dot = auxiliary_rates(term, x, J, L_b)
    chi_v, chi_b, chi_z = _parts(x, J.shape[1], L_b.shape[0])
    q = (q_bd + chi_b) + hj * b_dot
    z = z_e.copy() + 0j
    nt = chi_z.size
    z[:nt] = (z_e[:nt] - chi_z) + hj * (z_e_dot[:nt] - z_dot)
    z[nt:] = z_e[nt:] + hj * z_e_dot[nt:]
    return q, z, chi_v, v_dot


__all__ = [
    "auxiliary_advance", "auxiliary_maps", "auxiliary_rates", "feasible_command", "planar_maps",
    "relaxed",
    "spatial_maps",
]  # fmt: skip
