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

import warnings
from typing import NamedTuple

import numpy as np

from .._arrays import read_only, read_only_view
from ..errors import InfeasibleTaskError, ParameterError, SimulationError
from ..model.interface import ReducedModel
from ..model.planar import BarycentricModel
from ..model.spatial import SpatialBarycentricModel
from .adaptation import (
    regressor_filter_step,
    theta_b_step,
    theta_d_increment,
    theta_z_step,
)
from .backend import BACKENDS
from .funnel import Funnel, FunnelEval, FunnelExit, FunnelParams, IdentityFunnel
from .gains import Gains, SingularityPolicy
from .interface import Measurement, SignalLayout
from .kinematic import KinematicInputs, KinematicLaw, attitude_matrix, task_errors, task_size
from .manifold import manifold_input
from .null_space import NullSpace

SCHEMES = ("ppc", "no-ppc", "no-attitude", "known-model")
TASK_SIZE = 3  # planar end-effector pose (x, y, attitude): m2 + m3
ATTITUDE_SIZE = 1  # planar base attitude: m3


def component_names(m2: int, m3: int) -> tuple[str, ...]:
    """Names of the end-effector task components (pose order: position, then attitude)."""
    if m3 == 1:
        return ("x", "y", "attitude")[:m2] + ("attitude",)
    return ("x", "y", "z")[:m2] + ("s1", "s2", "s3")[:m3]


class SingularityWarning(UserWarning):
    """The damped pseudo-inverse of the kinematic law became active."""


class ControlOutput(NamedTuple):
    """Everything computed in one control period (values at the start of the period)."""

    u_m: np.ndarray  # joint torques [N m]
    w_mc: np.ndarray  # kinematic command [rad/s]
    w_mc_dot: np.ndarray  # its time derivative [rad/s^2]
    err_b: np.ndarray  # attitude error (m3) [rad or MRP]
    err_z: np.ndarray  # end-effector task error (task components) [m, rad or MRP]
    w_tilde: np.ndarray  # w - w-hat [rad/s]
    sigma_min: float
    damping: float
    funnel_b: FunnelEval | None = None  # numpy backend only (None for Eq. 81)
    funnel_z: FunnelEval | None = None  # numpy backend only
    # e of Eq. (54) with the true M and theta_d [N m s] (a diagnostic); None without theta_d_true
    e: np.ndarray | None = None
    # the period's signals at t as one row of CoordinatedController.signal_layout (w~, e, the
    # estimates and w-hat before the period advances them, w_mc, sigma_min, damping); None
    # without theta_d_true
    signals: np.ndarray | None = None


class RowOutput(NamedTuple):
    """What :meth:`CoordinatedController.step_row` returns.

    Attributes
    ----------
    u_m:
        The joint torques for the period [N m], shape ``(n_joints,)``.
    signals:
        The period's signals at its start, one row of
        :attr:`CoordinatedController.signal_layout` (w~, e of Eq. 54, the estimates and
        w-hat before the period advances them, w_mc, sigma_min, the damping).
    """

    u_m: np.ndarray
    signals: np.ndarray


def check_feasibility(
    n_joints: int, scheme: str, *, n_task: int = TASK_SIZE, m3: int = ATTITUDE_SIZE
) -> None:
    """Refuse a robot whose joints cannot serve the task (plus the attitude, if regulated).

    Eq. (25) needs H_bm (m3 x m1) of full row rank and Eq. (36) needs J_m U (n_task x m1) of
    full row rank: m1 >= n_task + m3 (docs/model.md section 5, docs/spatial.md); m1 >= n_task
    for Eq. (81), which does not regulate the attitude.
    """
    if scheme not in SCHEMES:
        raise InfeasibleTaskError(f"unknown scheme {scheme!r}; valid choices: {SCHEMES}")
    att = 0 if scheme == "no-attitude" else m3
    need = n_task + att
    if n_joints < need:
        what = f"the {n_task}-component end-effector task" + (
            "" if not att else f" plus the {m3}-component base attitude"
        )
        raise InfeasibleTaskError(
            f"scheme {scheme!r} needs at least {need} manipulator joints for {what} "
            f"({n_task} task + {att} attitude), the robot has {n_joints}"
        )


