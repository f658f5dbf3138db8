"""What a controller offers a lock-step runner (:mod:`ffsm_pin.sim.lockstep`): its compiled
period over a batch of runs in one call.

A controller that can be stepped in lock-step has ``lockstep_obstacle`` (None when it can),
``period`` (its dt [s]), ``lockstep_handles()`` (:class:`LockstepHandles`), ``settle(meas,
status, idx, value)`` (the bookkeeping of a period whose status is not plain: its stops) and
``damped_since`` (None, or since when it is damped: then every period is settled). The batch
kernels here all take ``(items, dt, t, seen, M, h, active, out, signals, j)``:

* ``items``: one item per run (:attr:`LockstepHandles.item`, in a typed list), each run's own
  controller state, advanced in place;
* ``seen = (q_b, q_m, w, z_e, z_e_dot)``: what each run's controller sees, row ``b`` for run
  ``b`` (a planar ``q_b`` one number per run); ``M``, ``h``: the true M and C w stand-ins;
* ``out = (status, idx, value, u, damping, booked, book)``: per run, the period's status (the
  codes of :mod:`.kernels`), its torque [N m], damping, and whether its controller must
  ``settle`` it (``book``; ``booked``: damped before);
* ``signals[b, j]``: the run's signals row, in the order of its recorded signals.

Each returns how many runs need their controller's ``settle``. Each period is the very
compiled period the run's single ``step`` calls, so the torques and the signals are its own,
bit for bit (tests/sim/test_lockstep.py).
"""

from __future__ import annotations

from typing import Any, NamedTuple

from numba import njit

from .._docstrings import doc_entries, fill_doc
from . import adaptive_ct_kernels, gjm_ct_kernels
from .kernels import STATUS_NONFINITE, STATUS_OK
from .period import PeriodOutputs, period_of

_DOC = doc_entries(
    batch_params="""
        Parameters
        ----------
        items : numba.typed.List
            One item per run (:attr:`LockstepHandles.item`), its state advanced in place.
        dt, t : float
            The control period and the time [s].
        seen : tuple of ndarray
            ``(q_b, q_m, w, z_e, z_e_dot)``, row ``b`` what run ``b``'s controller sees.
        M, h : ndarray or None
            Passed to each period as the true M and C w.
        active : ndarray of bool
            The runs still going (the others are skipped).
        out : tuple of ndarray
            ``(status, idx, value, u, damping, booked, book)``, written row by row.
        signals : ndarray, shape (B, rows, width)
            Row ``j`` of run ``b``'s signals written to ``signals[b, j]``.
        j : int
            The row.

        Returns
        -------
        int
            How many runs need their controller's ``settle``.""",
)


class LockstepHandles(NamedTuple):
    """What a lock-step runner calls a controller's period with.

    Attributes
    ----------
    item : object
        The run's item of the batch kernel's typed list (its live state).
    kernel : callable
        The batch kernel (the module docstring's arguments).
    M, h : ndarray or None
        What the kernel passes as the true M and C w.
    width : int
        Entries of the signals row the kernel writes.
    """

    item: Any
    kernel: Any
    M: Any
    h: Any
    width: int


@njit(cache=True)
@fill_doc(_DOC)
def lu_jia_periods(items, dt, t, seen, M, h, active, out, signals, j):
    """The paper's compiled periods (:func:`.period.period_of`) of the active runs; an item is
    ``(box, row)``: the period's box and the signals row it writes (copied to ``signals``).

    %(batch_params)s
    """
    q_b, q_m, w, z_e, z_e_dot = seen
    status, idx, value, u, damping, booked, book = out
    count = 0
    for b in range(len(items)):
        book[b] = False
        if not active[b]:
            continue
        box, row = items[b]
        meas = (t, q_b[b], q_m[b], w[b], z_e[b], z_e_dot[b], M, h)
        status[b], idx[b], value[b] = period_of(box, dt, meas, None)
        outputs = PeriodOutputs(*box.out)
        for i in range(u.shape[1]):
            u[b, i] = outputs.u_m[i]
        damping[b] = outputs.damping[0]
        for i in range(row.size):
            signals[b, j, i] = row[i]
        if status[b] != STATUS_OK or damping[b] != 0.0 or booked[b]:
            book[b] = True
            count += 1
    return count


@njit(cache=True)
def _baseline_row(u, b, u_b, w_md, sigma, damping_b, signals, j):
    """u[b] and the first signals of a baseline's row: w_mc, sigma_min, damping."""
    n = u_b.size
    for i in range(n):
        u[b, i] = u_b[i]
        signals[b, j, i] = w_md[i]
    signals[b, j, n] = sigma
    signals[b, j, n + 1] = damping_b


