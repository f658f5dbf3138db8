"""Fourth-order Runge-Kutta on the configuration Lie group (Runge-Kutta-Munthe-Kaas).

The state is (q, v): q on Pinocchio's configuration group (SE(2) or SE(3) for the root times the
joints), v in R^nv, with ``dq/dt = v`` in the sense of ``pin.integrate`` (the base twist in the
base frame) and ``dv/dt = ABA(q, v, tau)``.

An RK4 whose stages are ``pin.integrate(q0, c dt v_i)`` and whose update is
``pin.integrate(q0, dt/6 (v_1 + 2 v_2 + 2 v_3 + v_4))`` is only second order in the base pose:
the stage velocities live in different tangent spaces. Munthe-Kaas's fix is to write
``q(t) = integrate(q0, theta(t))`` in the chart around the step's start, where theta is an
ordinary vector with ``dtheta/dt = J(theta)^-1 v``, ``J = d integrate(q0, theta) / d theta``
(``pin.dIntegrate``, argument 1: the right Jacobian of the exponential map). Classical RK4 on
(theta, v) in that chart is fourth order on the group (Munthe-Kaas, BIT 38, 1998).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from numba import njit

from .._docstrings import fill_doc
from ._docs import SIM_DOC

_ARG1 = pin.ArgumentPosition.ARG1


@njit(cache=True)
def gauss_solve(A: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """out[:n] = A^-1 b by Gaussian elimination with partial pivoting (A, b overwritten).
    A non-finite or singular system gives non-finite entries, not an exception.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        The matrix, overwritten.
    b : ndarray, shape (n,)
        The right-hand side, overwritten.
    out : ndarray
        Its first n entries receive the solution.
    """
    n = b.size
    for k in range(n):
        p = k
        for r in range(k + 1, n):
            if abs(A[r, k]) > abs(A[p, k]):
                p = r
        if p != k:
            for j in range(k, n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            b[k], b[p] = b[p], b[k]
        for r in range(k + 1, n):
            f = A[r, k] / A[k, k]
            for j in range(k, n):
                A[r, j] -= f * A[k, j]
            b[r] -= f * b[k]
    for k in range(n - 1, -1, -1):
        s = b[k]
        for j in range(k + 1, n):
            s -= A[k, j] * out[j]
        out[k] = s / A[k, k]


def chart_block(model: pin.Model) -> int:
    """Size of the leading block of ``J(theta)`` that is not the identity: the root joint's nv
    when every other joint has one degree of freedom (revolute, continuous, prismatic: their
    exponential map is a translation of the coordinate, J = 1), else the whole of nv."""
    rest = [model.joints[j].nv for j in range(2, model.njoints)]
    return model.joints[1].nv if all(n == 1 for n in rest) else model.nv


def _chart_rate(model: pin.Model, q0, theta, v, nb: int) -> np.ndarray:
    """dtheta/dt = J(theta)^-1 v in the chart ``q = integrate(q0, theta)``; J is the identity
    outside its leading nb x nb block (:func:`chart_block`)."""
    J = pin.dIntegrate(model, q0, theta, _ARG1)
    rate = v.copy()
    gauss_solve(J[:nb, :nb].copy(), v[:nb].copy(), rate)
    return rate


@fill_doc(SIM_DOC)
def rkmk4_step(model: pin.Model, data: pin.Data, q0, v0, tau, dt: float, nb: int | None = None):
    """One RK4 step of size ``dt`` [s] with generalised forces ``tau`` held; ``nb`` is
    :func:`chart_block` (computed when not given).

    Parameters
    ----------
    %(model_data)s
    q0, v0 : ndarray
        The state at the start (Pinocchio convention).
    tau : ndarray, shape (nv,)
        Generalised forces, held.
    dt : float
        Step [s].
    nb : int or None
        :func:`chart_block` of the model.

    Returns
    -------
    q, v : ndarray
        The new state.
    a0 : ndarray
        The ABA acceleration at the start of the step.
    """
    if nb is None:
        nb = chart_block(model)
    a1 = pin.aba(model, data, q0, v0, tau).copy()
    # stage 1 sits at theta = 0, where J = identity: dtheta/dt = v0
    th2 = 0.5 * dt * v0
    v2 = v0 + 0.5 * dt * a1
    a2 = pin.aba(model, data, pin.integrate(model, q0, th2), v2, tau).copy()
    r2 = _chart_rate(model, q0, th2, v2, nb)
    th3 = 0.5 * dt * r2
    v3 = v0 + 0.5 * dt * a2
    a3 = pin.aba(model, data, pin.integrate(model, q0, th3), v3, tau).copy()
    r3 = _chart_rate(model, q0, th3, v3, nb)
    th4 = dt * r3
    v4 = v0 + dt * a3
    a4 = pin.aba(model, data, pin.integrate(model, q0, th4), v4, tau).copy()
    r4 = _chart_rate(model, q0, th4, v4, nb)
    theta = (dt / 6.0) * (v0 + 2.0 * r2 + 2.0 * r3 + r4)
    v = v0 + (dt / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return pin.integrate(model, q0, theta), v, a1
