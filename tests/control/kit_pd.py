"""A small controller written through the kit (docs/controllers.md, "Adding a built-in
controller"): a joint-space PD with a compiled kernel, planar and spatial.

    u_m = k_p (q_target - q_m) - k_d w_f,     w_f <- w_f + alpha (w_m - w_f)

with ``w_f`` the joint rates through a first-order filter (``alpha`` per period): a state the
kernel advances in place, so the kit's warm-up on copies has something to protect.
``[controller.params]``: ``kp``, ``kd`` [N m/rad, N m s/rad] > 0, ``alpha`` in (0, 1],
``target`` (one angle per joint; default the initial joint angles).

Everything a built-in controller needs is here (the kernels would be a module of their own):
the kernels and their named bundles, the class with its numpy step, compiled step and
parameters. The conformance suite (tests/control/test_conformance.py) registers it and runs it
like the built-ins.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ffsm_pin.control.compiled import CompiledController, kernel_measurement, state_field
from ffsm_pin.control.interface import ControllerContext, Measurement
from ffsm_pin.errors import ParameterError

DEFAULTS = {"kp": 5.0, "kd": 2.0, "alpha": 0.5}


# ---------------------------------------------------------------------- kernels
class PdGains(NamedTuple):
    """The PD's constants as its kernel reads them."""

    kp: float
    kd: float
    alpha: float
    target: np.ndarray  # [rad] (n,)


class PdState(NamedTuple):
    """What a period advances in place."""

    w_f: np.ndarray  # the filtered joint rates [rad/s] (n,)


@njit(cache=True)
def pd_period(gains, meas, state):
    """(u_m, position error) of one period; advances ``state.w_f`` in place."""
    n = meas.q_m.size
    m3 = meas.w.size - n
    u = np.empty(n)
    err = np.empty(n)
    for j in range(n):
        w_f = state.w_f[j] + gains.alpha * (meas.w[m3 + j] - state.w_f[j])
        err[j] = gains.target[j] - meas.q_m[j]
        u[j] = gains.kp * err[j] - gains.kd * w_f
        state.w_f[j] = w_f
    return u, err


# ---------------------------------------------------------------------- the controller
class KitPD(CompiledController):
    """Joint-space PD through the kit (module docstring)."""

    w_f = state_field("w_f", "the filtered joint rates [rad/s]")

    def __init__(self, ctx: ControllerContext, *, backend: str = "auto"):
        self.context = ctx
        self.m3 = ctx.m3
        params = dict(ctx.params)
        unknown = sorted(set(params) - {*DEFAULTS, "target"})
        if unknown:
            raise ParameterError(
                f"controller.params.{unknown[0]}: unknown for the kit PD; valid keys: "
                "alpha, kd, kp, target"
            )
        values = {}
        for key, default in DEFAULTS.items():
            value = params.get(key, default)
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not value > 0:
                raise ParameterError(f"controller.params.{key} = {value!r}: must be a number > 0")
            values[key] = float(value)
        if values["alpha"] > 1.0:
            raise ParameterError(f"controller.params.alpha = {values['alpha']}: must be <= 1")
        target = np.array(params.get("target", ctx.initial.q_m), dtype=float)
        if target.shape != (ctx.n_joints,):
            raise ParameterError(
                f"controller.params.target: {target.size} values, expected {ctx.n_joints}"
            )
        self.gains = PdGains(values["kp"], values["kd"], values["alpha"], target)
        self.signal_shapes = {"position_error": (ctx.n_joints,)}  # recorded as ctrl_...
        self.events: list[str] = []
        self.state = PdState(np.array(ctx.initial.w[ctx.m3 :], dtype=float))
        self.bind_backend(backend, ctx.initial)

    def step_compiled(self, meas: Measurement):
        """The period by :func:`pd_period`."""
        u, err = pd_period(self.gains, Measurement(*kernel_measurement(meas, self.m3)), self.state)
        return u, {"position_error": err}

    def step_numpy(self, meas: Measurement):
        """The period in numpy (the reference of :func:`pd_period`)."""
        g = self.gains
        self.w_f = self.w_f + g.alpha * (meas.w[self.m3 :] - self.w_f)
        err = g.target - meas.q_m
        return g.kp * err - g.kd * self.w_f, {"position_error": err}