class CoordinatedController:
    """Adaptive prescribed-performance coordinated controller, planar or spatial.

    Parameters
    ----------
    model:
        The reduced model of the robot (:class:`~ffsm_pin.model.interface.ReducedModel`:
        planar or spatial; regressors and estimate evaluators).
    scheme:
        One of :data:`SCHEMES`.
    theta_z0, theta_d0, theta_b0:
        Initial estimates (the true vectors for ``"known-model"``).
    initial:
        The measurement at t = 0; fixes the side of each funnel (Eqs. 16-17).
    null_space:
        Optional null-space term added to Eq. (36) (beyond the paper,
        :mod:`.null_space`); None = the paper's law.
    task:
        ``"pose"`` (m2 + m3 components) or ``"position"`` (m2).
    theta_d_true:
        The true theta_d, for the diagnostic e of Eq. (54) (:attr:`ControlOutput.e`, with the
        true M); never read by the law. None: e is not computed.
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
        self.theta_z = np.array(theta_z0, dtype=float)
        self.theta_d = np.array(theta_d0, dtype=float)
        self.theta_b = np.array(theta_b0, dtype=float)
        for name, vec, size in (
            ("theta_z", self.theta_z, model.n_z),
            ("theta_d", self.theta_d, model.n_d),
            ("theta_b", self.theta_b, model.n_b),
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
        nb = model.n_joints + self.m3
        #: the signals a period reports at t, as one row (:attr:`ControlOutput.signals`)
        self.signal_layout = SignalLayout({
            "w_tilde": (nb,), "e": (nb,), "theta_z_hat": (model.n_z,),
            "theta_d_hat": (model.n_d,), "theta_b_hat": (model.n_b,), "w_hat": (nb,),
            "w_mc": (model.n_joints,), "sigma_min": (), "damping": (),
        })  # fmt: skip
        self.w_hat = np.zeros(nb)  # Table 2: w-hat(0) = 0
        self.Y_df = np.zeros((nb, model.n_d))  # Table 2: Y_df(0) = 0
        self.adaptive = scheme != "known-model"
        self.events: list[str] = []
        self._initial = initial
        self._damped_since: float | None = None
        self._last_warning = -np.inf
        self.backend = self._choose_backend(backend)

    def _choose_backend(self, backend: str) -> str:
        """'numba' (the compiled period, :mod:`.period`) unless 'numpy' is asked.

        The compiled period serves planar and spatial robots with every scheme, task and
        null-space option. The planar known-model baseline runs the numpy reference unless
        ``backend = "numba"`` is asked: its built-in case keeps the reference's trajectory,
        from which the compiled one departs by rounding amplified along the loop near a
        singularity (benchmarks/README.md).
        """
        spatial = isinstance(self.model, SpatialBarycentricModel)
        planar = isinstance(self.model, BarycentricModel)
        if backend == "numba" and not (planar or spatial):
            raise ParameterError(
                "backend 'numba' is the compiled period of the package's planar and spatial "
                f"models, not of {type(self.model).__name__}; use 'numpy' or 'auto'"
            )
        planar_compiled = planar and (self.adaptive or backend == "numba")
        if backend == "numpy" or not (spatial or planar_compiled):
            return "numpy"
        from . import period as compiled  # the compiled period: numba compiles or loads it

        self._setup_compiled(compiled)
        self._warm_up()
        return "numba"

    def _setup_compiled(self, compiled) -> None:
        """Pack the compiled period's constant arguments and bind the period to this
        controller's states."""
        m = self.model
        consts = (
            m.kernel_constants(), self.n_task,
            self.scheme != "no-attitude", self.scheme == "no-ppc", self.adaptive,
            compiled.pack_funnel(self.funnel_b), compiled.pack_funnel(self.funnel_z),
            compiled.gains_array(self.gains, self.policy.threshold, self.q_bd),
            *self.reference.kernel_arrays(),
            compiled.pack_null_space(self.null_space, self.kinematic.center, m.n_joints),
        )  # fmt: skip
        self._compiled = compiled
        self._fast_consts = consts  # the period's constant arguments (also used by tests)
        self._parallel_compile = compiled.compile_in_parallel
        self._layout = lay = compiled.out_layout(
            m.n_joints, self.m3, self.n_task, self.signal_layout.shapes
        )
        # the slots a period reads, looked up once
        self._out_size, self._u_m_slots = lay["size"], lay["u_m"]
        self._signal_slots = lay["signals"]
        self._sigma_slot, self._damping_slot = lay["sigma_min"], lay["damping"]
        self._status_ok = compiled.STATUS_OK
        period = compiled.period
        N = m.n_joints + self.m3
        # the true M and C w (known model) always read-only, as the sensor's model hands them
        # out (the period's argument types: one compiled period for every run and the warm-up)
        no_M, no_h = read_only(np.zeros((N, N))), read_only(np.zeros(N))
        adaptive = self.adaptive
        # Eq. (54)'s e in the period when the truth is given (an empty array: not computed)
        truth = np.empty(0) if self.theta_d_true is None else self.theta_d_true

        def call(meas: Measurement, dt: float, out: np.ndarray):
            if adaptive:
                M, h = no_M, no_h
            else:
                assert meas.M is not None and meas.h is not None  # the sensor's full model
                M, h = read_only_view(meas.M), read_only_view(meas.h)
            return period(
                *consts, dt, meas.t, meas.q_b, meas.q_m, meas.w, meas.z_e, meas.z_e_dot, M, h,
                self.theta_z, self.theta_d, self.theta_b, self.w_hat, self.Y_df, truth, out,
            )  # fmt: skip

        self._period = call

    def _warm_up(self) -> None:
        """Compile (or load from numba's cache) the kernel now, on copies of the states, so
        that the first control period of a run is not the one that pays for it."""
        saved = (self.theta_z, self.theta_d, self.theta_b, self.w_hat, self.Y_df)
        self.theta_z, self.theta_d, self.theta_b, self.w_hat, self.Y_df = (
            self.theta_z.copy(), self.theta_d.copy(), self.theta_b.copy(), self.w_hat.copy(),
            self.Y_df.copy(),
        )  # fmt: skip
        m0 = self._initial
        if m0.M is None and not self.adaptive:  # known model: any M, C w do for compiling
            m0 = m0._replace(M=np.eye(len(m0.w)), h=np.zeros(len(m0.w)))
        if self._parallel_compile is not None:  # a first run: use both cores
            self._parallel_compile(
                self._fast_consts, m0.t, m0.q_b, m0.q_m, m0.w, m0.z_e, self.theta_z,
                self.theta_d, self.theta_b,
            )  # fmt: skip
        try:
            self._period(m0, 1e-3, np.empty(self._layout["size"]))
        finally:
            self.theta_z, self.theta_d, self.theta_b, self.w_hat, self.Y_df = saved

    # ------------------------------------------------------------------ one period
    @property
    def damped_since(self) -> float | None:
        """The time [s] since which damped least squares has been active without a break (the
        period's damping > 0 at every period since), or None when the last period was not
        damped; a stretch longer than the singularity policy's ``max_damped_time`` stops the
        run."""
        return self._damped_since

    def step(self, meas: Measurement, dt: float) -> ControlOutput:
        """Compute u_m for the period [t, t + dt) and advance the controller's states."""
        if self.backend == "numba":
            return self._outputs(self._compiled_period(meas, dt))
        return self._step_numpy(meas, dt)

    def step_row(self, meas: Measurement, dt: float) -> RowOutput:
        """The same period as :meth:`step`, returning only u_m and the signals' row.

        This is what :class:`~.lu_jia.LuJiaController` hands back each period. On the
        compiled backend both are views of the period's output and the other named outputs
        of :class:`ControlOutput` are not made (about 2.5 us a period on case 1).

        Parameters
        ----------
        meas:
            The measurement at the period's start t [s].
        dt:
            The period [s].

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
        if self.theta_d_true is None:
            raise ParameterError("step_row needs theta_d_true (the row's e of Eq. 54)")
        if self.backend == "numba":
            out = self._compiled_period(meas, dt)
            return RowOutput(out[self._u_m_slots], out[self._signal_slots])
        full = self._step_numpy(meas, dt)
        assert full.signals is not None  # (theta_d_true is given)
        return RowOutput(full.u_m, full.signals)

    def _compiled_period(self, meas: Measurement, dt: float) -> np.ndarray:
        """Run the compiled period into a new output buffer (its outputs are views of it),
        keep the singularity bookkeeping, and raise the stop its status says."""
        out = np.empty(self._out_size)  # fresh each period: the outputs are views of it
        status, idx = self._period(meas, dt, out)
        sigma, damping = out[self._sigma_slot], out[self._damping_slot]
        if status == self._status_ok and damping == 0.0 and self._damped_since is None:
            return out  # the common period: nothing to book, no stop
        return self._period_status(meas, status, idx, out, float(sigma), float(damping))

    def _period_status(
        self, meas: Measurement, status: int, idx: int, out: np.ndarray, sigma: float,
        damping: float,
    ) -> np.ndarray:  # fmt: skip
        compiled, lay = self._compiled, self._layout
        t = meas.t
        if status in (compiled.STATUS_FUNNEL_Z, compiled.STATUS_FUNNEL_B):
            funnel = self.funnel_z if status == compiled.STATUS_FUNNEL_Z else self.funnel_b
            rho = float(funnel.rho(t)[idx])
            exc = FunnelExit(
                idx, out[lay["exit_value"]], funnel.lower[idx] * rho, funnel.upper[idx] * rho
            )
            raise self._funnel_stop(meas, exc)
        if status == compiled.STATUS_H_COLLAPSE:
            raise self._collapse_stop(t, out[lay["H_bm_norm"]])
        # (the warning points at the caller of step / step_row: 5 frames up)
        self._singularity_bookkeeping(t, sigma, damping, stacklevel=5)
        if status == compiled.STATUS_M_NOT_PD:
            raise self._inertia_stop(t)
        if status == compiled.STATUS_BASE_ROW:
            what = "base row of the filter is" if self.m3 == 1 else "base rows of the filter are"
            raise SimulationError(f"t = {t:.4f} s: {what} singular", time=t, cause="singular")
        if status == compiled.STATUS_NONFINITE:
            raise self._nonfinite_stop(t)
        return out

    def _outputs(self, out: np.ndarray) -> ControlOutput:
        """The named outputs of a compiled period's buffer ``out`` (views of it)."""
        lay = self._layout
        return ControlOutput(
            u_m=out[lay["u_m"]],
            w_mc=out[lay["w_mc"]],
            w_mc_dot=out[lay["w_mc_dot"]],
            err_b=out[lay["err_b"]],
            err_z=out[lay["err_z"]],
            w_tilde=out[lay["w_tilde"]],
            sigma_min=float(out[lay["sigma_min"]]),
            damping=float(out[lay["damping"]]),
            e=None if self.theta_d_true is None else out[lay["e"]],
            signals=None if self.theta_d_true is None else out[lay["signals"]],
        )

    def _step_numpy(self, meas: Measurement, dt: float) -> ControlOutput:
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
        x = KinematicInputs(t, q_b, q_m, meas.z_e, self.theta_b, self.theta_z,
                            w[0] if m3 == 1 else w_b)  # fmt: skip
        rates = KinematicInputs(
            1.0, q_b_rate, w[m3:], meas.z_e_dot,
            (theta_b - self.theta_b) / dt, (theta_z - self.theta_z) / dt, 0.0,
        )  # fmt: skip
        try:
            kc = self.kinematic.command(x, rates)
        except FunnelExit as exc:
            raise self._funnel_stop(meas, exc) from None
        self._singularity_bookkeeping(t, kc.sigma_min, kc.damping, stacklevel=4)
        if self.scheme != "no-attitude" and not kc.H_bm_norm > 1e-9:
            raise self._collapse_stop(t, kc.H_bm_norm)

        # 3. dynamic level, Eqs. (46), (50)-(52), (60)-(64)
        if self.adaptive:
            w_tilde = w - self.w_hat
            M_hat = m.mass_matrix(self.theta_d, q_b, q_m)
            if np.any(np.linalg.eigvalsh(M_hat) <= 0):
                raise self._inertia_stop(t)
            Y_Mdot, Y_h = m.velocity_regressors(q_b, q_m, w, w_tilde)
            d_theta_d = theta_d_increment(self.Y_df, w_tilde, M_hat, g.gamma_3, dt)
            eta_x = -self.Y_df @ d_theta_d / dt  # Eq. (52)
            r = (Y_Mdot - Y_h) @ self.theta_d + g.k_de * (M_hat @ w_tilde) + eta_x
            w_hat = self.w_hat
        else:  # known model: computed torque on the true reduced dynamics
            w_tilde = np.zeros_like(w)
            assert meas.M is not None and meas.h is not None  # the sensor's full model
            M_hat, r, w_hat = meas.M, -meas.h, w
        mi = manifold_input(M_hat, r, w_hat, kc.w_mc, kc.w_mc_dot, kc.dwmc_dwb, g.k_d, t)
        if not np.all(np.isfinite(mi.u_m)):
            raise self._nonfinite_stop(t)
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
        return ControlOutput(
            u_m=mi.u_m,
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

    # ------------------------------------------------------------------ stops
    def _singularity_bookkeeping(
        self, t: float, sigma_min: float, damping: float, stacklevel: int
    ) -> None:
        thr = self.policy.threshold
        if damping > 0:
            if self._damped_since is None:
                self._damped_since = t
                if t - self._last_warning > 1.0:
                    msg = (
                        f"t = {t:.3f} s: the arm is near a singularity (sigma_min = "
                        f"{sigma_min:.4f} < {thr}); damped least squares is active"
                    )
                    self.events.append(msg)
                    warnings.warn(msg, SingularityWarning, stacklevel=stacklevel)
                    self._last_warning = t
            elif t - self._damped_since > self.policy.max_damped_time:
                raise SimulationError(
                    f"t = {t:.3f} s: the arm stayed singular for more than "
                    f"{self.policy.max_damped_time} s (sigma_min = {sigma_min:.4f} < {thr} since "
                    f"t = {self._damped_since:.3f} s)",
                    time=t,
                    cause="singular",
                )
        else:
            self._damped_since = None

    @staticmethod
    def _collapse_stop(t: float, h_norm: float) -> SimulationError:
        return SimulationError(
            f"t = {t:.4f} s: the estimate theta_b-hat collapsed (|H_bm-hat| = {h_norm:.3g}); "
            "Eq. (25) is undefined",
            time=t,
            cause="estimate",
        )

    @staticmethod
    def _nonfinite_stop(t: float) -> SimulationError:
        return SimulationError(
            f"t = {t:.4f} s: the joint torque became non-finite", time=t, cause="nonfinite"
        )

    @staticmethod
    def _inertia_stop(t: float) -> SimulationError:
        return SimulationError(
            f"t = {t:.4f} s: the estimated inertia M(q, theta_d-hat) is not positive definite; "
            "the filter (46) is undefined",
            time=t,
            cause="estimate",
        )

    def _funnel_stop(self, meas: Measurement, exc: FunnelExit) -> SimulationError:
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
        if self._damped_since is not None:
            note = f"; the arm has been near a singularity since t = {self._damped_since:.3f} s"
        return SimulationError(
            f"t = {t:.4f} s: {what} = {exc.value:.5g} left its funnel "
            f"({exc.lower:.5g}, {exc.upper:.5g}); the transformation (21) is undefined{note}",
            time=t,
            cause="funnel",
            funnel=which,
        )
