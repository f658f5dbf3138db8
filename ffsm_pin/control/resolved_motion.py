"""Resolved motion through the generalized Jacobian: what both baselines build on
(docs/baselines.md; :mod:`.gjm_ct`, :mod:`.adaptive_ct`).

With the momentum conserved, the base rate is ``w_b = H_bb^-1 (A_0 - H_bm w_m)`` (Eq. 13 of
the paper) and the end-effector rate of Eq. (3) becomes ``dz_e/dt = J* w_m + d`` with the
generalized Jacobian ``J* = J_m - J_b H_bb^-1 H_bm`` and ``d = J_b H_bb^-1 A_0 + (v_0, 0)``
(Umetani & Yoshida 1989). :func:`resolved_rates` gives the joint rates that make the task error
decay at k_z, ``w_md = J*^+ (dz_d/dt - d - k_z e_z)``, and the base rate with them; their
compiled twins are :mod:`.resolved_motion_kernels`. Also here: the default rates
(:func:`rate_gains`), the drift bound they use (:func:`drift_bound`), and the check of a
baseline's ``[controller.params]`` (:func:`gains_from`), and the base both baselines'
controllers share (:class:`ResolvedMotionBaseline`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from .._docstrings import fill_doc
from ..errors import ParameterError, SimulationError, expected_count
from ._docs import CONTROL_DOC
from .compiled import CompiledController, kernel_measurement
from .held_body import CaptureEvent, join_held_body
from .interface import ControllerContext, Measurement
from .kinematic import momentum_evaluator, wrap_angle
from .linalg import damped_row_pinv
from .lockstep import LockstepHandles
from .reference_kernels import reference_arrays


@fill_doc(CONTROL_DOC)
def rate_gains(
    funnel, dt: float, m2: int, n_task: int, drift: float = 0.0
) -> tuple[tuple[float, ...], float]:
    """(k_z per task component, the joint loop's rate) [1/s] from the scenario's end-effector
    funnel ``funnel`` (a FunnelParams), the control period ``dt`` [s] and a drift speed
    ``drift`` [m/s] the model may miss (the larger of ``|v_0-hat|`` and the end-effector speed
    measured at t = 0, :func:`drift_bound`).

    Per task component, the larger of

    * ``2 beta_z``: the error decays twice as fast as its funnel, so an error that starts
      inside stays inside when the model is exact;
    * ``drift / (sigma_z rho_z,inf)``: a drift wrong by as much as its estimate leaves a
      steady error drift / k_z (the resolved-rate loop has no integral action), which then
      stays inside the narrower side of the final funnel (position components only).

    The joint loop is ten times faster than the fastest task component, but at most
    0.1 / dt (a tenth of the sampling rate).

    %(params_funnel)s

    Returns
    -------
    tuple
        (k_z per task component, the joint loop's rate) [1/s].
    """

    def per_component(x):
        return np.broadcast_to(np.asarray(x, dtype=float), (n_task,))

    beta, sigma, rhoinf = (per_component(x) for x in (funnel.beta, funnel.sigma, funnel.rhoinf))
    k_z = 2.0 * beta
    k_z[:m2] = np.maximum(k_z[:m2], drift / (sigma[:m2] * rhoinf[:m2]))
    return tuple(float(k) for k in k_z), float(min(10.0 * k_z.max(), 0.1 / dt))


def drift_bound(ctx: ControllerContext, theta_z: np.ndarray) -> float:
    """The drift speed a wrong model may miss [m/s]: the larger of ``|v_0-hat|`` (the estimated
    CoM velocity) and the end-effector speed measured at t = 0.

    Parameters
    ----------
    ctx : ControllerContext
        The controller's context (m2, the measurement at t = 0).
    theta_z : ndarray
        The kinematic estimate; its first m2 entries are v_0-hat [m/s].

    Returns
    -------
    float
        The drift speed [m/s].
    """
    return max(
        float(np.linalg.norm(np.asarray(theta_z)[: ctx.m2])),
        float(np.linalg.norm(np.asarray(ctx.initial.z_e_dot)[: ctx.m2])),
    )


def gains_from(ctx: ControllerContext, derived) -> dict:
    """The ``[controller.params]`` of a baseline, checked: numbers > 0 (or one per component
    where a tuple default says so); unknown keys are an error naming the valid ones.

    Parameters
    ----------
    ctx : ControllerContext
        Its ``params`` are read.
    derived : GjmGains or AdaptiveCtGains
        The baseline's gains derived from the scenario (their defaults).

    Returns
    -------
    dict
        The gains by name.
    """
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


@fill_doc(CONTROL_DOC)
def resolved_rates(model, momentum, reference, theta_z, theta_b, k_z, threshold, n_task,
                   t, q_b, q_m, z_e) -> ResolvedRates:  # fmt: skip
    """Resolved motion through the generalized Jacobian at a (possibly complex) state, with the
    model of the estimates ``theta_z``, ``theta_b``; ``momentum`` gives H_bb, H_bm, A_0
    (the model itself, or :class:`~.kinematic.ComplexStepMomentum` for spatial models).

    Parameters
    ----------
    model : ReducedModel
        The estimated model.
    momentum : ReducedModel or ComplexStepMomentum
        What gives H_bb, H_bm, A_0 (:func:`~.kinematic.momentum_evaluator`).
    reference : Reference
        The task reference.
    theta_z, theta_b : ndarray
        The estimates.
    k_z : float or ndarray
        Task gain [1/s].
    threshold : float
        Damped least squares below this smallest singular value [m].
    n_task : int
        Task rows.
    %(t_q_z)s

    Returns
    -------
    ResolvedRates
        w_m, w_b [rad/s], sigma_min and the damping.
    """
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


class ResolvedMotionBaseline(CompiledController):
    """What both baselines' controllers share: the run's sizes, reference and singularity
    threshold, the scenario's estimates as the state (theta_z, theta_d, theta_b), the gains
    from ``[controller.params]`` over the derived ones, the resolved rates at the estimates and
    the call of the compiled period on its bundles."""

    needs_estimates = True
    sigma_measure = "J*-hat"  # its sigma_min: the generalized Jacobian of the estimated model
    gains: Any
    theta_z: np.ndarray
    signal_shapes: dict[str, tuple[int, ...]]  # the signals it returns, in the row's order

    def take_context(self, ctx: ControllerContext) -> None:
        """The run's sizes, reference and threshold from ``ctx`` (kept, to rebuild the
        controller, e.g. on the other backend)."""
        self.context = ctx
        self.model = ctx.model
        self.m2, self.m3, self.nt, self.n = ctx.m2, ctx.m3, ctx.n_task, ctx.n_joints
        self.reference = ctx.scenario.reference
        self.threshold = ctx.scenario.performance.singularity_threshold  # damped below the run's
        # spatial: H_bb, H_bm of complex-step arguments through the real model
        self._momentum = momentum_evaluator(ctx.model)
        self.events: list[str] = []

    def on_capture(self, event: CaptureEvent) -> None:
        """The hand grasped a body (the optional hook, docs/controllers.md): its parameters,
        when the event carries them, join the estimates (:func:`~.held_body.join_held_body`):
        gjm-ct's fixed model is updated, adaptive-ct adapts on from there.

        Parameters
        ----------
        event : CaptureEvent
            The capture.
        """
        join_held_body(self.context, self.state, event, self.events)

    def drift(self) -> float:
        """:func:`drift_bound` at the estimate theta_z (the gains' default derivation)."""
        return drift_bound(self.context, self.theta_z)

    def set_gains(self, gains_class: type, derived: Any) -> None:
        """The gains: ``[controller.params]`` over the ``derived`` ones (:func:`gains_from`).

        Parameters
        ----------
        gains_class : type
            The baseline's gains dataclass (``GjmGains``, ``AdaptiveCtGains``).
        derived : gains_class
            The gains derived from the scenario (docs/gains.md), overridden key by key.
        """
        self.gains = gains_class(**gains_from(self.context, derived))
        self._k_z = np.array(self.gains.k_z)

    def rates(self, theta_z, theta_b, t, q_b, q_m, z_e) -> ResolvedRates:
        """:func:`resolved_rates` of this controller at the estimates ``theta_z``, ``theta_b``.

        Parameters
        ----------
        theta_z, theta_b : ndarray
            The kinematic (Eq. 4) and momentum (Eq. 14) parameter estimates.
        t : float or complex
            Time [s].
        q_b : float, complex or ndarray
            Base attitude: planar angle [rad], spatial MRP.
        q_m : ndarray, shape (n,)
            Joint angles [rad].
        z_e : ndarray, shape (n_task,)
            End-effector pose (or position) as measured.

        Returns
        -------
        ResolvedRates
            The commanded joint rates w_md [rad/s], the base rate they imply, sigma_min [m] of
            the estimated generalized Jacobian and the damping applied.
        """
        return resolved_rates(
            self.model, self._momentum, self.reference, theta_z, theta_b, self._k_z,
            self.threshold, self.nt, t, q_b, q_m, z_e,
        )  # fmt: skip

    def prepare_period(self, gains: tuple, periods: dict) -> None:
        """The compiled period's bundles: the model's constants, ``gains`` (the period's named
        gains), the reference's arrays, and the period of this geometry from ``periods``.

        Parameters
        ----------
        gains : NamedTuple
            The period's gains bundle (``GjmKernelGains``, ``AdaptiveCtKernelGains``).
        periods : dict
            The compiled period per attitude size m3 (1 planar, 3 spatial).
        """
        self._geo = self.context.model.kernel_constants()
        self._fields = (tuple(gains), tuple(reference_arrays(self.reference)))
        self._period = periods[self.m3]

    # ------------------------------------------------------------------ lock-step
    #: What its messages call it.
    label = "controller"
    #: The batch kernel (:mod:`.lockstep`); None: no lock-step.
    lockstep_kernel: Any = None

    @property
    def lockstep_obstacle(self) -> str | None:
        """Why this controller's periods cannot be stepped together with others' (one compiled
        call for a batch of runs, :mod:`ffsm_pin.sim.lockstep`), or None."""
        if self.lockstep_kernel is None:
            return f"controller {type(self).__name__}: no batch kernel"
        if self.backend != "numba":
            return "the controller's numpy backend"
        return None

    @property
    def period(self) -> float:
        """The control period dt [s] its :meth:`step` takes."""
        return self.context.dt

    def lockstep_handles(self) -> LockstepHandles:
        """The batch kernel of this geometry and this run's item for it: the compiled
        period's bundles and the live estimates (:mod:`.lockstep`).

        Returns
        -------
        LockstepHandles
            The item, the kernel, no true M and C w, the signals' row width.
        """
        gains, ref = self._fields
        width = sum(int(np.prod(shape)) for shape in self.signal_shapes.values())
        item = (self._geo, gains, ref, tuple(self.state))
        return LockstepHandles(item, self.lockstep_kernel, None, None, width)

    @fill_doc(CONTROL_DOC)
    def settle(self, meas: Measurement, status: int, idx: int, value: float) -> None:
        """The stop of a period run through :meth:`lockstep_handles` whose status is not
        plain (:meth:`nonfinite_stop`).

        %(params_settle)s
        """
        raise self.nonfinite_stop(meas.t)

    def nonfinite_stop(self, t: float) -> SimulationError:
        """The stop of a torque that is not finite at ``t`` [s] (a controller that checks its
        torque itself; the run checks every torque too).

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        SimulationError
            The stop (cause ``"nonfinite"``).
        """
        return SimulationError(
            f"t = {t:.4f} s: the {self.label} torque became non-finite", time=t, cause="nonfinite"
        )

    #: Since when every period was damped (None: the baselines keep no singularity watch).
    damped_since: float | None = None

    def run_period(self, meas: Measurement) -> tuple:
        """The compiled period at ``meas`` on the bundles of :meth:`prepare_period` and the
        state (the estimates)."""
        gains, ref = self._fields
        return self._period(
            self._geo, gains, ref, kernel_measurement(meas, self.m3), tuple(self.state)
        )


__all__ = [
    "ResolvedMotionBaseline", "ResolvedRates", "drift_bound", "gains_from", "rate_gains",
    "resolved_rates",
]  # fmt: skip
