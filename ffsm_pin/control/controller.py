"""The adaptive prescribed-performance coordinated controller (Lu & Jia 2019, Section 3).

:class:`CoordinatedController` runs one control period in :meth:`~CoordinatedController.step`:

1. adaptation of theta_b (Eq. 28) and theta_z (Eq. 42), closed form;
2. kinematic level: w_mc and dw_mc/dt (Eqs. 25+36, or 81), exact by complex step;
3. dynamic level: filter (46) with eta_x (52), input u_m (60-64), filtered regressor (50),
   adaptation of theta_d (51), semi-implicit.

Schemes (Section 4): ``"ppc"`` (case 1), ``"no-ppc"`` (case 2: psi = e, Phi = 1,
drho/dt = 0), ``"no-attitude"`` (case 3: Eq. 81), and ``"known-model"`` (the baseline: true
parameters, no adaptation, and a computed-torque dynamic level with Pinocchio's reduced M and
C w in place of the filter).

A run stops in a controlled way (:class:`~ffsm_pin.errors.SimulationError`, with time and
cause) when a funnel whose transformation the scheme uses is left, when the arm stays near a
singularity longer than the policy allows, when an estimate degenerates, or when a number
becomes non-finite. Damping of the pseudo-inverse is announced by a
:class:`SingularityWarning`.
"""

from __future__ import annotations

import numpy as np

from .._docstrings import fill_doc
from ..errors import ParameterError, SimulationError, choices_text
from ..model.interface import ReducedModel
from ..model.planar import BarycentricModel
from ..model.spatial import SpatialBarycentricModel
from ._docs import CONTROL_DOC
from .adaptation import (
    regressor_filter_step,
    theta_b_step,
    theta_d_increment,
    theta_z_step,
)
from .backend import BACKENDS
from .compiled import CompiledController, state_field
from .compiled_period import CompiledPeriod
from .funnel import Funnel, FunnelExit, FunnelParams, IdentityFunnel
from .gains import Gains, SingularityPolicy
from .interface import Measurement, SignalLayout
from .kernels import COMPLEX_STEP
from .kinematic import KinematicInputs, KinematicLaw, attitude_matrix, task_errors, task_size
from .manifold import manifold_input
from .null_space import NullSpace
from .period import PeriodState
from .physical import ADAPTATIONS, PhysicalTerm, increment, initial_projection, physical_term
from .saturation import AuxiliarySystem, AuxiliaryTerm
from .schemes import (
    ATTITUDE_SIZE,
    SCHEMES,
    TASK_SIZE,
    ControlOutput,
    RowOutput,
    check_feasibility,
)
from .stops import (
    SingularityWarning,
    SingularityWatch,
    collapse_stop,
    component_names,
    inertia_stop,
    nonfinite_stop,
    physical_stop,
)


