"""The paper's controller (Lu & Jia 2019) behind the :mod:`.interface` (``type = "lu-jia"``).

:class:`LuJiaController` adapts :class:`~.controller.CoordinatedController` (the law itself,
Sections 3.1-3.3) to the one controller interface: it reads its keys (``scheme``, gains,
funnels, estimates, singularity policy, null space) from the scenario, and reports what it has
as standard signals (estimates, w-hat, w~, Eq. (54)'s e, w_mc, sigma_min, damping), recorded at
the start of each period, before the period advances the estimates.
"""

from __future__ import annotations

import numpy as np

from .._docstrings import fill_doc
from ..errors import ParameterError, choices_text
from ._docs import CONTROL_DOC
from .backend import BACKENDS
from .controller import CoordinatedController, check_feasibility
from .gains import step_problems
from .held_body import CaptureEvent, join_held_body
from .interface import ControllerContext, Measurement, SignalLayout, SignalRow
from .kinematic import KinematicInputs
from .lockstep import LockstepHandles, lu_jia_periods
from .lu_jia_params import LuJiaParams
from .physical import margin_kernel
from .saturation import auxiliary_term, demand_problem
from .wheel_law import BaseWheelLaw, wheel_mode


def backend_from(ctx: ControllerContext, backend: str = "auto") -> str:
    """The backend a run asks for: ``backend`` unless it is ``"auto"``, else
    ``[controller.params] backend`` (default ``"auto"``), checked against
    :data:`~.backend.BACKENDS`. The table's other keys are not the paper's controller's (its
    gains, funnels and estimates have tables of their own): they are left for other controllers,
    as a campaign that varies ``controller.type`` shares one table (docs/controllers.md).

    Parameters
    ----------
    ctx : ControllerContext
        Its ``params`` are read.
    backend : str
        The backend asked for by the caller.

    Returns
    -------
    str
        One of :data:`~.backend.BACKENDS`.
    """
    value = ctx.params.get("backend", "auto")
    if value not in BACKENDS:
        raise ParameterError(
            f"controller.params.backend = {value!r}: valid choices: {choices_text(BACKENDS)}"
        )
    return backend if backend != "auto" else value