@njit(cache=True)
@fill_doc(_DOC)
def gjm_ct_planar(items, dt, t, seen, M, h, active, out, signals, j):
    """gjm-ct's planar periods (:func:`.gjm_ct_kernels.period_planar`); an item is its
    ``(geo, gains, reference, estimates)`` bundles. Signals: w_mc, sigma_min, damping.

    %(batch_params)s
    """
    q_b, q_m, w, z_e, z_e_dot = seen
    status, idx, value, u, damping, booked, book = out
    for b in range(len(items)):
        book[b] = False
        if active[b]:
            geo, gains, ref, est = items[b]
            meas = (t, q_b[b], q_m[b], w[b], z_e[b], z_e_dot[b], M, h)
            u_b, w_md, sigma, damp = gjm_ct_kernels.period_planar(geo, gains, ref, meas, est)
            damping[b] = damp
            _baseline_row(u, b, u_b, w_md, sigma, damp, signals, j)
    return 0


@njit(cache=True)
@fill_doc(_DOC)
def gjm_ct_spatial(items, dt, t, seen, M, h, active, out, signals, j):
    """gjm-ct's spatial periods (:func:`.gjm_ct_kernels.period_spatial`), as
    :func:`gjm_ct_planar`.

    %(batch_params)s
    """
    q_b, q_m, w, z_e, z_e_dot = seen
    status, idx, value, u, damping, booked, book = out
    for b in range(len(items)):
        book[b] = False
        if active[b]:
            geo, gains, ref, est = items[b]
            meas = (t, q_b[b], q_m[b], w[b], z_e[b], z_e_dot[b], M, h)
            u_b, w_md, sigma, damp = gjm_ct_kernels.period_spatial(geo, gains, ref, meas, est)
            damping[b] = damp
            _baseline_row(u, b, u_b, w_md, sigma, damp, signals, j)
    return 0


@njit(cache=True)
def _estimates_row(est, signals, b, j, start):
    """theta_z, theta_d, theta_b at t (before the period) into the row from ``start``."""
    k = start
    for theta in est:
        for i in range(theta.size):
            signals[b, j, k] = theta[i]
            k += 1


@njit(cache=True)
@fill_doc(_DOC)
def adaptive_ct_planar(items, dt, t, seen, M, h, active, out, signals, j):
    """adaptive-ct's planar periods (:func:`.adaptive_ct_kernels.period_planar`, the
    estimates advanced in place); an item is its ``(geo, gains, reference, estimates)``.
    Signals: w_mc, sigma_min, damping, then the estimates at t. A torque not finite: status
    :data:`~.kernels.STATUS_NONFINITE` (the controller's ``settle`` raises its stop).

    %(batch_params)s
    """
    q_b, q_m, w, z_e, z_e_dot = seen
    status, idx, value, u, damping, booked, book = out
    count = 0
    for b in range(len(items)):
        book[b] = False
        if active[b]:
            geo, gains, ref, est = items[b]
            _estimates_row(est, signals, b, j, q_m.shape[1] + 2)
            meas = (t, q_b[b], q_m[b], w[b], z_e[b], z_e_dot[b], M, h)
            u_b, w_r, sigma, damp, finite, _ = adaptive_ct_kernels.period_planar(
                geo, gains, ref, meas, est
            )
            damping[b] = damp
            _baseline_row(u, b, u_b, w_r, sigma, damp, signals, j)
            status[b] = STATUS_OK if finite else STATUS_NONFINITE
            if not finite:
                book[b] = True
                count += 1
    return count


@njit(cache=True)
@fill_doc(_DOC)
def adaptive_ct_spatial(items, dt, t, seen, M, h, active, out, signals, j):
    """adaptive-ct's spatial periods (:func:`.adaptive_ct_kernels.period_spatial`), as
    :func:`adaptive_ct_planar`.

    %(batch_params)s
    """
    q_b, q_m, w, z_e, z_e_dot = seen
    status, idx, value, u, damping, booked, book = out
    count = 0
    for b in range(len(items)):
        book[b] = False
        if active[b]:
            geo, gains, ref, est = items[b]
            _estimates_row(est, signals, b, j, q_m.shape[1] + 2)
            meas = (t, q_b[b], q_m[b], w[b], z_e[b], z_e_dot[b], M, h)
            u_b, w_r, sigma, damp, finite, _ = adaptive_ct_kernels.period_spatial(
                geo, gains, ref, meas, est
            )
            damping[b] = damp
            _baseline_row(u, b, u_b, w_r, sigma, damp, signals, j)
            status[b] = STATUS_OK if finite else STATUS_NONFINITE
            if not finite:
                book[b] = True
                count += 1
    return count


__all__ = [
    "LockstepHandles", "adaptive_ct_planar", "adaptive_ct_spatial", "gjm_ct_planar",
    "gjm_ct_spatial", "lu_jia_periods",
]  # fmt: skip
