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

_ARG1 = pin.ArgumentPosition.ARG1


def _chart_rate(model: pin.Model, q0, theta, v) -> np.ndarray:
    """dtheta/dt = J(theta)^-1 v in the chart ``q = integrate(q0, theta)``."""
    return np.linalg.solve(pin.dIntegrate(model, q0, theta, _ARG1), v)


def rkmk4_step(model: pin.Model, data: pin.Data, q0, v0, tau, dt: float):
    """One RK4 step of size ``dt`` [s] with generalised forces ``tau`` held.

    Returns ``(q, v, a0)``: the new state and the ABA acceleration at the start of the step.
    """
    a1 = pin.aba(model, data, q0, v0, tau).copy()
    # stage 1 sits at theta = 0, where J = identity: dtheta/dt = v0
    th2 = 0.5 * dt * v0
    v2 = v0 + 0.5 * dt * a1
    a2 = pin.aba(model, data, pin.integrate(model, q0, th2), v2, tau).copy()
    r2 = _chart_rate(model, q0, th2, v2)
    th3 = 0.5 * dt * r2
    v3 = v0 + 0.5 * dt * a2
    a3 = pin.aba(model, data, pin.integrate(model, q0, th3), v3, tau).copy()
    r3 = _chart_rate(model, q0, th3, v3)
    th4 = dt * r3
    v4 = v0 + dt * a3
    a4 = pin.aba(model, data, pin.integrate(model, q0, th4), v4, tau).copy()
    r4 = _chart_rate(model, q0, th4, v4)
    theta = (dt / 6.0) * (v0 + 2.0 * r2 + 2.0 * r3 + r4)
    v = v0 + (dt / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return pin.integrate(model, q0, theta), v, a1
