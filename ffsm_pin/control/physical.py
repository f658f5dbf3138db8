"""Physically consistent adaptation (``adaptation = "physical"``): the projection of theta_d-hat
onto the set C = {theta_d : P(theta_d) >= eps I} after each step of the adaptation law.

P is the model's barycentric pseudo-inertia (:meth:`~ffsm_pin.model.planar.BarycentricModel.
pseudo_inertia`, docs/robust.md section 1), linear in theta_d, positive semidefinite for the true
parameters; on C the estimated inertia M(q, theta_d-hat) is positive definite at every
configuration. C is convex (a linear matrix inequality). After the law's increment, while
``lambda_min(P(theta)) < eps (1 - tol)``, theta moves to the Euclidean projection onto the
half-space ``{theta : v^T P(theta) v >= eps}`` of each eigenvector v whose eigenvalue is below
eps, in turn (one sweep per eigendecomposition). The half-space
contains C, so the distance to any point of C (the truth included, when eps <= lambda_min of
the true P) never increases: the parameter term |theta~|^2 / gamma of the paper's Lyapunov
function (Theorem 1) does not increase at a projection (docs/robust.md). A step that needs
no projection is not touched (the same values as ``adaptation = "gradient"``).

:func:`project` is the readable numpy reference; :func:`project_kernel` the compiled version,
called by the compiled periods through :func:`physical_increment` (a no-op that numba prunes
when the term is None, the default law).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .._array_kernels import positive_definite
from ..errors import ParameterError
from ..model._pseudo_inertia import (
    PseudoInertiaTable,
    adjoint,
    assemble,
    pseudo_inertia,
    pseudo_inertia_adjoint,
)

#: the adaptation laws of theta_d (``[controller] adaptation``)
ADAPTATIONS = ("gradient", "physical")
#: the default margin eps as a fraction of lambda_min(P) of the initial estimate (docs/gains.md)
MARGIN_FRACTION = 0.1
#: accepted: lambda_min(P) >= eps (1 - PROJECTION_TOL)
PROJECTION_TOL = 1e-3
#: sweeps of half-space projections per period before the run stops (docs/robust.md)
MAX_PROJECTIONS = 200


class PhysicalTerm(NamedTuple):
    """The projection's constants as both versions read them: the model's pseudo-inertia
    table (:class:`~ffsm_pin.model._pseudo_inertia.PseudoInertiaTable`) and the margin."""

    rows: np.ndarray
    cols: np.ndarray
    params: np.ndarray
    coefs: np.ndarray
    size: int
    margin: float  # eps
    tol: float
    max_iter: int


def physical_term(model, theta_d0, margin: float | None) -> PhysicalTerm:
    """The projection of ``model`` with the margin eps: ``margin``, or when None the derived
    default :data:`MARGIN_FRACTION` x lambda_min(P(theta_d0)) (docs/gains.md).

    Parameters
    ----------
    model : ReducedModel
        A barycentric model (its ``pseudo_inertia_table``).
    theta_d0 : array_like
        The initial estimate of theta_d.
    margin : float or None
        eps, or None for the derived default.

    Returns
    -------
    PhysicalTerm
        The constants of the projection.

    Raises
    ------
    ParameterError
        The margin is negative, or is derived from an initial estimate that is not physical.
    """
    table = model.pseudo_inertia_table()
    if margin is None:
        lam = float(np.linalg.eigvalsh(pseudo_inertia(table, theta_d0))[0])
        if not lam > 0:
            raise ParameterError(
                "controller.physical_margin: the initial estimate of theta_d is not physical "
                f"(lambda_min(P) = {lam:.3g}), so no margin can be derived from it; give "
                "physical_margin > 0 (the estimate is then projected before the first period)"
            )
        margin = MARGIN_FRACTION * lam
    if not margin >= 0:
        raise ParameterError(f"controller.physical_margin = {margin}: valid choices: >= 0")
    rows, cols, params, coefs, size = table
    return PhysicalTerm(rows, cols, params, coefs, size, float(margin), PROJECTION_TOL,
                        MAX_PROJECTIONS)  # fmt: skip


def margin_of(term: PhysicalTerm, theta_d) -> float:
    """lambda_min(P(theta_d)): the distance of the estimate to the boundary of the physical
    set (negative outside it; the projection keeps it >= eps (1 - tol)), recorded as the
    signal ``ctrl_lambda_min_P`` of ``adaptation = "physical"`` (docs/robust.md).

    Parameters
    ----------
    term : PhysicalTerm
        The table.
    theta_d : array_like
        The estimate.

    Returns
    -------
    float
        The smallest eigenvalue of P [kg m^2].
    """
    table = PseudoInertiaTable(term.rows, term.cols, term.params, term.coefs, term.size)
    return float(np.linalg.eigvalsh(pseudo_inertia(table, np.asarray(theta_d)))[0])


@njit(cache=True)
def margin_kernel(term, theta_d):
    """:func:`margin_of`, compiled (what a run records each period).

    Parameters
    ----------
    term : PhysicalTerm
        The table.
    theta_d : ndarray
        The estimate.
    """
    P = assemble(term.rows, term.cols, term.params, term.coefs, term.size, theta_d)
    return np.linalg.eigvalsh(P)[0]


def project(term: PhysicalTerm, theta_d) -> tuple[np.ndarray, int, float]:
    """theta_d moved into {lambda_min(P) >= eps (1 - tol)} by half-space projections (module
    docstring); the numpy reference of :func:`project_kernel`.

    Parameters
    ----------
    term : PhysicalTerm
        The table and the margin.
    theta_d : array_like
        The estimate.

    Returns
    -------
    theta_d : ndarray
        The projected estimate (``theta_d`` itself, not a copy, when no projection acts).
    count : int
        Sweeps made; ``max_iter + 1`` when lambda_min is still below after max_iter.
    lam_min : float
        lambda_min(P) of the returned estimate.
    """
    table = PseudoInertiaTable(term.rows, term.cols, term.params, term.coefs, term.size)
    eps = term.margin
    lam, V = np.linalg.eigh(pseudo_inertia(table, theta_d))
    count = 0
    while lam[0] < eps * (1.0 - term.tol):
        if count == term.max_iter:
            return theta_d, count + 1, float(lam[0])
        for i in range(len(lam)):  # a sweep: each eigenvector below eps, in turn
            if lam[i] >= eps:
                break
            a = pseudo_inertia_adjoint(table, V[:, i], len(theta_d))
            gap = eps - a @ theta_d  # (a . theta_d = v^T P v, lam[i] before the sweep)
            if gap > 0:
                theta_d = theta_d + (gap / (a @ a)) * a
        count += 1
        lam, V = np.linalg.eigh(pseudo_inertia(table, theta_d))
    return theta_d, count, float(lam[0])


def initial_projection(term: PhysicalTerm, theta_d: np.ndarray, events: list[str]) -> np.ndarray:
    """``theta_d`` projected into the physical set with a large cap (10 x the period's), and
    the fact noted in ``events`` when the projection acted (docs/robust.md).

    Parameters
    ----------
    term : PhysicalTerm
        The projection.
    theta_d : ndarray
        The initial estimate.
    events : list of str
        The controller's events.

    Returns
    -------
    ndarray
        The estimate the law starts from.
    """
    theta, count, lam = project(term._replace(max_iter=10 * term.max_iter), theta_d)
    if count:
        events.append(
            f"the initial theta_d-hat was not physical: projected ({count} sweeps, "
            f"moved by {np.linalg.norm(theta - theta_d):.3g}) to lambda_min(P) = {lam:.3g}"
        )
    return np.array(theta, dtype=float)


def increment(term: PhysicalTerm, theta_d, d_theta_d) -> tuple[np.ndarray, int]:
    """The increment the law applies (numpy reference of :func:`physical_increment`):
    ``d_theta_d`` itself when theta_d + d_theta_d needs no projection, else projected - theta_d.

    Parameters
    ----------
    term : PhysicalTerm
        The table and the margin.
    theta_d : ndarray
        theta_d-hat at t.
    d_theta_d : ndarray
        The law's increment.

    Returns
    -------
    increment : ndarray
        The increment to apply.
    count : int
        Sweeps made (``max_iter + 1``: the cap was reached).
    """
    theta, count, _ = project(term, theta_d + d_theta_d)
    return (d_theta_d, 0) if count == 0 else (theta - theta_d, count)


@njit(cache=True)
def _spectrum(term, theta_d):
    return np.linalg.eigh(
        assemble(term.rows, term.cols, term.params, term.coefs, term.size, theta_d)
    )


@njit(cache=True)
def project_kernel(term, theta_d):
    """:func:`project`, compiled: (theta_d, count, lam_min), theta_d a new array.

    Parameters
    ----------
    term : PhysicalTerm
        The table and the margin.
    theta_d : ndarray
        The estimate.
    """
    theta = theta_d.copy()
    eps = term.margin
    lam, V = _spectrum(term, theta)
    count = 0
    while lam[0] < eps * (1.0 - term.tol):
        if count == term.max_iter:
            return theta, count + 1, lam[0]
        for i in range(lam.size):
            if lam[i] >= eps:
                break
            v = np.ascontiguousarray(V[:, i])
            a = adjoint(term.rows, term.cols, term.params, term.coefs, v, theta.size)
            gap = eps - a @ theta
            if gap > 0:
                theta += (gap / (a @ a)) * a
        count += 1
        lam, V = _spectrum(term, theta)
    return theta, count, lam[0]


@njit(cache=True)
def physical_increment(term, theta_d, d_theta_d):
    """The increment the law applies: ``d_theta_d`` itself when ``term`` is None (the paper's
    law) or theta_d + d_theta_d needs no projection; else projected - theta_d. Returns
    (increment, ok): ok False when :func:`project_kernel` reached its cap. Whether a
    projection is needed is decided by a Cholesky factorisation of P - eps (1 - tol) I
    (:func:`~ffsm_pin._array_kernels.positive_definite`: 24 x 24 for the Panda, a few us
    against LAPACK's eigenvalues), LAPACK deciding when a pivot is not positive; it differs from
    the numpy reference's ``lambda_min >= eps (1 - tol)`` only at that boundary to rounding.

    Parameters
    ----------
    term : PhysicalTerm or None
        The projection, None for the gradient law.
    theta_d : ndarray
        theta_d-hat at t.
    d_theta_d : ndarray
        The law's increment.
    """
    if term is None:
        return d_theta_d, True
    theta = theta_d + d_theta_d
    P = assemble(term.rows, term.cols, term.params, term.coefs, term.size, theta)
    for i in range(term.size):
        P[i, i] -= term.margin * (1.0 - term.tol)
    if positive_definite(P):  # the common period: a Cholesky decides, no eigenvalues
        return d_theta_d, True
    theta, count, _ = project_kernel(term, theta)
    if count == 0:
        return d_theta_d, True
    return theta - theta_d, count <= term.max_iter


__all__ = [
    "ADAPTATIONS", "MARGIN_FRACTION", "MAX_PROJECTIONS", "PROJECTION_TOL", "PhysicalTerm",
    "increment", "initial_projection", "margin_kernel", "margin_of", "physical_increment",
    "physical_term",
    "project",
    "project_kernel",
]  # fmt: skip
