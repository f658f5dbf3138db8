"""Baseline ``type = "gjm-ct"``: resolved motion through the generalized Jacobian with a
computed-torque joint loop (docs/baselines.md).

Kinematic level (Umetani & Yoshida 1989): with the momentum conserved, the base rate is
``w_b = H_bb^-1 (A_0 - H_bm w_m)`` (Eq. 13 of the paper) and the end-effector rate of Eq. (3)
becomes

    dz_e/dt = J* w_m + d,   J* = J_m - J_b H_bb^-1 H_bm,   d = J_b H_bb^-1 A_0 + (v_0, 0),

J* the generalized Jacobian. The commanded joint rate makes the task error decay at the rate
``k_z``:  ``w_md = J*^+ (dz_d/dt - d - k_z e_z)``, with J*^+ the damped right pseudo-inverse of
the scenario's singularity policy.

Joint level: ``a_m = dw_md/dt + k_v (w_md - w_m)`` (dw_md/dt exact by a complex step along the
measured rates), and the computed torque on the reduced dynamics of Eq. (9a) with the base rows
unactuated: ``a_b = -M_bb^-1 (M_bm a_m + h_b)``, ``u_m = M_mb a_b + M_mm a_m + h_m``.

Every model quantity comes from the scenario's estimates (``[controller.estimates]``), never
adapted; ``initial = "true"`` makes it the known-model baseline. The base attitude is free.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import ParameterError, expected_count
from .backend import choose_backend
from .interface import ControllerContext, Measurement
from .kinematic import COMPLEX_STEP, along_measured_motion, momentum_evaluator, wrap_angle
from .linalg import damped_row_pinv

_H = COMPLEX_STEP  # the step of along_measured_motion


@dataclass(frozen=True)
class GjmGains:
    """Gains of the gjm-ct baseline.

    Attributes
    ----------
    k_z:
        Decay rate of the end-effector error, one per task component [1/s].
    k_v:
        Decay rate of the joint-rate error w_m - w_md [1/s].
    """

    k_z: tuple[float, ...]
    k_v: float

    @classmethod
    def derived(cls, funnel, dt: float, m2: int, n_task: int, drift: float = 0.0) -> GjmGains:
        """Defaults from the scenario's end-effector funnel ``funnel`` (a FunnelParams), the
        control period ``dt`` [s] and a drift speed ``drift`` [m/s] the model may miss (the
        controller passes the larger of ``|v_0-hat|`` and the end-effector speed measured at t = 0).

        Per task component, the larger of

        * ``2 beta_z``: the error decays twice as fast as its funnel, so an error that starts
          inside stays inside when the model is exact;
        * ``drift / (sigma_z rho_z,inf)``: a drift wrong by as much as its estimate leaves a
          steady error drift / k_z (the resolved-rate loop has no integral action), which then
          stays inside the narrower side of the final funnel (position components only).

        The joint loop is ten times faster than the fastest task component, but at most
        0.1 / dt (a tenth of the sampling rate).
        """

        def per_component(x):
            return np.broadcast_to(np.asarray(x, dtype=float), (n_task,))

        beta, sigma, rhoinf = (per_component(x) for x in (funnel.beta, funnel.sigma, funnel.rhoinf))
        k_z = 2.0 * beta
        k_z[:m2] = np.maximum(k_z[:m2], drift / (sigma[:m2] * rhoinf[:m2]))
        return cls(tuple(float(k) for k in k_z), float(min(10.0 * k_z.max(), 0.1 / dt)))


def drift_bound(ctx: ControllerContext, theta_z: np.ndarray) -> float:
    """The drift speed a wrong model may miss [m/s]: the larger of ``|v_0-hat|`` (the estimated
    CoM velocity) and the end-effector speed measured at t = 0."""
    return max(
        float(np.linalg.norm(np.asarray(theta_z)[: ctx.m2])),
        float(np.linalg.norm(np.asarray(ctx.initial.z_e_dot)[: ctx.m2])),
    )


def gains_from(ctx: ControllerContext, derived) -> dict:
    """The ``[controller.params]`` of a baseline, checked: numbers > 0 (or one per component
    where a tuple default says so); unknown keys are an error naming the valid ones."""
    out = {}
    unknown = sorted(set(ctx.params) - set(vars(derived)))
    if unknown:
        raise ParameterError(
            f"controller.params.{unknown[0]}: unknown for controller.type "
            f"{ctx.scenario.controller.type!r}; valid keys: {', '.join(vars(derived))}"
        )
    for key, default in vars(derived).items():
        value = ctx.params.get(key, default)
        arr = np.asarray(value, dtype=float)
        if isinstance(default, tuple):
            arr = np.broadcast_to(arr, (len(default),)) if arr.ndim == 0 else arr
            if arr.shape != (len(default),):
                raise ParameterError(
                    f"controller.params.{key}: {arr.size} values, expected "
                    f"{expected_count(len(default))}"
                )
        if not (np.all(np.isfinite(arr)) and np.all(arr > 0)):
            raise ParameterError(f"controller.params.{key} = {value!r}: must be > 0")
        out[key] = tuple(float(x) for x in arr) if isinstance(default, tuple) else float(arr)
    return out


class ResolvedRates(NamedTuple):
    """Joint and base rates that make the task error decay at k_z (module docstring)."""

    w_m: np.ndarray  # w_md = J*^+ (dz_d/dt - d - k_z e_z) [rad/s]
    w_b: np.ndarray  # the base rate momentum conservation gives with it, H_bb^-1 (A_0 - H_bm w_md)
    sigma_min: float  # smallest singular value of J* [m]
    damping: float  # lambda^2 of its damped pseudo-inverse (0 = undamped)


def resolved_rates(model, momentum, reference, theta_z, theta_b, k_z, threshold, n_task,
                   t, q_b, q_m, z_e) -> ResolvedRates:  # fmt: skip
    """Resolved motion through the generalized Jacobian at a (possibly complex) state, with the
    model of the estimates ``theta_z``, ``theta_b``; ``momentum`` gives H_bb, H_bm, A_0
    (the model itself, or :class:`~.kinematic.ComplexStepMomentum` for spatial models)."""
    m2 = model.m2
    J_b, J_m = model.jacobians(theta_z, q_b, q_m)
    J_b, J_m = J_b[:n_task], J_m[:n_task]
    H_bb, H_bm, A0 = momentum.momentum_matrices(theta_b, q_b, q_m)
    G = np.linalg.solve(H_bb, np.column_stack((H_bm, np.atleast_1d(A0))))
    J_star = J_m - J_b @ G[:, :-1]  # the generalized Jacobian
    drift = J_b @ G[:, -1]
    drift[:m2] = drift[:m2] + theta_z[:m2]  # + (v_0, 0)
    err = np.array(z_e)[:n_task] - reference.ee_pose(t)
    if model.m3 == 1 and n_task > m2:
        err[m2] = wrap_angle(err[m2])
    inv = damped_row_pinv(J_star, threshold)
    w_m = inv.pinv @ (reference.ee_rate(t) - drift - k_z * err)
    w_b = G[:, -1] - G[:, :-1] @ w_m
    return ResolvedRates(w_m, w_b, inv.sigma_min, inv.damping)


class GjmComputedTorque:
    """Generalized-Jacobian resolved motion with a computed-torque joint loop (no adaptation).

    Parameters
    ----------
    ctx:
        The run's context: model, estimates, reference, funnels (for the default gains),
        ``[controller.params]`` (``k_z``, ``k_v`` override the derived gains,
        :meth:`GjmGains.derived`).
    """

    needs_estimates = True
    params_keys = ("k_z", "k_v")  # [controller.params]: the fields of GjmGains
    sigma_measure = "J*-hat"  # its sigma_min: the generalized Jacobian of the estimated model

    def __init__(self, ctx: ControllerContext, *, backend: str = "auto"):
        sc = ctx.scenario
        self.context = ctx  # to rebuild it (e.g. on the other backend)
        self.model = ctx.model
        self.m2, self.m3, self.nt, self.n = ctx.m2, ctx.m3, ctx.n_task, ctx.n_joints
        self.theta_z, self.theta_d, self.theta_b = (np.array(x) for x in ctx.required_estimates())
        drift = drift_bound(ctx, self.theta_z)
        derived = GjmGains.derived(sc.performance.funnel_z, ctx.dt, self.m2, self.nt, drift)
        self.gains = GjmGains(**gains_from(ctx, derived))
        self._k_z = np.array(self.gains.k_z)
        self.reference = sc.reference
        self.q_bd = np.asarray(ctx.base_attitude_reference, dtype=float)
        self.threshold = sc.performance.singularity_threshold  # damped below the run's
        # spatial: H_bb, H_bm of complex-step arguments through the real model
        self._momentum = momentum_evaluator(ctx.model)
        self.events: list[str] = []
        self.backend = choose_backend(backend)
        if self.backend == "numba":
            from ._gjm_kernels import PERIOD

            self._consts = (
                *ctx.model.kernel_constants(), *self.reference.kernel_arrays(), self._k_z,
                float(self.gains.k_v), float(self.threshold), int(self.nt),
            )  # fmt: skip
            self._period = PERIOD[self.m3]
            self.step = self.step_numba  # type: ignore[method-assign]
            # compile (or load) the period now, not in the run's first period (no state moves)
            self.step_numba(ctx.initial)

    def joint_rate_command(self, t, q_b, q_m, z_e):
        """(w_md, sigma_min, damping) at a (possibly complex) state (see the module docstring)."""
        rates = resolved_rates(
            self.model, self._momentum, self.reference, self.theta_z, self.theta_b, self._k_z,
            self.threshold, self.nt, t, q_b, q_m, z_e,
        )  # fmt: skip
        return rates.w_m, rates.sigma_min, rates.damping

    def step(self, meas: Measurement):
        """u_m for the period starting at ``meas.t``, and w_md (as ``w_mc``), sigma_min and
        damping as signals (the compiled period, :meth:`step_numba`, unless
        ``backend="numpy"``: :meth:`step_numpy`)."""
        return self.step_numpy(meas)

    def step_numba(self, meas: Measurement):
        """:meth:`step` by the compiled period (``ffsm_pin/control/_gjm_kernels.py``)."""
        q_b = meas.q_b if self.m3 > 1 else float(meas.q_b)
        u, w_md, sigma, damping = self._period(
            *self._consts, meas.t, q_b, meas.q_m, meas.w, meas.z_e, meas.z_e_dot,
            self.theta_z, self.theta_d, self.theta_b,
        )  # fmt: skip
        return u, {"w_mc": w_md, "sigma_min": sigma, "damping": damping}

    def step_numpy(self, meas: Measurement):
        """:meth:`step` in numpy: the readable reference of the compiled period."""
        m3 = self.m3
        w_m = meas.w[m3:]
        w_md_c, sigma, damping = self.joint_rate_command(*along_measured_motion(meas, m3))
        w_md, w_md_dot = w_md_c.real.copy(), w_md_c.imag / _H
        a_m = w_md_dot + self.gains.k_v * (w_md - w_m)
        M = self.model.mass_matrix(self.theta_d, meas.q_b, meas.q_m)
        h = self.model.velocity_product(self.theta_d, meas.q_b, meas.q_m, meas.w)
        a_b = -np.linalg.solve(M[:m3, :m3], M[:m3, m3:] @ a_m + h[:m3])
        u = M[m3:, :m3] @ a_b + M[m3:, m3:] @ a_m + h[m3:]
        return u, {"w_mc": w_md, "sigma_min": sigma, "damping": damping}


__all__ = [
    "GjmComputedTorque", "GjmGains", "ResolvedRates", "drift_bound", "gains_from",
    "resolved_rates",
]  # fmt: skip
