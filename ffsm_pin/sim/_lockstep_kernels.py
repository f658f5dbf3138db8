"""The compiled parts of a lock-step run (:mod:`.lockstep`): the batch's typed lists, its
actuators in one call (each case by the very kernel its single run calls), the torque and
state checks for the batch. The controllers' batch kernels are theirs
(:mod:`ffsm_pin.control.lockstep`)."""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.typed import List

from ._actuator_kernel import actuate
from .plant import STATE_OK, _project_base, _state_status  # (the plant's own, for the batch)


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


@njit(cache=True)
def restore_momenta(Ag, V, momentum0, rows, live):
    """The momentum projection :meth:`~.plant.Plant.step` makes after each step, for each
    case ``b`` in ``live`` in one call: the base twist of ``V[b]`` corrected in place so that
    the momentum at the case's new configuration, whose centroidal map is ``Ag[b]``, is
    ``momentum0[b]`` again (the plant's own projection kernel, case by case: the same bits).

    Parameters
    ----------
    Ag : ndarray, shape (B, 6, nv)
        Each case's centroidal map at its new configuration.
    V : ndarray, shape (B, nv)
        The velocities, corrected in place.
    momentum0 : ndarray, shape (B, r)
        Each case's conserved rows of h_g.
    rows : ndarray, shape (r,)
        Those rows (:attr:`~.plant.Plant.conserved_rows`).
    live : ndarray of int
        The cases to correct.
    """
    for b in live:
        _project_base(Ag[b], V[b], momentum0[b], rows)


@njit(cache=True)
def torque_faults(u, active, faulty):
    """``faulty[b]``: an active case's torque ``u[b]`` holds an entry that is not finite (the
    run's check of a controller's torque); returns how many do."""
    count = 0
    for b in range(u.shape[0]):
        faulty[b] = False
        if active[b]:
            for i in range(u.shape[1]):
                if not np.isfinite(u[b, i]):
                    faulty[b] = True
            count += faulty[b]
    return count
