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

import numpy as np

from .._docstrings import fill_doc
from ._docs import CONTROL_DOC
from .compiled import state_field
from .gjm_ct_kernels import PERIOD, GjmKernelGains
from .interface import ControllerContext, Measurement
from .kernels import COMPLEX_STEP, Estimates
from .kinematic import along_measured_motion
from .lockstep import gjm_ct_periods
from .resolved_motion import (
    ResolvedMotionBaseline,
    ResolvedRates,
    drift_bound,
    gains_from,
    rate_gains,
    resolved_rates,
)


@dataclass(frozen=True)
class GjmGains:
    """Gains of the gjm-ct baseline.

    Attributes
    ----------
    k_z : tuple of float
        Decay rate of the end-effector error, one per task component [1/s].
    k_v : float
        Decay rate of the joint-rate error w_m - w_md [1/s].
    """

    k_z: tuple[float, ...]
    k_v: float

    @classmethod
    @fill_doc(CONTROL_DOC)
    def derived(cls, funnel, dt: float, m2: int, n_task: int, drift: float = 0.0) -> GjmGains:
        """Defaults from the scenario's end-effector funnel ``funnel`` (a FunnelParams), the
        control period ``dt`` [s] and a drift speed ``drift`` [m/s] the model may miss (the
        controller passes the larger of ``|v_0-hat|`` and the end-effector speed measured at
        t = 0): :func:`~.resolved_motion.rate_gains`, k_v its joint loop's rate.

        %(params_funnel)s

        Returns
        -------
        GjmGains
            The default gains.
        """
        return cls(*rate_gains(funnel, dt, m2, n_task, drift))


class GjmComputedTorque(ResolvedMotionBaseline):
    """Generalized-Jacobian resolved motion with a computed-torque joint loop (no adaptation).

    Parameters
    ----------
    ctx : ControllerContext
        The run's context: model, estimates, reference, funnels (for the default gains),
        ``[controller.params]`` (``k_z``, ``k_v`` override the derived gains,
        :meth:`GjmGains.derived`).
    backend : str
        "numba", "numpy" or "auto".
    """

    params_keys = ("k_z", "k_v")  # [controller.params]: the fields of GjmGains
    theta_z = state_field("theta_z", "theta_z-hat, the scenario's estimate")
    theta_d = state_field("theta_d", "theta_d-hat, the scenario's estimate")
    theta_b = state_field("theta_b", "theta_b-hat, the scenario's estimate")

    label = "gjm-ct"  # (its messages)
    lockstep_kernel = staticmethod(gjm_ct_periods)  # its periods over a batch (sim.lockstep)

    def __init__(self, ctx: ControllerContext, *, backend: str = "auto"):
        self.take_context(ctx)
        self.state = Estimates(*(np.array(x) for x in ctx.required_estimates()))  # not adapted
        funnel_z = ctx.scenario.performance.funnel_z
        self.set_gains(GjmGains, GjmGains.derived(funnel_z, ctx.dt, self.m2, self.nt, self.drift()))
        self.q_bd = np.asarray(ctx.base_attitude_reference, dtype=float)
        self.signal_shapes = {"w_mc": (self.n,), "sigma_min": (), "damping": ()}
        self.bind_backend(backend, ctx.initial)

    def prepare_kernels(self) -> None:
        """The compiled period's bundles (:mod:`.gjm_ct_kernels`): gains, the model's and the
        reference's arrays."""
        gains = GjmKernelGains(
            self._k_z, float(self.gains.k_v), float(self.threshold), int(self.nt)
        )
        self.prepare_period(gains, PERIOD)

    @fill_doc(CONTROL_DOC)
    def joint_rate_command(self, t, q_b, q_m, z_e):
        """(w_md, sigma_min, damping) at a (possibly complex) state (see the module docstring).

        Parameters
        ----------
        %(t_q_z)s
        """
        rates = self.rates(self.theta_z, self.theta_b, t, q_b, q_m, z_e)
        return rates.w_m, rates.sigma_min, rates.damping

    def step(self, meas: Measurement):
        """u_m for the period starting at ``meas.t``, and w_md (as ``w_mc``), sigma_min and
        damping as signals (the compiled period, :meth:`step_compiled`, unless
        ``backend="numpy"``: :meth:`step_numpy`)."""
        return super().step(meas)

    def step_compiled(self, meas: Measurement):
        """:meth:`step` by the compiled period (``ffsm_pin/control/gjm_ct_kernels.py``)."""
        u, w_md, sigma, damping = self.run_period(meas)
        return u, {"w_mc": w_md, "sigma_min": sigma, "damping": damping}

    def step_numpy(self, meas: Measurement):
        """:meth:`step` in numpy: the readable reference of the compiled period."""
        m3 = self.m3
        w_m = meas.w[m3:]
        w_md_c, sigma, damping = self.joint_rate_command(*along_measured_motion(meas, m3))
        w_md, w_md_dot = w_md_c.real.copy(), w_md_c.imag / COMPLEX_STEP
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