class LuJiaController:
    """Adaptive prescribed-performance coordinated controller, one implementation of
    :class:`~.interface.Controller` (docs/controllers.md).

    Parameters
    ----------
    ctx : ControllerContext
        The run's context; the law's keys are read from ``ctx.scenario.controller``.
    backend : str
        ``"auto"`` (the compiled period where there is one), ``"numba"`` or ``"numpy"`` (the
        readable reference); see :class:`~.controller.CoordinatedController`. When ``"auto"``,
        the scenario's ``[controller.params] backend`` decides (:func:`backend_from`).

    Attributes
    ----------
    law : CoordinatedController
        The :class:`~.controller.CoordinatedController` itself (estimates, funnels, kinematic law).
    context : ControllerContext
        The context it was built from (to rebuild it, e.g. on another backend).
    """

    needs_funnels = True  # the transformation (21) is undefined outside a funnel
    needs_estimates = True  # [controller.estimates] checked early, before the funnels
    params_model = LuJiaParams  # its own parameters: scenario.controller.lu_jia

    @staticmethod
    def check_task(scenario, n_joints: int, n_task: int, m3: int) -> None:
        """Refuse, before anything is built, a robot with too few joints for the scheme
        (:func:`~.controller.check_feasibility`).

        Parameters
        ----------
        scenario : Scenario
            Its scheme is read.
        n_joints : int
            Joints of the robot.
        n_task : int
            Task components.
        m3 : int
            Attitude coordinates.
        """
        check_feasibility(n_joints, scenario.controller.lu_jia.scheme, n_task=n_task, m3=m3)

    @staticmethod
    def check_gains(scenario, m3: int) -> list[str]:
        """The discrete-time conditions the scenario's gains violate at its dt, one message
        each naming the gain and a value that satisfies it (:func:`~.gains.step_problems`).

        Parameters
        ----------
        scenario : Scenario
            Its ``controller.lu_jia``, performance and dt are read.
        m3 : int
            Attitude coordinates.

        Returns
        -------
        list of str
            One message per violated condition.
        """
        p, perf = scenario.controller.lu_jia, scenario.performance
        attitude = p.scheme != "no-attitude"
        found = step_problems(p.gains, perf.funnel_b, perf.funnel_z, scenario.dt, m3, attitude)
        return [p.text for p in found]

    def __init__(self, ctx: ControllerContext, *, backend: str = "auto"):
        self.context = ctx
        backend = backend_from(ctx, backend)
        sc = ctx.scenario
        p, perf = sc.controller.lu_jia, sc.performance  # its own parameters; the run's funnels
        estimates = ctx.required_estimates()
        if ctx.truth is None:
            raise ValueError("the lu-jia controller needs the context's truth (for Eq. 54's e)")
        self.law = CoordinatedController(
            ctx.model,
            scheme=p.scheme,
            gains=p.gains,
            funnel_b=perf.funnel_b,  # the transformation (21) on the run's funnels
            funnel_z=perf.funnel_z,
            reference=sc.reference,
            base_attitude_ref=ctx.base_attitude_reference,
            singularity=p.policy(perf.singularity_threshold),
            theta_z0=estimates[0],
            theta_d0=estimates[1],
            theta_b0=estimates[2],
            initial=ctx.initial,
            null_space=p.null_space,
            task=ctx.task,
            backend=backend,
            theta_d_true=ctx.truth[1],  # for Eq. (54)'s e alone
            auxiliary=auxiliary_term(
                p.saturation,
                np.full(ctx.n_joints, np.inf) if ctx.torque_limit is None else ctx.torque_limit,
                p.saturation.rates(perf.funnel_b, perf.funnel_z, p.gains.k_d),
                ctx.dt,
            ),
            adaptation=p.adaptation,
            physical_margin=p.physical_margin,
        )
        law = self.law
        self.scheme = p.scheme  # reported as summary.json's scheme
        self.needs_dynamics = not law.adaptive  # known-model: the true M and C w
        self.events = law.events
        self._dt = ctx.dt
        # the period's signals at t, returned as its row (a SignalRow of this declared
        # layout: recorded in one copy)
        self.signal_layout = law.signal_layout
        extra: dict[str, tuple[int, ...]] = {}
        if law.auxiliary is not None:  # and the relaxation at t (ctrl_chi_b, ctrl_chi_z)
            _, chi_b, chi_z = law.auxiliary.parts()
            extra.update(chi_b=chi_b.shape, chi_z=chi_z.shape)
        if law.physical is not None:  # and the distance to the boundary (ctrl_lambda_min_P)
            extra["lambda_min_P"] = ()
        if extra:
            self.signal_layout = SignalLayout({**law.signal_layout.shapes, **extra})
        self.signal_shapes = dict(law.signal_layout.shapes)  # (as before the layout)
        # [controller.params] wheels = "after-capture": the wheels turn the bus back after a
        # grasp (our extension, wheel_law.py); otherwise the wheels' own control
        wheels = sc.robot.wheels
        self._wheels: BaseWheelLaw | None = None
        if wheel_mode(ctx.params, wheels) == "after-capture":
            assert wheels is not None
            rate = float(np.max(perf.funnel_b.beta))  # the base funnel's decay rate [1/s]
            self._wheels = BaseWheelLaw(wheels, ctx.base_attitude_reference, rate, law, ctx.dt)

    @property
    def wheel_torque(self):
        """The optional wheel output (docs/controllers.md): with ``[controller.params] wheels =
        "after-capture"`` the method :meth:`.wheel_law.BaseWheelLaw.torque`, else None (the
        wheels' own ``control`` then acts)."""
        return None if self._wheels is None else self._wheels.torque

    @property
    def sigma_measure(self) -> str:
        """What sigma_min is the smallest singular value of (summary.json's ``min_sigma_of``):
        J_m-hat U-hat of Eq. (36), J_m-hat of Eq. (81) (scheme ``"no-attitude"``), or both
        when the law let the base attitude go during the run (the wheels after a capture)."""
        if self.scheme == "no-attitude":
            return "J_m-hat"
        if not self.law.kinematic.attitude:
            return "J_m-hat U-hat, then J_m-hat (after the grasp: Eq. 81)"
        return "J_m-hat U-hat"

    @property
    def backend(self) -> str:
        """The backend the law runs on: ``"numba"`` (the compiled period) or ``"numpy"``."""
        return self.law.backend

    def torque_demand(self, meas: Measurement) -> str | None:
        """``--check``'s feasibility estimate (:func:`~.saturation.demand_problem`): the law's
        command at ``meas`` (t = 0) against the context's torque limit; advances the law's
        estimates (for a check that never runs the law).

        Parameters
        ----------
        meas : Measurement
            The measurement at t = 0.

        Returns
        -------
        str or None
            The warning's text, or None (within the limits, or no limits).
        """
        limit = self.context.torque_limit
        if limit is None or not np.any(np.isfinite(limit)):
            return None
        u_c = self.law.step_numpy(meas, self._dt).u_m
        return demand_problem(u_c, limit, self.context.scenario.controller.lu_jia.saturation.mode)

    def singular_value(self, meas: Measurement) -> float:
        """sigma_min of the inverted task Jacobian (J_m-hat U-hat, or J_m-hat for Eq. 81) at
        ``meas`` with the current estimates [m]; the distance to a kinematic singularity."""
        law = self.law
        w_b = meas.w[0] if law.m3 == 1 else meas.w[: law.m3]
        x = KinematicInputs(meas.t, meas.q_b, meas.q_m, meas.z_e, law.theta_b, law.theta_z, w_b)
        return float(law.kinematic.evaluate(x)[3])

    def on_capture(self, event: CaptureEvent) -> None:
        """The hand grasped a body (the optional hook, docs/controllers.md): its parameters,
        when the event carries them, join theta_z-hat, theta_d-hat and theta_b-hat
        (:func:`~.held_body.join_held_body`); the adaptation goes on from there. The
        diagnostic e of Eq. (54) takes the merged robot's true theta_d the event carries.

        Parameters
        ----------
        event : CaptureEvent
            The capture.
        """
        join_held_body(self.context, self.law.state, event, self.law.events)
        if event.theta_d_true is not None:  # Eq. (54)'s e from now on: the merged robot's M
            self.law.set_theta_d_true(event.theta_d_true)
        if self._wheels is not None:  # the wheels turn the bus back from the grasp on
            self._wheels.start()

    def step(self, meas: Measurement):
        """u_m for the period [t, t + dt) and the signals at t (before the update), a
        :class:`~ffsm_pin.control.interface.SignalRow` of :attr:`signal_layout`: w~ and e
        of Eq. (54) with the true M and theta_d, the estimates and w-hat, w_mc, sigma_min
        and the damping."""
        law = self.law
        if law.auxiliary is None and law.physical is None:
            out = law.step_row(meas, self._dt)
            return out.u_m, SignalRow(out.signals, self.signal_layout)
        at_t = []  # at t, before the period advances them
        if law.auxiliary is not None:  # chi_b, chi_z
            at_t.append(law.auxiliary.state[law.auxiliary.nb :].copy())
        if law.physical is not None:  # lambda_min of P(theta_d-hat)
            at_t.append(np.array([margin_kernel(law.physical, law.theta_d)]))
        out = law.step_row(meas, self._dt)
        return out.u_m, SignalRow(np.concatenate((out.signals, *at_t)), self.signal_layout)

    # ------------------------------------------------------------------ lock-step
    @property
    def lockstep_obstacle(self) -> str | None:
        """Why this controller's periods cannot be stepped together with other controllers'
        (one compiled call for a batch of runs, :mod:`ffsm_pin.sim.lockstep`), or None: the
        compiled backend, an adaptive scheme, neither the auxiliary system nor the physical
        projection (their signals are made around the period), the true theta_d known."""
        law = self.law
        checks = (
            (law.backend != "numba", "the controller's numpy backend"),
            (not law.adaptive, "the known-model scheme (the true M and C w measured)"),
            (law.auxiliary is not None, "the saturation auxiliary system"),
            (law.physical is not None, "the physical projection of the estimates"),
            (law.theta_d_true is None, "no true theta_d (Eq. 54's signals)"),
            (self._wheels is not None, "the wheels' own law"),
        )
        return next((why for bad, why in checks if bad), None)

    @property
    def period(self) -> float:
        """The control period dt [s] its :meth:`step` takes."""
        return self._dt

    def lockstep_handles(self) -> LockstepHandles:
        """The paper's batch kernel (:func:`.lockstep.lu_jia_periods`) and this run's item for
        it: the compiled period's live box and the signals row it writes
        (:meth:`.compiled_period.CompiledPeriod.period_handles`); :meth:`settle` each period
        that is not plain.

        Returns
        -------
        LockstepHandles
            The item, the kernel, the stand-ins of the true M and C w, the row's width.
        """
        h = self.law.period_handles()
        return LockstepHandles((h.box, h.row), lu_jia_periods, h.M, h.h, h.row.size)

    @fill_doc(CONTROL_DOC)
    def settle(self, meas: Measurement, status: int, idx: int, value: float) -> None:
        """The bookkeeping after a period run through :meth:`lockstep_handles`
        (:meth:`.compiled_period.CompiledPeriod.settle`: the singularity watch, the stops).

        %(params_settle)s
        """
        self.law.settle(meas, status, idx, value, stacklevel=2)

    @property
    def damped_since(self) -> float | None:
        """Since when every period was damped [s], or None (then a plain period needs no
        :meth:`settle`)."""
        return self.law.damped_since
