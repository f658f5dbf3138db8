"""What the run loop accepts of a controller's reply: a torque of real numbers, one per joint,
finite (:func:`checked_torque`), with the signals split off the reply
(:func:`checked_reply`); anything else is a :class:`ControllerFault`, the run's stop with
cause ``"controller"`` (docs/controllers.md)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..control.interface import Reply, SignalRow, split_reply

#: float64, the dtype a torque is checked against first (:func:`checked_torque`)
_FLOAT64 = np.dtype(np.float64)


class ControllerFault(Exception):
    """A controller broke the interface (a bad torque or signal); the run stops."""


def checked_torque(u, n: int) -> np.ndarray:
    """``u`` as the run applies it: real numbers, shape ``(n,)``, finite, or a
    :class:`ControllerFault` that says which (the run's stop, cause ``"controller"``).

    Parameters
    ----------
    u : array_like
        The controller's torque [N m].
    n : int
        Joints.

    Returns
    -------
    ndarray
        ``u`` as float64.
    """
    if type(u) is np.ndarray and u.dtype is _FLOAT64 and u.shape == (n,):  # the usual reply
        if all(map(math.isfinite, u.tolist())):  # (the checks below, in fewer calls)
            return u
    u = np.asarray(u)
    if u.dtype.kind not in "fiu":  # (not bool, complex, strings or objects)
        raise ControllerFault(
            f"the controller returned a torque of dtype {u.dtype} ({u.tolist()!r:.80}); "
            f"expected real numbers, shape ({n},), one per joint [N m]"
        )
    if u.dtype != np.float64:
        u = u.astype(float)
    if u.shape != (n,):
        raise ControllerFault(
            f"the controller returned a torque of shape {u.shape}; expected ({n},), one per "
            "joint [N m]"
        )
    if not all(map(math.isfinite, u.tolist())):  # (np.isfinite(u).all(), three times dearer)
        raise ControllerFault(
            f"the controller returned a non-finite torque {u.tolist()} (shape ({n},))"
        )
    return u


def checked_reply(reply: Any, n: int) -> tuple[np.ndarray, Any]:
    """``(u_m, signals)`` of a controller's reply (``u_m`` or ``(u_m, signals)``, as
    :func:`~ffsm_pin.control.interface.split_reply` splits it) with ``u_m`` checked by
    :func:`checked_torque`.

    The package's controllers reply ``(float64 array of shape (n,), SignalRow)``: that reply
    is checked in one pass of tests and handed back as it is (the same values as the split and
    the check one after the other, in fewer Python calls: this runs every period).

    Parameters
    ----------
    reply : object
        What the controller's ``step`` returned.
    n : int
        Joints.

    Returns
    -------
    tuple
        The torque [N m] as float64 and the signals (a dict, a SignalRow, or an empty dict).

    Raises
    ------
    ControllerFault
        The torque is not real, not of shape ``(n,)`` or not finite.
    """
    if type(reply) is tuple and len(reply) == 2:
        u, signals = reply
        if (
            type(signals) is SignalRow
            and type(u) is np.ndarray
            and u.dtype is _FLOAT64
            and u.shape == (n,)
            and all(map(math.isfinite, u.tolist()))
        ):
            return reply
    split: Reply = split_reply(reply)
    return checked_torque(split.u_m, n), split.signals
