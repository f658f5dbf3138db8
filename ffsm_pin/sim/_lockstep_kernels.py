"""The compiled parts of a lock-step run (:mod:`.lockstep`): the batch's control periods in
one call, and its actuators in one call, each case by the very kernel its single run calls."""

from __future__ import annotations

from numba import njit

from ..control.period import PeriodOutputs, period_of
from ._actuator_kernel import actuate


@njit(cache=True)
def periods(boxes, rows, dt, t, seen, M, h, active, out, signals, j):
    """The compiled periods of the active cases, one call: case ``b`` sees row ``b`` of the
    measurement arrays ``seen = (q_b, q_m, w, z_e, z_e_dot)`` (its ``q_b`` the number
    ``q_b[b]`` on a planar robot) and the stand-ins ``M``, ``h`` (adaptive laws); its period's
    results go to row ``b`` of ``out = (status, idx, value, u, damping)`` (its torque [N m] to
    ``u[b]``) and its signals' row (``rows[b]``, written by the period) to ``signals[b, j]``."""
    q_b, q_m, w, z_e, z_e_dot = seen
    status, idx, value, u, damping = out
    for b in range(len(boxes)):
        if not active[b]:
            continue
        box = boxes[b]
        meas = (t, q_b[b], q_m[b], w[b], z_e[b], z_e_dot[b], M, h)
        status[b], idx[b], value[b] = period_of(box, dt, meas, None)
        outputs = PeriodOutputs(*box.out)
        for i in range(u.shape[1]):
            u[b, i] = outputs.u_m[i]
        damping[b] = outputs.damping[0]
        row = rows[b]
        for i in range(row.size):
            signals[b, j, i] = row[i]


@njit(cache=True)
def actuate_all(u_cmd, x, limits, noise, out, active, saturated):
    """:func:`~._actuator_kernel.actuate` for each active case ``b``: its own torque state
    ``x[b]`` and row ``b`` of ``limits = (limit, alpha, lagged, max_change, rate_limited)``;
    ``noise`` the zeros of actuators without torque noise; whether it saturated to
    ``saturated[b]``."""
    limit, alpha, lagged, max_change, rate_limited = limits
    for b in range(u_cmd.shape[0]):
        if active[b]:
            saturated[b] = actuate(
                u_cmd[b], x[b], limit[b], alpha[b], lagged[b], max_change[b], rate_limited[b],
                noise, out[b],
            )  # fmt: skip
