"""Baseline ``type = "adaptive-ct"``: adaptive computed torque of the Slotine & Li type on the
barycentric regressors (docs/baselines.md).

Reference motion: the resolved rates of :mod:`.gjm_ct` with the current estimates,
``w_r = (w_br, w_mr)`` (w_mr = J*^+ (dz_d/dt - d - k_z e_z), w_br = H_bb^-1 (A_0 - H_bm w_mr)),
and its derivative dw_r/dt by a complex step along the measured rates and the estimates' rates.
With the sliding variable ``s = w - w_r`` (Slotine & Li 1987):

    u_m = [Y theta_d-hat]_m - k_s M-hat_mm s_m,     Y theta_d = M dw_r/dt + C(q, w) w_r,
    dtheta_d-hat/dt = -gamma_d Y_m^T s_m,

``Y_m`` the joint rows of the regressor. Along the closed loop ``M_mm ds_m/dt ~ Y_m theta_d~``,
so the law is stiff with rate gamma_d Y_m^T M_mm^-1 Y_m (large where w_r is, near a fold of
J*): it is stepped linearly implicitly in that mode, with s_m taken at the end of the step, as
the paper's Eq. (51) (:func:`~.adaptation.theta_d_increment`); with an explicit step, case 1
with 10 % parameter error (estimates seed 3) blew up at 12.3 s.

C(q, w) w_r is the symmetric bilinear form of the model's C(q, w) w (Christoffel symbols are
symmetric in their two velocity indices), by polarization
``C(q, w) w_r = 1/4 (Y_h(w + w_r) - Y_h(w - w_r)) theta_d``. The kinematic
estimates theta_b and theta_z adapt by the paper's Eqs. (28) and (42) (gains gamma_1, gamma_2).
No funnel, no filter, no attractive manifold: it is the textbook adaptive law on the same model.
The scenario's ``[controller] adaptation = "physical"`` (with ``physical_margin``) projects each
step of theta_d-hat onto the physical set, as for lu-jia (:mod:`.physical`, docs/robust.md).

The base rows are not actuated, so Slotine & Li's Lyapunov argument covers only the joint rows;
the base follows by momentum conservation. Their argument also needs dM/dt - 2 C skew-symmetric
for the C used in C(q, w) w_r: true of the polarized form on planar robots (generalized
coordinates), not on spatial ones, whose base rate is the angular velocity (quasi-velocities,
tests/control/test_adaptive_ct.py checks both). The tests show what it does on the shipped robots
with 30 % parameter error (tests/control/test_adaptive_ct.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._docstrings import fill_doc
from ._docs import CONTROL_DOC
from .adaptation import theta_b_step, theta_d_increment, theta_z_step
from .adaptive_ct_kernels import PERIOD, AdaptiveCtKernelGains
from .compiled import state_field
from .interface import ControllerContext, Measurement
from .kernels import COMPLEX_STEP, Estimates
from .kinematic import along_measured_motion
from .lockstep import adaptive_ct_periods
from .physical import PhysicalTerm, increment, initial_projection, margin_kernel, physical_term
from .resolved_motion import ResolvedMotionBaseline, rate_gains
from .stops import physical_stop


@dataclass(frozen=True)
@fill_doc(CONTROL_DOC)
class AdaptiveCtGains:
    """Gains of the adaptive-ct baseline.

    Attributes
    ----------
    k_z : tuple of float
        Decay rate of the end-effector error in the reference motion, per component [1/s].
    k_s : float
        Rate of the sliding variable s (the damping is k_s M-hat_mm) [1/s].
    gamma_b, gamma_z, gamma_d : float
        Adaptation gains of theta_b (Eq. 28), theta_z (Eq. 42) and theta_d (gradient law).
    """

    k_z: tuple[float, ...]
    k_s: float
    gamma_b: float
    gamma_z: float
    gamma_d: float

    @classmethod
    def derived(cls, scenario, dt: float, m2: int, n_task: int, drift: float) -> AdaptiveCtGains:
        """k_z and k_s as gjm-ct's k_z and k_v (:func:`~.resolved_motion.rate_gains`, with the
        drift term: without it the 5-link robot leaves its funnel at 7 s while theta_z-hat
        adapts); the adaptation gains are the scenario's gamma_1, gamma_2, gamma_3.

        Parameters
        ----------
        scenario : Scenario
            Its end-effector funnel and the paper's adaptation gains are read.
        %(funnel_task_drift)s

        Returns
        -------
        AdaptiveCtGains
            The default gains.
        """
        k_z, k_s = rate_gains(scenario.performance.funnel_z, dt, m2, n_task, drift)
        p = scenario.controller.lu_jia.gains  # the paper's adaptation gains, as defaults
        return cls(k_z, k_s, p.gamma_1, p.gamma_2, p.gamma_3)


class AdaptiveComputedTorque(ResolvedMotionBaseline):
    """Adaptive computed torque (Slotine & Li type) on the barycentric regressors.

    Parameters
    ----------
    ctx : ControllerContext
        The run's context; ``[controller.params]`` may set ``k_z``, ``k_s``, ``gamma_b``,
        ``gamma_z``, ``gamma_d`` (defaults: :meth:`AdaptiveCtGains.derived`).
    backend : str
        "numba", "numpy" or "auto".
    """

    # [controller.params]: the fields of AdaptiveCtGains
    params_keys = ("k_z", "k_s", "gamma_b", "gamma_z", "gamma_d")
    theta_z = state_field("theta_z", "theta_z-hat (Eq. 42), advanced in place by the kernels")
    theta_d = state_field("theta_d", "theta_d-hat (the gradient law)")
    theta_b = state_field("theta_b", "theta_b-hat (Eq. 28)")

    label = "adaptive-ct"  # (its messages)
    lockstep_kernel = staticmethod(adaptive_ct_periods)  # its periods over a batch (sim.lockstep)

    def __init__(self, ctx: ControllerContext, *, backend: str = "auto"):
        self.take_context(ctx)
        estimates = ctx.required_estimates()
        self.state = Estimates(*(np.array(x, dtype=float) for x in estimates))
        p = ctx.scenario.controller.lu_jia  # the theta_d law: [controller] adaptation
        self.physical: PhysicalTerm | None = None
        if p.adaptation == "physical":
            self.physical = physical_term(ctx.model, self.theta_d, p.physical_margin)
            self.theta_d[:] = initial_projection(self.physical, self.theta_d, self.events)
        derived = AdaptiveCtGains.derived(ctx.scenario, ctx.dt, self.m2, self.nt, self.drift())
        self.set_gains(AdaptiveCtGains, derived)
        self.dt = ctx.dt
        self.signal_shapes = {
            "w_mc": (self.n,), "sigma_min": (), "damping": (),
            "theta_z_hat": (ctx.model.n_z,), "theta_d_hat": (ctx.model.n_d,),
            "theta_b_hat": (ctx.model.n_b,),
        }  # fmt: skip
        if self.physical is not None:  # the estimate's distance to the boundary
            self.signal_shapes["lambda_min_P"] = ()
        self.bind_backend(backend, ctx.initial)

    def prepare_kernels(self) -> None:
        """The compiled period's bundles (:mod:`.adaptive_ct_kernels`): gains and the period's
        constants, the model's and the reference's arrays."""
        g = self.gains
        gains = AdaptiveCtKernelGains(
            self._k_z, float(g.k_s), float(g.gamma_b), float(g.gamma_z), float(g.gamma_d),
            float(self.threshold), int(self.nt), float(self.dt), self.physical,
        )  # fmt: skip
        self.prepare_period(gains, PERIOD)

    def _reference(self, t, q_b, q_m, z_e, theta_z, theta_b):
        r = self.rates(theta_z, theta_b, t, q_b, q_m, z_e)
        return np.concatenate((np.atleast_1d(r.w_b), r.w_m)), r.sigma_min, r.damping

    def _signals_at_t(self) -> dict[str, np.ndarray | float]:
        """The estimates at t, before the period's update, and with ``adaptation =
        "physical"`` their distance to the boundary, lambda_min(P(theta_d-hat)) [kg m^2]
        (``ctrl_lambda_min_P``, as lu-jia records it)."""
        signals: dict[str, np.ndarray | float] = {
            "theta_z_hat": self.theta_z.copy(),
            "theta_d_hat": self.theta_d.copy(),
            "theta_b_hat": self.theta_b.copy(),
        }
        if self.physical is not None:
            signals["lambda_min_P"] = float(margin_kernel(self.physical, self.theta_d))
        return signals

    def step(self, meas: Measurement):
        """u_m for the period starting at ``meas.t``; the estimates advance to t + dt (the
        compiled period, :meth:`step_compiled`, unless ``backend="numpy"``:
        :meth:`step_numpy`)."""
        return super().step(meas)

    def step_compiled(self, meas: Measurement):
        """:meth:`step` by the compiled period (``ffsm_pin/control/adaptive_ct_kernels.py``)."""
        signals = self._signals_at_t()
        u, w_r, sigma, damping, finite, physical = self.run_period(meas)
        if not physical:
            assert self.physical is not None
            raise physical_stop(meas.t, self.physical.max_iter)
        if not finite:
            raise self.nonfinite_stop(meas.t)
        signals.update(w_mc=w_r, sigma_min=sigma, damping=damping)
        return u, signals

    @property
    def lockstep_obstacle(self) -> str | None:
        """As the baselines' (:class:`~.resolved_motion.ResolvedMotionBaseline`), and not with
        ``adaptation = "physical"`` (its stop and its margin are made around the period)."""
        if self.physical is not None:
            return "the physical projection of the estimates"
        return super().lockstep_obstacle

    def step_numpy(self, meas: Measurement):
        """:meth:`step` in numpy: the readable reference of the compiled period."""
        m, g, m3, dt = self.model, self.gains, self.m3, self.dt
        t, q_b, q_m, w = meas.t, meas.q_b, meas.q_m, meas.w
        signals = self._signals_at_t()
        # kinematic estimates, the paper's Eqs. (28) and (42)
        theta_b = theta_b_step(self.theta_b, m.Y_b(q_b, q_m, w), g.gamma_b, dt)
        Y_z = m.Y_z(q_b, q_m, w)[: self.m2]  # the attitude rows are parameter-free
        theta_z = theta_z_step(self.theta_z, Y_z, meas.z_e_dot[: self.m2], g.gamma_z, dt)
        # reference motion and its rate along the measured motion and the estimates' rates
        # (complex step)
        hj = 1j * COMPLEX_STEP
        w_r_c, sigma, damping = self._reference(
            *along_measured_motion(meas, m3),
            self.theta_z + hj * (theta_z - self.theta_z) / dt,
            self.theta_b + hj * (theta_b - self.theta_b) / dt,
        )
        w_r, w_r_dot = w_r_c.real.copy(), w_r_c.imag / COMPLEX_STEP
        s = w - w_r
        # Y theta_d = M dw_r/dt + C(q, w) w_r, the latter by polarization of C(q, x) x
        Y = m.Y_M(q_b, q_m, w_r_dot) + 0.25 * (m.Y_h(q_b, q_m, w + w_r) - m.Y_h(q_b, q_m, w - w_r))
        Y_m, s_m = Y[m3:], s[m3:]
        M_hat = m.mass_matrix(self.theta_d, q_b, q_m)
        u = Y_m @ self.theta_d - self.gains.k_s * (M_hat[m3:, m3:] @ s_m)
        if not np.all(np.isfinite(u)):
            raise self.nonfinite_stop(t)
        # the gradient law, linearly implicit in its stiff mode (as Eq. 51's, theta_d_increment)
        d_theta_d = theta_d_increment(Y_m, s_m, M_hat[m3:, m3:], g.gamma_d, dt)
        if self.physical is not None:  # projected onto the physical set (physical.py)
            d_theta_d, count = increment(self.physical, self.theta_d, d_theta_d)
            if count > self.physical.max_iter:
                raise physical_stop(t, self.physical.max_iter)
        self.theta_d = self.theta_d + d_theta_d
        self.theta_b, self.theta_z = theta_b, theta_z
        signals.update(w_mc=w_r[m3:], sigma_min=sigma, damping=damping)
        return u, signals
