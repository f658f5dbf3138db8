"""The compiled actuator step (numba), the same arithmetic as
:meth:`ffsm_pin.sim.actuators.Actuators.apply_reference` joint by joint (tested equal, bit for
bit, in tests/sim/test_actuators.py)."""

from __future__ import annotations

from numba import njit


@njit(cache=True)
def actuate(u_cmd, x, limit, alpha, lagged, max_change, rate_limited, noise, out):
    """Apply one control period: saturation, lag, rate limit, noise, saturation again.

    ``x`` (the actuators' torque state) is updated in place and the applied torque written to
    ``out``; returns True when some joint's applied torque is at its limit.
    """
    saturated = False
    for j in range(u_cmd.size):
        lim = limit[j]
        y = min(max(u_cmd[j], -lim), lim)
        if lagged:
            y = x[j] + alpha * (y - x[j])
        if rate_limited:
            step = max_change[j]
            y = x[j] + min(max(y - x[j], -step), step)
        x[j] = y
        u = min(max(y + noise[j], -lim), lim)
        out[j] = u
        if abs(u) >= lim:
            saturated = True
    return saturated
