"""Compiled pieces the controllers' kernels share: the one home of each.

* :data:`COMPLEX_STEP`, the step h of every complex-step derivative in the control layer
  (``f(x + i h dx)``, ``df = Im / h``; the numpy references' too, :mod:`.kinematic`);
* the status codes a compiled period returns (``STATUS_*``);
* the named bundles shared by several controllers: :class:`Estimates` (the model parameters a
  baseline estimates), :data:`FUNNEL_RECORD` (a funnel, Eqs. 18-22, one record per component) and
  :class:`NullSpaceTerm` (the option of :mod:`.null_space`), with the kernels that read them
  (:func:`funnel_terms`, the null-space objective's gradients);
* the damped pseudo-inverse of the singularity policy (:func:`damped_pinv`), the planar angle
  wrap, and the estimators' steps both the paper's controller and ``adaptive-ct`` take
  (:func:`theta_z_step`, :func:`filter_regressor_update`).

Linear algebra without a controller's meaning (products by loops, complex products, a solve,
positive definiteness) lives in :mod:`ffsm_pin._array_kernels`; the reference's compiled
evaluation in :mod:`.reference_kernels`. Each kernel is checked against its numpy reference
(``tests/control/test_kernels.py`` and through the periods).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .._array_kernels import gram, mv, spd_solve, symmetric_solve_transposed
from .._docstrings import doc_entries, fill_doc
from .._symmetric_kernels import smallest_eigenvalue
from .null_space import GRADIENT_STEP, OBJECTIVE_CODE

#: The complex step h of the control layer's exact derivatives (any tiny h: no subtractive
#: cancellation in ``Im f(x + i h dx) / h``).
COMPLEX_STEP = 1e-30

STATUS_OK = 0
STATUS_FUNNEL_Z = 1  # end-effector error left its funnel
STATUS_FUNNEL_B = 2  # attitude error left its funnel
STATUS_M_NOT_PD = 3  # M(q, theta_d-hat) not positive definite
STATUS_BASE_ROW = 4  # singular base row of the filter
STATUS_H_COLLAPSE = 5  # |H_bm-hat| ~ 0
STATUS_NONFINITE = 6  # u_m not finite
STATUS_NOT_PHYSICAL = 7  # the projection of theta_d-hat (physical.py) reached its cap

#: the code of the joint-centering objective (:data:`.null_space.OBJECTIVE_CODE`)
JOINT_CENTERING = OBJECTIVE_CODE["joint-centering"]

_TWO_PI = 2.0 * np.pi


class Estimates(NamedTuple):
    """The model parameters a baseline estimates (barycentric layout of the robot's model),
    advanced in place by a compiled period that adapts them."""

    theta_z: np.ndarray  # (v_0, V_0 .. V_n), Eq. (3)
    theta_d: np.ndarray  # dynamics, Eq. (9)
    theta_b: np.ndarray  # (A_0, the base rows' parameters), Eq. (14)


#: A funnel as the compiled kernels read it: one record per error component (a structured
#: array, a single argument however many components), from
#: :meth:`~.funnel.Funnel.kernel_table`: rho(t) = (rho_0 - rho_inf) exp(-beta t) + rho_inf
#: (Eq. 18), ``R(s) = ln((a + b_1 s) / (a + b_2 s))`` of Eq. (21), and the bounds on s = e / rho.
FUNNEL_FIELDS = ("rho_0", "rho_inf", "beta", "a", "b_1", "b_2", "upper", "lower")
FUNNEL_RECORD = np.dtype([(name, np.float64) for name in FUNNEL_FIELDS])


def funnel_constants(funnel) -> np.ndarray:
    """The records (:data:`FUNNEL_RECORD`, one per error component) of a
    :class:`~ffsm_pin.control.funnel.Funnel`: the rows of its kernel table, the same values."""
    table = funnel.kernel_table()
    records = np.empty(table.shape[1], dtype=FUNNEL_RECORD)
    for name, row in zip(FUNNEL_FIELDS, table, strict=True):
        records[name] = row
    return records


class NullSpaceTerm(NamedTuple):
    """The null-space option of :mod:`.null_space` as the kinematic laws read it."""

    code: int  # the objective's code (:data:`.null_space.OBJECTIVE_CODE`)
    gain: float  # k_s
    step: float  # [rad] the central difference's step (:data:`.null_space.GRADIENT_STEP`)
    center: np.ndarray  # [rad] joint-centering centre (zeros when unused), (n,)


def null_space_term(null_space, center, n: int) -> NullSpaceTerm | None:
    """The :class:`NullSpaceTerm` of a :class:`~ffsm_pin.control.null_space.NullSpace` with
    the joint-centering ``center`` (None: zeros) for ``n`` joints; None when the objective is
    ``"none"``: the kinematic laws test ``ns is not None`` on an argument, which numba decides
    when it compiles, so a run without the null-space term does not compile its gradient (a
    first run's critical path, about 1-2 s).

    Parameters
    ----------
    null_space : NullSpace
        The term.
    center : array_like or None
        The joint-centering center [rad]; None: zeros.
    n : int
        Number of joints.

    Returns
    -------
    NullSpaceTerm or None
        None when the objective is ``"none"``.
    """
    code = OBJECTIVE_CODE[null_space.objective]
    if code == 0:
        return None
    c = np.zeros(n)
    if center is not None:
        c[:] = center
    return NullSpaceTerm(code, float(null_space.gain), GRADIENT_STEP, c)


@njit(cache=True)
def wrap_angle(d):
    """A planar angle difference mapped to (-pi, pi] by its real part (complex-step safe; as
    :func:`ffsm_pin.control.kinematic.wrap_angle`)."""
    return d - _TWO_PI * np.rint(d.real / _TWO_PI)


@njit(cache=True)
def funnel_terms(f, t, e, identity):
    """(psi, Phi, exit index or -1) of Eqs. (18)-(22) for the funnel ``f``
    (records of :data:`FUNNEL_RECORD`) at time ``t`` [s], in the dtype of the error ``e`` (real, or
    complex for a complex step in ``t`` or the state). The exit index is the component nearest
    to (or farthest beyond) its bound, as :class:`~ffsm_pin.control.funnel.Funnel` reports it
    (psi and Phi are then not Eqs. 21-22's: the period stops);
    ``identity`` gives psi = e, Phi = 1 (no prescribed performance).

    Parameters
    ----------
    f : ndarray
        The funnel's records (:data:`FUNNEL_RECORD`).
    t : float or complex
        Time [s].
    e : ndarray, shape (m,)
        The error.
    identity : bool
        psi = e, Phi = 1.
    """
    m = e.size
    psi = np.empty(m, dtype=e.dtype)
    Phi = np.empty(m, dtype=e.dtype)
    if identity:
        for i in range(m):
            psi[i] = e[i]
            Phi[i] = 1.0
        return psi, Phi, -1
    # rho (complex when t is complex-stepped) and s = e / rho held in Phi and psi until
    # Eqs. (21)-(22) replace them (two arrays fewer a call); on an exit psi and Phi hold them
    rho, s = Phi, psi
    worst, idx = np.inf, -1
    for i in range(m):
        c = f[i]
        rho[i] = (c.rho_0 - c.rho_inf) * np.exp(-c.beta * t) + c.rho_inf  # Eq. (18)
        s[i] = e[i] / rho[i]
        margin = min(c.upper - s[i].real, s[i].real - c.lower)
        if margin < worst:
            worst, idx = margin, i
    if worst <= 0:
        return psi, Phi, idx
    for i in range(m):
        c = f[i]
        num = c.a + c.b_1 * s[i]
        den = c.a + c.b_2 * s[i]
        psi[i] = np.log(num / den)  # Eq. (21)
        Phi[i] = (c.b_1 / num - c.b_2 / den) / rho[i]  # Eq. (22)
    return psi, Phi, -1


@njit(cache=True)
def damped_pinv(A, thr):
    """Damped right pseudo-inverse ``A^T (A A^T + lambda^2 E)^-1`` of a wide matrix (real or
    complex, complex-step safe), with the damping of
    :func:`ffsm_pin.control.linalg.damped_row_pinv`: lambda^2 = thr^2 - sigma^2 when the
    smallest singular value sigma of Re A is below ``thr``, else 0.

    Returns ``(pinv, sigma, lambda^2)``. One kernel for both geometries and the baselines.

    Parameters
    ----------
    A : ndarray, shape (m, k)
        A wide matrix, real or complex.
    thr : float
        The damping threshold [units of A].
    """
    G = gram(A)
    sigma = np.sqrt(max(smallest_eigenvalue(G.real), 0.0))
    damping = 0.0
    if sigma < thr:
        damping = thr * thr - sigma * sigma
        for i in range(G.shape[0]):
            G[i, i] += damping
    return symmetric_solve_transposed(G, A), sigma, damping  # A^T G^-1


# ---------------------------------------------------------------------- null-space objective
@njit(cache=True)
def spd_det(G):
    """det of an SPD matrix by elimination without pivoting (complex-step safe; as
    ffsm_pin.control.null_space.spd_det)."""
    G = G.copy()
    m = G.shape[0]
    det = G[0, 0] * 1.0
    for k in range(m):
        if k > 0:
            det = det * G[k, k]
        for i in range(k + 1, m):
            f = G[i, k] / G[k, k]
            for j in range(k + 1, m):
                G[i, j] -= f * G[k, j]
    return det


@njit(cache=True)
def joint_centering_gradient(ns, q_m):
    """grad_{q_m} mu of the joint-centering objective mu = -1/2 |q_m - center|^2: center - q_m
    (``ns`` a :class:`NullSpaceTerm`; as
    :func:`ffsm_pin.control.null_space.null_space_gradient`).

    Parameters
    ----------
    ns : NullSpaceTerm
        Its ``center`` is read [rad].
    q_m : ndarray, shape (n,)
        Joint angles [rad].
    """
    grad = np.empty(q_m.size, dtype=q_m.dtype)
    for j in range(q_m.size):
        grad[j] = ns.center[j] - q_m[j]
    return grad


@njit(cache=True)
def manipulability(A):
    """mu = sqrt(det(A A^T)) with the plain transpose, complex-step safe (as
    :func:`ffsm_pin.control.null_space.manipulability`); A = J_m-hat U-hat of Eq. (36)."""
    return np.sqrt(spd_det(A @ A.T))


@njit(cache=True)
def perturbed_joints(q_m, h):
    """(2n, n): q_m + h e_j in row 2j, q_m - h e_j in row 2j + 1 (the central difference of
    :func:`manipulability_gradient`; ``h`` real [rad]).

    Parameters
    ----------
    q_m : ndarray, shape (n,)
        Joint angles [rad].
    h : float
        The step [rad].
    """
    n = q_m.size
    Q = np.empty((2 * n, n), dtype=q_m.dtype)
    for j in range(n):
        for k in range(n):
            Q[2 * j, k] = q_m[k]
            Q[2 * j + 1, k] = q_m[k]
        Q[2 * j, j] += h
        Q[2 * j + 1, j] -= h
    return Q


@njit(cache=True)
def manipulability_gradient(A, h):
    """grad_{q_m} mu by central differences: ``A[i]`` the geometry's J_m-hat U-hat at row i of
    :func:`perturbed_joints` (as :func:`ffsm_pin.control.null_space.null_space_gradient`).

    Parameters
    ----------
    A : ndarray
        ``A[i]``: J_m-hat U-hat at row i of :func:`perturbed_joints`.
    h : float
        The step [rad].
    """
    n = A.shape[0] // 2
    grad = np.empty(n, dtype=A.dtype)
    for j in range(n):
        grad[j] = (manipulability(A[2 * j]) - manipulability(A[2 * j + 1])) / (2.0 * h)
    return grad


@njit(cache=True)
def objective_points(ns, q_m):
    """The joint angles at which a geometry evaluates A = J_m-hat U-hat for the null-space
    objective's gradient (:func:`objective_gradient`): the rows of :func:`perturbed_joints`
    for manipulability, none for joint centering (its gradient needs no A).

    Parameters
    ----------
    ns : NullSpaceTerm
        The objective (its ``code`` and ``step`` [rad] are read).
    q_m : ndarray, shape (n,)
        Joint angles [rad].

    Returns
    -------
    ndarray, shape (2n, n) or (0, n)
        One configuration a row.
    """
    if ns.code == JOINT_CENTERING:
        return np.empty((0, q_m.size), dtype=q_m.dtype)
    return perturbed_joints(q_m, ns.step)


@njit(cache=True)
def objective_gradient(ns, q_m, A):
    """grad_{q_m} mu of the null-space objective (as
    :func:`ffsm_pin.control.null_space.null_space_gradient`), the geometry's part given:
    ``A[i]`` its J_m-hat U-hat at row i of :func:`objective_points`.

    Parameters
    ----------
    ns : NullSpaceTerm
        The objective.
    q_m : ndarray, shape (n,)
        Joint angles [rad].
    A : ndarray, shape (k, n_task, n)
        The geometry's A at :func:`objective_points` (k = 0 for joint centering).

    Returns
    -------
    ndarray, shape (n,)
        The gradient.
    """
    if ns.code == JOINT_CENTERING:
        return joint_centering_gradient(ns, q_m)
    return manipulability_gradient(A, ns.step)


# ---------------------------------------------------------------------- estimators
#: the entries Eq. (50)'s two updates share
_FILTER_DOC = doc_entries(
    filter_state="""
        Y_df : ndarray
            The filtered regressor, updated in place.
        decay, gain : float
            exp(-k_de dt) and (1 - exp(-k_de dt)) / k_de.""",
)


@njit(cache=True)
@fill_doc(_FILTER_DOC)
def filter_regressor_update(Y_df, decay, gain, YM, YMdot, Yh):
    """Eq. (50) over one period, in place: ``Y_df <- decay Y_df + gain ((YM - YMdot) + Yh)``
    with ``decay = exp(-k_de dt)``, ``gain = (1 - exp(-k_de dt)) / k_de`` and Y_dc = Y_M(dw-hat
    /dt - k_de w~) - Y_Mdot + Y_h (as :func:`ffsm_pin.control.adaptation.regressor_filter_step`).
    Element by element in the order of the array expression it replaces, so the same values;
    one pass without temporaries (spatial 10 x 300: 3.4 us against 12 us).

    Parameters
    ----------
    %(filter_state)s
    YM, YMdot, Yh : ndarray
        The terms of Y_dc, shaped as Y_df.
    """
    for i in range(Y_df.shape[0]):
        for j in range(Y_df.shape[1]):
            Y_df[i, j] = decay * Y_df[i, j] + gain * ((YM[i, j] - YMdot[i, j]) + Yh[i, j])


@njit(cache=True)
@fill_doc(_FILTER_DOC)
def filter_input_update(Y_df, decay, gain, Y_dc):
    """Eq. (50) over one period, in place, from its input ``Y_dc`` formed beforehand:
    ``Y_df <- decay Y_df + gain Y_dc`` (the spatial period adds Y_M into Y_c, so that Y_dc
    is one array; :func:`filter_regressor_update` takes its three terms).

    Parameters
    ----------
    %(filter_state)s
    Y_dc : ndarray
        Y_dc, shaped as Y_df.
    """
    for i in range(Y_df.shape[0]):
        for j in range(Y_df.shape[1]):
            Y_df[i, j] = decay * Y_df[i, j] + gain * Y_dc[i, j]


@njit(cache=True)
def theta_z_step(theta_z, Yz, z_e_dot, gamma_2, dt):
    """Eq. (42) by backward Euler on the position rows ``Yz`` of Y_z (as
    :func:`ffsm_pin.control.adaptation.theta_z_step`); ``z_e_dot`` the measured rates.

    Parameters
    ----------
    theta_z : ndarray
        theta_z-hat at t.
    Yz : ndarray
        The position rows of Y_z.
    z_e_dot : ndarray
        The measured end-effector rates.
    gamma_2 : float
        Adaptation gain.
    dt : float
        Step [s].
    """
    m = Yz.shape[0]
    r = z_e_dot[:m] - mv(Yz, theta_z)
    G = gram(Yz)
    for i in range(m):
        G[i, i] += 1.0 / (gamma_2 * dt)
    return theta_z + mv(Yz.T, spd_solve(G, r))


__all__ = [
    "COMPLEX_STEP", "JOINT_CENTERING", "STATUS_BASE_ROW", "STATUS_FUNNEL_B", "STATUS_FUNNEL_Z",
    "STATUS_H_COLLAPSE", "STATUS_M_NOT_PD", "STATUS_NONFINITE", "STATUS_NOT_PHYSICAL",
    "STATUS_OK", "Estimates",
    "FUNNEL_RECORD", "NullSpaceTerm", "damped_pinv", "filter_input_update",
    "filter_regressor_update",
    "funnel_constants", "funnel_terms", "joint_centering_gradient", "manipulability",
    "manipulability_gradient", "null_space_term", "perturbed_joints", "spd_det",
    "theta_z_step", "wrap_angle",
]  # fmt: skip
