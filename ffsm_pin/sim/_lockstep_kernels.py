"""The compiled parts of a lock-step run (:mod:`.lockstep`): the batch's control periods in
one call, and its actuators in one call, each case by the very kernel its single run calls."""

from __future__ import annotations

from numba import njit
from numba.typed import List

from ..control.kernels import STATUS_OK
from ..control.period import PeriodOutputs, period_of
from ._actuator_kernel import actuate
from .plant import STATE_OK, _state_status  # (the plant's own state check, for the batch)


@njit(cache=True)
def listed(first, count):
    """A typed list of ``count`` items, each ``first`` until :func:`put` sets it. Made (and
    filled) in compiled, cached code: a ``numba.typed.List`` built from Python compiles its
    methods for the item type in every process (0.15 s a list)."""
    out = List()
    for _ in range(count):
        out.append(first)
    return out


@njit(cache=True)
def put(items, i, item):
    """``items[i] = item`` for a list of :func:`listed`, compiled and cached."""
    items[i] = item


@njit(cache=True)
def periods(boxes, rows, dt, t, seen, M, h, active, out, signals, j):
    """The compiled periods of the active cases, one call: case ``b`` sees row ``b`` of the
    measurement arrays ``seen = (q_b, q_m, w, z_e, z_e_dot)`` (its ``q_b`` the number
    ``q_b[b]`` on a planar robot) and the stand-ins ``M``, ``h`` (adaptive laws); its period's
    results go to row ``b`` of ``out = (status, idx, value, u, damping, booked, book)`` (its
    torque [N m] to ``u[b]``) and its signals' row (``rows[b]``, written by the period) to
    ``signals[b, j]``. ``book[b]``: the period needs its controller's bookkeeping (a status
    not OK, damping, or ``booked[b]``, damped before); returns how many do."""
    q_b, q_m, w, z_e, z_e_dot = seen
    status, idx, value, u, damping, booked, book = out
    count = 0
    for b in range(len(boxes)):
        book[b] = False
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
        if status[b] != STATUS_OK or damping[b] != 0.0 or booked[b]:
            book[b] = True
            count += 1
    return count


@njit(cache=True)
def actuate_all(u_cmd, x, limits, noise, out, active, counts):
    """:func:`~._actuator_kernel.actuate` for each active case ``b``: its own torque state
    ``x[b]`` and row ``b`` of ``limits = (limit, alpha, lagged, max_change, rate_limited)``;
    ``noise`` the zeros of actuators without torque noise. ``counts = (periods, per_joint)``:
    a period in which it saturated adds one to ``periods[b]`` and to ``per_joint[b, i]`` of
    each joint at its limit (:meth:`~.actuators.Actuators.apply`'s counts)."""
    limit, alpha, lagged, max_change, rate_limited = limits
    periods_at, per_joint = counts
    for b in range(u_cmd.shape[0]):
        if active[b] and actuate(
            u_cmd[b], x[b], limit[b], alpha[b], lagged[b], max_change[b], rate_limited[b],
            noise, out[b],
        ):  # fmt: skip
            periods_at[b] += 1
            for i in range(out.shape[1]):
                if abs(out[b, i]) >= limit[b, i]:
                    per_joint[b, i] += 1


@njit(cache=True)
def state_checks(Q, V, n_linear, rate_limit, active, state):
    """The plant's state check (:meth:`~.plant.Plant.state_status`) of each active case's
    (q, v), rows of ``Q``, ``V``, into ``state[b]``; returns how many are not ``STATE_OK``."""
    count = 0
    for b in range(Q.shape[0]):
        state[b] = STATE_OK
        if active[b]:
            state[b] = _state_status(Q[b], V[b], n_linear, rate_limit)
            if state[b] != STATE_OK:
                count += 1
    return count
