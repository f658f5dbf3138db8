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

from numba import njit, types
from numba.extending import overload

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


def _gjm_ct_period(geo, gains, ref, meas, est):
    """gjm-ct's period of the geometry of ``meas`` (compiled code only: :func:`_gjm_ct_choice`)."""
    raise NotImplementedError("compiled code only")


def _adaptive_ct_period(geo, gains, ref, meas, est):
    """adaptive-ct's period of the geometry of ``meas`` (compiled code only)."""
    raise NotImplementedError("compiled code only")


def _by_geometry(planar, spatial):
    """An overload's implementation: ``planar`` when the measurement's q_b is a number, else
    ``spatial`` (chosen when the caller is compiled, so one batch kernel serves both)."""

    def choose(geo, gains, ref, meas, est):
        period = planar if isinstance(meas.types[1], types.Float) else spatial

        def call(geo, gains, ref, meas, est):
            return period(geo, gains, ref, meas, est)

        return call

    return choose


overload(_gjm_ct_period)(_by_geometry(gjm_ct_kernels.period_planar, gjm_ct_kernels.period_spatial))
overload(_adaptive_ct_period)(
    _by_geometry(adaptive_ct_kernels.period_planar, adaptive_ct_kernels.period_spatial)
)


@njit(cache=True)
def _case_measurement(seen, b, t, M, h):
    """Run ``b``'s measurement tuple, as :func:`.compiled.kernel_measurement` makes it."""
    q_b, q_m, w, z_e, z_e_dot = seen
    return (t, q_b[b], q_m[b], w[b], z_e[b], z_e_dot[b], M, h)


@njit(cache=True)
@fill_doc(_DOC)
def gjm_ct_periods(items, dt, t, seen, M, h, active, out, signals, j):
    """gjm-ct's periods (:mod:`.gjm_ct_kernels`, planar or spatial); an item is its
    ``(geo, gains, reference, estimates)`` bundles. Signals: w_mc, sigma_min, damping.

    %(batch_params)s
    """
    u, damping, book = out[3], out[4], out[6]
    for b in range(len(items)):
        book[b] = False
        if active[b]:
            geo, gains, ref, est = items[b]
            meas = _case_measurement(seen, b, t, M, h)
            u_b, w_md, sigma, damp = _gjm_ct_period(geo, gains, ref, meas, est)
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
def adaptive_ct_periods(items, dt, t, seen, M, h, active, out, signals, j):
    """adaptive-ct's periods (:mod:`.adaptive_ct_kernels`, planar or spatial; the estimates
    advanced in place); an item is its ``(geo, gains, reference, estimates)``. Signals: w_mc,
    sigma_min, damping, then the estimates at t. A torque not finite: status
    :data:`~.kernels.STATUS_NONFINITE` (the controller's ``settle`` raises its stop).

    %(batch_params)s
    """
    status, u, damping, book = out[0], out[3], out[4], out[6]
    count = 0
    for b in range(len(items)):
        book[b] = False
        if active[b]:
            geo, gains, ref, est = items[b]
            _estimates_row(est, signals, b, j, u.shape[1] + 2)
            meas = _case_measurement(seen, b, t, M, h)
            u_b, w_r, sigma, damp, finite, _ = _adaptive_ct_period(geo, gains, ref, meas, est)
            damping[b] = damp
            _baseline_row(u, b, u_b, w_r, sigma, damp, signals, j)
            status[b] = STATUS_OK if finite else STATUS_NONFINITE
            if not finite:
                book[b] = True
                count += 1
    return count


__all__ = ["LockstepHandles", "adaptive_ct_periods", "gjm_ct_periods", "lu_jia_periods"]