@fill_doc(CONTROL_DOC)
class CoordinatedController(CompiledPeriod, CompiledController):
    """Adaptive prescribed-performance coordinated controller, planar or spatial.

    Parameters
    ----------
    model : ReducedModel
        The reduced model of the robot (:class:`~ffsm_pin.model.interface.ReducedModel`:
        planar or spatial; regressors and estimate evaluators).
    scheme : str
        One of :data:`SCHEMES`.
    gains : Gains
        The gains of the law.
    funnel_b, funnel_z : FunnelParams
        The attitude and end-effector funnels (Eqs. 16-18).
    reference : Reference
        The task reference (``ee_pose(t)``, ``n_components``).
    base_attitude_ref : float or ndarray
        Desired base attitude q_bd [rad] (planar) or MRP (spatial).
    singularity : SingularityPolicy
        Damped least squares and the stop near a singular ``J_m-hat U-hat``.
    theta_z0, theta_d0, theta_b0 : array_like
        Initial estimates (the true vectors for ``"known-model"``).
    initial : Measurement
        The measurement at t = 0; fixes the side of each funnel (Eqs. 16-17).
    backend : str
        "numba", "numpy" or "auto".
    null_space : NullSpace or None
        Optional null-space term added to Eq. (36) (beyond the paper,
        :mod:`.null_space`); None = the paper's law.
    task : str
        ``"pose"`` (m2 + m3 components) or ``"position"`` (m2).
    theta_d_true : array_like or None
        The true theta_d, for the diagnostic e of Eq. (54) (:attr:`ControlOutput.e`, with the
        true M); never read by the law. None: e is not computed.
    auxiliary : AuxiliaryTerm or None
        The auxiliary system of ``saturation = "auxiliary"`` (:mod:`.saturation`); None: the
        paper's law.
    adaptation : str
        The law of theta_d-hat, one of :data:`~.physical.ADAPTATIONS` (``"physical"``: Eq. 51
        projected onto the physical set, :mod:`.physical`).
    physical_margin : float or None
        eps of the physical set (None: derived, :func:`~.physical.physical_term`).
    """

    def __init__(
        self,
        model: ReducedModel,
        *,
        scheme: str,
        gains: Gains,
        funnel_b: FunnelParams,
        funnel_z: FunnelParams,
        reference,
        base_attitude_ref: float | np.ndarray,
        singularity: SingularityPolicy,
        theta_z0,
        theta_d0,
        theta_b0,
        initial: Measurement,
        backend: str = "auto",
        null_space: NullSpace | None = None,
        task: str = "pose",
        theta_d_true=None,
        auxiliary: AuxiliaryTerm | None = None,
        adaptation: str = "gradient",
        physical_margin: float | None = None,
    ):
        self.m2, self.m3 = model.m2, model.m3
        self.task = task
        self.n_task = task_size(self.m2, self.m3, task)
        check_feasibility(model.n_joints, scheme, n_task=self.n_task, m3=self.m3)
        if backend not in BACKENDS:
            raise ParameterError(f"unknown backend {backend!r}; valid choices: {BACKENDS}")
        self.model = model
        self.scheme = scheme
        self.gains = gains
        self.policy = singularity
        self.reference = reference
        self.q_bd = np.atleast_1d(np.asarray(base_attitude_ref, dtype=float))
        for name, size, want in (
            ("base_attitude_ref", self.q_bd.size, self.m3),
            ("reference.ee", reference.n_components, self.n_task),
            ("funnel_b", funnel_b.size, self.m3),
            ("funnel_z", funnel_z.size, self.n_task),
        ):
            if size != want:
                raise ParameterError(
                    f"{name} has {size} components, the {task!r} task of this robot needs {want}"
                )
        err_b, err_z = task_errors(
            reference, self.q_bd, initial.t, initial.q_b, initial.z_e, self.m3
        )
        funnel_cls = IdentityFunnel if scheme == "no-ppc" else Funnel
        self.funnel_b = funnel_cls(funnel_b, err_b)
        self.funnel_z = funnel_cls(funnel_z, err_z)
        self.kinematic = KinematicLaw(
            model,
            gains,
            self.funnel_b,
            self.funnel_z,
            reference,
            self.q_bd,
            singularity.threshold,
            attitude=scheme != "no-attitude",
            null_space=null_space,
            null_space_center=initial.q_m,
            task=task,
        )
        self.null_space = self.kinematic.null_space
        theta_z = np.array(theta_z0, dtype=float)
        theta_d = np.array(theta_d0, dtype=float)
        theta_b = np.array(theta_b0, dtype=float)
        for name, vec, size in (
            ("theta_z", theta_z, model.n_z),
            ("theta_d", theta_d, model.n_d),
            ("theta_b", theta_b, model.n_b),
        ):
            if vec.shape != (size,):
                raise ParameterError(
                    f"{name} estimate has {vec.size} entries, the robot's layout needs {size}"
                )
        self.theta_d_true = None if theta_d_true is None else np.array(theta_d_true, dtype=float)
        if self.theta_d_true is not None and self.theta_d_true.shape != (model.n_d,):
            raise ParameterError(
                f"theta_d_true has {self.theta_d_true.size} entries, the robot's layout needs "
                f"{model.n_d}"
            )
        self.adaptive = scheme != "known-model"
        self.events: list[str] = []
        self.physical = self._physical(adaptation, physical_margin, theta_d)
        if self.physical is not None:
            theta_d = initial_projection(self.physical, theta_d, self.events)
        nb = model.n_joints + self.m3
        #: the signals a period reports at t, as one row (:attr:`ControlOutput.signals`)
        self.signal_layout = SignalLayout({
            "w_tilde": (nb,), "e": (nb,), "theta_z_hat": (model.n_z,),
            "theta_d_hat": (model.n_d,), "theta_b_hat": (model.n_b,), "w_hat": (nb,),
            "w_mc": (model.n_joints,), "sigma_min": (), "damping": (),
        })  # fmt: skip
        #: what a period advances: the estimates, w-hat(0) = 0 and Y_df(0) = 0 (Table 2)
        self.state = PeriodState(theta_z, theta_d, theta_b, np.zeros(nb), np.zeros((nb, model.n_d)))
        self._initial = initial
        self._watch = SingularityWatch(singularity, self.events)
        self.auxiliary = None if auxiliary is None else AuxiliarySystem(
            auxiliary, nb, self.m3, self.n_task
        )  # fmt: skip
        self.bind_backend(backend, initial, 1e-3)

    # ------------------------------------------------------------------ the state
    theta_z = state_field("theta_z", "theta_z-hat (Eq. 42), advanced in place by the kernels")
    theta_d = state_field("theta_d", "theta_d-hat (Eq. 51)")
    theta_b = state_field("theta_b", "theta_b-hat (Eq. 28)")
    w_hat = state_field("w_hat", "the filter's state w-hat (Eq. 46)")
    Y_df = state_field("Y_df", "the filtered regressor Y_df (Eq. 50)")

    @property
    def damped_since(self) -> float | None:
        """The time [s] since which damped least squares has been active without a break (the
        period's damping > 0 at every period since), or None when the last period was not
        damped; a stretch longer than the singularity policy's ``max_damped_time`` stops the
        run."""
        return self._watch.since

    def _physical(self, adaptation: str, margin: float | None, theta_d) -> PhysicalTerm | None:
        """The projection of ``adaptation = "physical"`` (None: the paper's Eq. 51, or the
        known-model scheme, which does not adapt)."""
        if adaptation not in ADAPTATIONS:
            raise ParameterError(
                f"controller.adaptation = {adaptation!r}: valid choices: "
                f"{choices_text(ADAPTATIONS)}"
            )
        if adaptation == "gradient" or not self.adaptive:
            return None
        return physical_term(self.model, theta_d, margin)

    # ------------------------------------------------------------------ backend
    def choose(self, backend: str) -> str:
        """'numba' (the compiled period, :mod:`.period`) unless 'numpy' is asked.

        The compiled period serves planar and spatial robots with every scheme, task and
        null-space option, the known-model baseline included (since issue 38 judged results
        by their rounding envelope: its built-in planar case parts from the numpy reference
        by less than twice its own one-ulp envelope over 30 s, docs/REPRODUCTION.md).
        """
        spatial = isinstance(self.model, SpatialBarycentricModel)
        planar = isinstance(self.model, BarycentricModel)
        if backend == "numba" and not (planar or spatial):
            raise ParameterError(
                "backend 'numba' is the compiled period of the package's planar and spatial "
                f"models, not of {type(self.model).__name__}; use 'numpy' or 'auto'"
            )
        if backend == "numpy" or not (spatial or planar):
            return "numpy"
        return "numba"

    def bind(self) -> None:
        """Bind :meth:`step` and :meth:`step_row` to the backend's."""
        super().bind()
        self.step_row = self._row_compiled if self.backend == "numba" else self._row_numpy  # type: ignore[method-assign]

    # ------------------------------------------------------------------ one period
    def step_row(self, meas: Measurement, dt: float) -> RowOutput:
        """The same period as :meth:`step`, returning only u_m and the signals' row.

        This is what :class:`~.lu_jia.LuJiaController` hands back each period. On the
        compiled backend both are copies of the period's outputs and the other named outputs
        of :class:`ControlOutput` are not made.

        %(params_step_period)s

        Returns
        -------
        RowOutput
            u_m [N m] for [t, t + dt), and the row of :attr:`signal_layout` at t.

        Raises
        ------
        ParameterError
            The controller was made without ``theta_d_true``.
        SimulationError
            The stops of :meth:`step`: a funnel exit, a collapse of H_bm-hat, damped least
            squares active for longer than the policy's ``max_damped_time``, a singular
            filter, an inertia that is not positive definite, a torque not finite.
        """
        if self.backend == "numba":
            return self._row_compiled(meas, dt)
        return self._row_numpy(meas, dt)

    def _row_numpy(self, meas: Measurement, dt: float) -> RowOutput:
        self._require_truth()
        full = self._numpy_period(meas, dt)
        assert full.signals is not None  # (theta_d_true is given)
        return RowOutput(full.u_m, full.signals)

    def step_numpy(self, meas: Measurement, dt: float) -> ControlOutput:
        """:meth:`step` by the readable numpy reference.

        %(sections_step_period)s
        """
        return self._numpy_period(meas, dt)

    def _numpy_period(self, meas: Measurement, dt: float) -> ControlOutput:
        m, g, m3 = self.model, self.gains, self.m3
        # the estimates and w-hat at t (the period replaces them, never writes into them)
        at_t = (self.theta_z, self.theta_d, self.theta_b, self.w_hat)
        t, q_b, q_m, w = meas.t, meas.q_b, meas.q_m, meas.w
        w_b = w[:m3]

        # 1. kinematic-level adaptation, Eqs. (28) and (42)
        if self.adaptive:
            theta_b = theta_b_step(self.theta_b, m.Y_b(q_b, q_m, w), g.gamma_1, dt)
            Y_z = m.Y_z(q_b, q_m, w)[: self.m2]  # the attitude rows are parameter-free
            theta_z = theta_z_step(self.theta_z, Y_z, meas.z_e_dot[: self.m2], g.gamma_2, dt)
        else:
            theta_b, theta_z = self.theta_b, self.theta_z

        # 2. kinematic level, Eqs. (25)+(36) or (81), and d w_mc / dt
        q_b_rate = w[0] if m3 == 1 else attitude_matrix(q_b, m3) @ w_b  # Eq. (1)
        z_e, z_e_dot, q_bd, aux = meas.z_e, meas.z_e_dot, self.q_bd, self.auxiliary
        if aux is not None:  # the relaxed errors e_b - chi_b, e_z - chi_z (saturation.py)
            maps = self._auxiliary_maps(meas, theta_d=self.theta_d, theta_z=self.theta_z)
            (chi_v, chi_b, chi_z), chi_dot = aux.parts(), aux.rates(*maps[1:])
            z_e, z_e_dot, nt = (
                np.array(z_e, dtype=float),
                np.array(z_e_dot, dtype=float),
                chi_z.size,
            )
            z_e[:nt], z_e_dot[:nt] = z_e[:nt] - chi_z, z_e_dot[:nt] - chi_dot[2]
            self.kinematic.q_bd = (q_bd + chi_b) + 1j * COMPLEX_STEP * chi_dot[1]
        x = KinematicInputs(t, q_b, q_m, z_e, self.theta_b, self.theta_z,
                            w[0] if m3 == 1 else w_b)  # fmt: skip
        rates = KinematicInputs(
            1.0, q_b_rate, w[m3:], z_e_dot,
            (theta_b - self.theta_b) / dt, (theta_z - self.theta_z) / dt, 0.0,
        )  # fmt: skip
        try:
            kc = self.kinematic.command(x, rates)
        except FunnelExit as exc:
            raise self.funnel_stop(meas, exc) from None
        finally:
            self.kinematic.q_bd = q_bd
        # (the warning points at the caller of step / step_row)
        self._watch.update(t, kc.sigma_min, kc.damping, stacklevel=3)
        if self.kinematic.attitude and not kc.H_bm_norm > 1e-9:  # (Eq. 81: no H_bm-hat)
            raise collapse_stop(t, kc.H_bm_norm)

        # 3. dynamic level, Eqs. (46), (50)-(52), (60)-(64)
        if self.adaptive:
            w_tilde = w - self.w_hat
            M_hat = m.mass_matrix(self.theta_d, q_b, q_m)
            if np.any(np.linalg.eigvalsh(M_hat) <= 0):
                raise inertia_stop(t)
            Y_Mdot, Y_h = m.velocity_regressors(q_b, q_m, w, w_tilde)
            d_theta_d = theta_d_increment(self.Y_df, w_tilde, M_hat, g.gamma_3, dt)
            if self.physical is not None:  # projected onto the physical set (physical.py)
                d_theta_d, count = increment(self.physical, self.theta_d, d_theta_d)
                if count > self.physical.max_iter:
                    raise physical_stop(t, self.physical.max_iter)
            eta_x = -self.Y_df @ d_theta_d / dt  # Eq. (52)
            r = (Y_Mdot - Y_h) @ self.theta_d + g.k_de * (M_hat @ w_tilde) + eta_x
            w_hat = self.w_hat
        else:  # known model: computed torque on the true reduced dynamics
            w_tilde = np.zeros_like(w)
            assert meas.M is not None and meas.h is not None  # the sensor's full model
            M_hat, r, w_hat = meas.M, -meas.h, w
        w_dyn, w_dyn_dot = kc.w_mc, kc.w_mc_dot
        if aux is not None:  # the dynamic level tracks w_mc + chi_v (the deficit let go)
            w_dyn, w_dyn_dot = kc.w_mc + chi_v[m3:], kc.w_mc_dot + chi_dot[0][m3:]
        mi = manifold_input(M_hat, r, w_hat, w_dyn, w_dyn_dot, kc.dwmc_dwb, g.k_d, t)
        if not np.all(np.isfinite(mi.u_m)):
            raise nonfinite_stop(t)
        u_m = mi.u_m  # with the option: the feedforward the actuators deliver (saturation.py)
        if aux is not None:
            u_m = aux.command(mi.u_m, w_dyn_dot, maps[0], kc.dwmc_dwb)
        e = None  # Eq. (54) with the true M and theta_d, before the estimates advance
        if self.theta_d_true is not None:
            if self.adaptive:
                M_true = m.mass_matrix(self.theta_d_true, q_b, q_m)
                e = M_true @ w_tilde + self.Y_df @ (self.theta_d_true - self.theta_d)
            else:  # w~ = 0, Y_df = 0 and theta_d-hat = theta_d
                e = np.zeros_like(w)

        signals = None  # one row of signal_layout
        if e is not None:
            signals = np.concatenate((w_tilde, e, *at_t, kc.w_mc, [kc.sigma_min, kc.damping]))

        # advance the controller's states to t + dt
        if self.adaptive:
            Y_dc = m.Y_M(q_b, q_m, mi.w_hat_dot - g.k_de * w_tilde) - Y_Mdot + Y_h  # Eq. (49)
            self.Y_df = regressor_filter_step(self.Y_df, Y_dc, g.k_de, dt)  # Eq. (50)
            self.theta_d = self.theta_d + d_theta_d  # Eq. (51)
            self.w_hat = self.w_hat + dt * mi.w_hat_dot  # Eq. (46)
            self.theta_b, self.theta_z = theta_b, theta_z
        else:
            self.w_hat = w + dt * mi.w_hat_dot
        if aux is not None:  # the excess drives chi; the filter integrates the torque applied
            dw = aux.advance(mi.u_m, u_m, *maps)
            if np.any(dw != 0.0):
                self.w_hat = self.w_hat + dt * dw
        return ControlOutput(
            u_m=u_m,
            w_mc=kc.w_mc,
            w_mc_dot=mi.w_mc_dot,
            err_b=self.kinematic.errors(t, q_b, meas.z_e)[0],
            err_z=kc.funnel_z.error,
            w_tilde=w_tilde,
            sigma_min=kc.sigma_min,
            damping=kc.damping,
            funnel_b=kc.funnel_b,
            funnel_z=kc.funnel_z,
            e=e,
            signals=signals,
        )

    def _auxiliary_maps(self, meas: Measurement, *, theta_d, theta_z) -> tuple:
        """(M-hat, J-hat over (w_b, w_m), L_b) at ``meas`` (the auxiliary system's maps,
        :func:`.saturation_kernels.auxiliary_maps`); the true M for the known-model scheme."""
        m = self.model
        M = m.mass_matrix(theta_d, meas.q_b, meas.q_m) if self.adaptive else meas.M
        J = np.hstack(m.jacobians(theta_z, meas.q_b, meas.q_m))[: self.n_task]
        return M, np.real(J), np.real(attitude_matrix(meas.q_b, self.m3))

    # ------------------------------------------------------------------ stops
    def funnel_stop(self, meas: Measurement, exc: FunnelExit) -> SimulationError:
        """The stop of a funnel exit at ``meas`` (which funnel, which component, the bounds).

        Parameters
        ----------
        meas : Measurement
            The measurement at the exit.
        exc : FunnelExit
            The exit.

        Returns
        -------
        SimulationError
            The stop (cause ``"funnel"``).
        """
        t = meas.t
        # which funnel: the attitude funnel is evaluated after the end-effector one
        err_b, err_z = task_errors(self.reference, self.q_bd, t, meas.q_b, meas.z_e, self.m3)
        if not self.funnel_z.inside(t, err_z):
            name = component_names(self.m2, self.m3)[exc.index]
            what = f"end-effector error component {exc.index} ({name})"
            which = "z"
        else:
            what = "base attitude error" + (f" component {exc.index}" if self.m3 > 1 else "")
            which = "b"
        note = ""
        if self._watch.since is not None:
            note = f"; the arm has been near a singularity since t = {self._watch.since:.3f} s"
        return SimulationError(
            f"t = {t:.4f} s: {what} = {exc.value:.5g} left its funnel "
            f"({exc.lower:.5g}, {exc.upper:.5g}); the transformation (21) is undefined{note}",
            time=t,
            cause="funnel",
            funnel=which,
        )


__all__ = [  # (the schemes' and the stops' names too, where they were first defined)
    "ATTITUDE_SIZE", "SCHEMES", "TASK_SIZE", "ControlOutput", "CoordinatedController",
    "Measurement", "RowOutput", "SingularityWarning", "check_feasibility", "component_names",
]  # fmt: skip
