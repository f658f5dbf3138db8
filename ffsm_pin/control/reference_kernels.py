"""The end-effector reference evaluated inside a compiled period (complex-step safe).

A scenario's reference (:class:`ffsm_pin.scenario.spec.Reference`) gives its arrays through
``kernel_arrays()``: constant terms, harmonic selection, amplitudes, frequencies, phases and the
piecewise polynomial of a reference from data. :class:`ReferenceArrays` names them, and
:func:`reference_at` evaluates z_e,d(t) or its rate as ``Reference.ee_pose`` /
``Reference.ee_rate`` do.

Where this lives: the reference is the scenario layer's (:mod:`ffsm_pin.scenario.spec`), which
sits above the control layer, and the controllers' kernels call this one, so its compiled
evaluation is here, next to the kernels that use it; ``Reference.kernel_arrays`` is the one
place the two layers meet. (Moving the kernel beside ``Reference`` would need the control layer
to import the scenario's, which the layering forbids.)
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .._array_kernels import mv


class ReferenceArrays(NamedTuple):
    """A reference's arrays as the compiled kernels read them (``Reference.kernel_arrays``):
    ``z_d(t) = c + A (amp * cos(freq t + phase)) + pp(t)``."""

    c: np.ndarray  # constant terms, (n_task,)
    A: np.ndarray  # harmonic term -> component, (n_task, n_terms)
    amp: np.ndarray  # amplitudes, (n_terms,)
    freq: np.ndarray  # [rad/s]
    phase: np.ndarray  # [rad]
    pp: np.ndarray | None  # piecewise polynomial table; None: no data (nothing compiled for it)


def reference_arrays(reference) -> ReferenceArrays:
    """The :class:`ReferenceArrays` of a scenario's reference (``reference.kernel_arrays()``,
    C-contiguous float arrays), ``pp`` None when the reference has no piecewise polynomial (a
    reference not from data): the kernels then compile none of its code (numba prunes a
    branch on an argument that is None)."""
    c, A, amp, freq, phase, pp = reference.kernel_arrays()
    return ReferenceArrays(c, A, amp, freq, phase, pp if pp.shape[1] > 0 else None)


@njit(cache=True)
def reference_at(ref, t, rate):
    """z_e,d(t) (``rate`` False) or dz_e,d/dt of ``ref`` (:class:`ReferenceArrays`): the
    harmonic terms plus, when ``ref.pp`` is not None, the piecewise polynomial of a reference
    from data (complex-step safe).

    Parameters
    ----------
    ref : ReferenceArrays
        The reference.
    t : float or complex
        Time [s].
    rate : bool
        The rate dz_e,d/dt instead of z_e,d.
    """
    arg = ref.freq * t + ref.phase
    if rate:
        out = mv(ref.A, -ref.amp * ref.freq * np.sin(arg))
    else:
        out = ref.c + mv(ref.A, ref.amp * np.cos(arg))
    return _plus_piecewise(out, ref.pp, t, 1 if rate else 0)


@njit(cache=True)
def _plus_piecewise(out, pp, t, order):
    """``out`` plus the piecewise polynomial ``pp``'s derivative of that order at t; ``out``
    itself when ``pp`` is None (an argument: numba compiles nothing else then)."""
    if pp is None:
        return out
    if pp.shape[1] == 0:  # (a table without segments: the same)
        return out
    return out + piecewise(pp, t, order)


@njit(cache=True)
def piecewise(table, t, order):
    """d^order/dt^order of :class:`ffsm_pin.scenario.trajectory.PiecewisePolynomial` at t
    (as its numpy ``derivative``; the segment is chosen by Re t).

    Parameters
    ----------
    table : ndarray
        The polynomial's table (segment starts in row 0).
    t : float or complex
        Time [s].
    order : int
        Order of the derivative (0: the value).
    """
    starts = table[0]
    tr = t.real
    lo, hi = 0, starts.size  # last k with starts[k] <= tr (0 when none)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if starts[mid] <= tr:
            lo = mid
        else:
            hi = mid
    tau = t - starts[lo]
    n = (table.shape[0] - 1) // 6
    out = np.zeros(n) + 0.0 * tau  # real or complex, as t
    for p in range(5, order - 1, -1):
        fac = 1.0
        for j in range(order):
            fac *= p - j
        for i in range(n):
            out[i] = out[i] * tau + fac * table[1 + p * n + i, lo]
    return out


__all__ = ["ReferenceArrays", "piecewise", "reference_arrays", "reference_at"]
