"""The paper's compiled period driven from Python (the compiled side of
:class:`~.controller.CoordinatedController`).

:class:`CompiledPeriod` makes the period's named bundles once (:mod:`.period`: the law's
constants, the model's and the reference's arrays, the outputs with the signals as views of one
row of the controller's ``signal_layout``), warms the period up (a first run compiles its real
kernels in a second process meanwhile, :func:`.period.compile_in_parallel`), runs a period into
its outputs and turns its status into the law's stops (:mod:`.stops`), as the numpy reference
raises them. The backend choice, the warm-up on copies and the binding of ``step`` are the
kit's (:class:`~.compiled.CompiledController`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from .._arrays import read_only, read_only_view
from .._docstrings import fill_doc
from ..errors import ParameterError
from . import kernels  # the status codes (STATUS_*)
from ._docs import CONTROL_DOC
from ._period_box import PeriodBox, period_box
from .funnel import Funnel, FunnelExit
from .gains import Gains, SingularityPolicy
from .interface import Measurement, SignalLayout
from .period import (
    PeriodState,
    compile_in_parallel,
    law_fields,
    period,
    period_law,
    period_of,
    period_outputs,
)
from .reference_kernels import reference_arrays
from .schemes import ControlOutput, RowOutput
from .stops import (
    SingularityWatch,
    base_row_stop,
    collapse_stop,
    inertia_stop,
    nonfinite_stop,
    physical_stop,
)


class PeriodArguments(NamedTuple):
    """The arguments of one call of :func:`.period.period`, in order."""

    geo: Any  #: the model's kernel constants
    law: tuple  #: the fields of the law (:func:`.period.law_fields`)
    ref: tuple  #: the fields of the reference arrays
    dt: float  #: the period [s]
    meas: tuple  #: the fields of the measurement (the true M and C w, or stand-ins)
    state: tuple  #: the fields of the period's state (advanced in place)
    out: tuple  #: the fields of the outputs (written)
    aux: Any  #: the auxiliary system and its state, or None


class PeriodHandles(NamedTuple):
    """What :meth:`CompiledPeriod.period_handles` gives: the arguments of
    :func:`.period.period_of` that stay the same every period, and where it writes."""

    box: PeriodBox  #: the fixed arguments (:mod:`._period_box`)
    aux: Any  #: the auxiliary system and its state, or None
    M: np.ndarray  #: read-only stand-in of the true M (an adaptive law does not read it)
    h: np.ndarray  #: read-only stand-in of the true C w
    outputs: Any  #: the :class:`~.period.PeriodOutputs` each period writes (u_m, ...)
    row: np.ndarray  #: the signals' row of the controller's ``signal_layout`` (views in outputs)


@fill_doc(CONTROL_DOC)
class CompiledPeriod:
    """The compiled side of :class:`~.controller.CoordinatedController` (a mixin: the law's
    attributes below are the controller's)."""

    model: Any
    scheme: str
    gains: Gains
    policy: SingularityPolicy
    q_bd: np.ndarray
    funnel_b: Funnel
    funnel_z: Funnel
    null_space: Any
    kinematic: Any
    reference: Any
    n_task: int
    m3: int
    adaptive: bool
    theta_d_true: np.ndarray | None
    physical: Any  # PhysicalTerm or None
    signal_layout: SignalLayout
    state: PeriodState
    auxiliary: Any  # AuxiliarySystem or None (saturation.py)
    _watch: SingularityWatch
    funnel_stop: Callable[[Measurement, FunnelExit], Exception]  # the controller's method

    def prepare_kernels(self) -> None:
        """The compiled period's bundles (:mod:`.period`): the law's constants, the model's
        and the reference's, the outputs (the signals as views of one row of
        :attr:`signal_layout`), and read-only stand-ins for the true M and C w, which only
        the known-model scheme reads (one compiled period for every run and the warm-up)."""
        m = self.model
        self._geo = m.kernel_constants()
        self._law = period_law(
            n_task=self.n_task, scheme=self.scheme, gains=self.gains,
            threshold=self.policy.threshold, q_bd=self.q_bd, funnel_b=self.funnel_b,
            funnel_z=self.funnel_z, null_space=self.null_space, center=self.kinematic.center,
            n_joints=m.n_joints, theta_d_true=self.theta_d_true, physical=self.physical,
        )  # fmt: skip
        if not self.kinematic.attitude:  # (released before the kernels were made)
            self._law = self._law._replace(attitude=False)
        self._ref = reference_arrays(self.reference)
        self._out, self._row = period_outputs(self.signal_layout, m.n_joints, self.m3, self.n_task)
        N = m.n_joints + self.m3
        self._no_M, self._no_h = read_only(np.zeros((N, N))), read_only(np.zeros(N))
        # what the period takes every period: the bundles' fields (period's docstring)
        self._fields = (self._geo, law_fields(self._law), tuple(self._ref))
        self._out_fields = tuple(self._out)
        aux = self.auxiliary  # its state is the numpy reference's array, advanced in place
        self._aux = None if aux is None else (aux.term, aux.state)
        self._box: PeriodBox | None = None  # made by the first period (_period_box)
        self._box_of: tuple = ()

    def _kernel_meas(self, meas: Measurement) -> tuple:
        """The fields of ``meas`` as the period takes them: the true M and C w read-only (known
        model; as the sensor's model hands them out), the stand-ins otherwise."""
        if self.adaptive:
            M, h = self._no_M, self._no_h
        else:
            assert meas.M is not None and meas.h is not None  # the sensor's full model
            M, h = read_only_view(meas.M), read_only_view(meas.h)
        return (meas.t, meas.q_b, meas.q_m, meas.w, meas.z_e, meas.z_e_dot, M, h)

    def period_arguments(self, meas: Measurement, dt: float) -> PeriodArguments:
        """The arguments :func:`.period.period` takes at ``meas``: the live bundles, its state
        advanced in place by a call (for benchmarks and tests that call the compiled steps
        themselves; :meth:`prepare_kernels` first).

        Parameters
        ----------
        meas : Measurement
            The measurement.
        dt : float
            The period [s].

        Returns
        -------
        PeriodArguments
            ``period(*arguments)`` is one period.
        """
        geo, law, ref = self._fields
        return PeriodArguments(
            geo, law, ref, dt, self._kernel_meas(meas), tuple(self.state), self._out_fields,
            self._aux,
        )  # fmt: skip

    def warm_up_call(self, meas: Measurement, dt: float) -> None:
        """The compiled period alone at ``meas`` (no bookkeeping), after a first run's second
        process has compiled its real kernels (:func:`.period.compile_in_parallel`).

        Parameters
        ----------
        meas : Measurement
            The measurement warmed up at.
        dt : float
            The period [s].
        """
        if meas.M is None and not self.adaptive:  # known model: any M, C w do for compiling
            meas = meas._replace(M=np.eye(len(meas.w)), h=np.zeros(len(meas.w)))
        args = self.period_arguments(meas, dt)
        compile_in_parallel(self._geo, self._law, self._ref, Measurement(*args.meas), self.state)
        aux = None if args.aux is None else (args.aux[0], args.aux[1].copy())  # (a copy)
        period(*args._replace(aux=aux))

    def set_theta_d_true(self, theta_d_true) -> None:
        """Replace the true theta_d of the diagnostic e of Eq. (54) in place, for both
        backends (after a capture: the merged robot's, docs/capture.md); nothing when the
        law has none.

        Parameters
        ----------
        theta_d_true : array_like, shape (n_2,)
            The new true theta_d.
        """
        if self.theta_d_true is None:
            return
        self.theta_d_true[:] = theta_d_true
        law = getattr(self, "_law", None)  # (the compiled bundle's copy, once prepared)
        if law is not None:
            law.theta_d_true[:] = theta_d_true

    def release_attitude(self) -> None:
        """From now on the arm no longer regulates the base attitude: the kinematic law is
        Eq. (81) (the scheme ``"no-attitude"``'s, w_mc = J_m-hat^+ (target - J_b-hat w_b),
        the base's rate a measured input), for both backends. For a bus whose attitude
        another actuator takes over: lu-jia's wheels after a capture (docs/capture.md, "The
        paper's controller with the wheels"). The base funnel is no longer evaluated by the
        law (its error is still returned and recorded); a null-space term, defined for
        Eq. (36) only, no longer acts.
        """
        self.kinematic.attitude = False
        law = getattr(self, "_law", None)  # (the compiled bundle, once prepared)
        if law is not None:
            self._law = law._replace(attitude=False)
            geo, _, ref = self._fields
            self._fields = (geo, law_fields(self._law), ref)

    def _require_truth(self) -> None:
        """Refuse a row without the true theta_d (its e of Eq. 54 needs it)."""
        if self.theta_d_true is None:
            raise ParameterError("step_row needs theta_d_true (the row's e of Eq. 54)")

    def _row_compiled(self, meas: Measurement, dt: float) -> RowOutput:
        self._require_truth()
        self._run_compiled(meas, dt)
        return RowOutput(self._out.u_m.copy(), self._row.copy())

    def step_compiled(self, meas: Measurement, dt: float) -> ControlOutput:
        """:meth:`step` by the compiled period; the outputs are copies.

        %(sections_step_period)s
        """
        self._run_compiled(meas, dt)
        o, truth = self._out, self.theta_d_true is not None
        return ControlOutput(
            u_m=o.u_m.copy(), w_mc=o.w_mc.copy(), w_mc_dot=o.w_mc_dot.copy(),
            err_b=o.err_b.copy(), err_z=o.err_z.copy(), w_tilde=o.w_tilde.copy(),
            sigma_min=float(o.sigma_min[0]), damping=float(o.damping[0]),
            e=o.e.copy() if truth else None, signals=self._row.copy() if truth else None,
        )  # fmt: skip

    def __getstate__(self) -> dict:
        """The attributes a copy takes (``copy.deepcopy``), without the period's box: numba's
        structref does not copy, and a copy's box must hold the copy's own arrays (its first
        period makes it again)."""
        state = self.__dict__.copy()
        if "_box" in state:
            state["_box"], state["_box_of"] = None, ()
        return state

    def __setstate__(self, state: dict) -> None:
        """A copy's attributes; its outputs' signals views of its own row again (a deep copy
        copies each view on its own, and the period would write the copies while the
        controller hands out a row no longer written)."""
        self.__dict__.update(state)
        if "_row" not in state:  # (a copy made before prepare_kernels)
            return
        m = self.model
        out, row = period_outputs(self.signal_layout, m.n_joints, self.m3, self.n_task)
        row[:] = self._row
        for mine, copied in zip(out, self._out, strict=True):
            if not np.shares_memory(mine, row):  # (the other outputs: arrays of their own)
                mine[...] = copied
        self._out, self._row, self._out_fields = out, row, tuple(out)

    def _period_box(self) -> PeriodBox:
        """The box of the period's fixed arguments (:mod:`._period_box`), made again when the
        law's fields or the state were replaced (``release_attitude``, a capture joining a
        held body, a warm-up on copies): the same objects as :meth:`period_arguments`'."""
        box, made_of = self._box, self._box_of  # (made_of: the fields and state it holds)
        if box is None or made_of[0] is not self._fields or made_of[1] is not self.state:
            geo, law, ref = self._fields
            box = period_box(geo, law, ref, tuple(self.state), self._out_fields)
            self._box, self._box_of = box, (self._fields, self.state)
        return box

    def _run_compiled(self, meas: Measurement, dt: float) -> None:
        """Run the compiled period into the outputs, keep the singularity bookkeeping, and
        raise the stop its status says."""
        status, idx, value = period_of(self._period_box(), dt, self._kernel_meas(meas), self._aux)
        plain = status == kernels.STATUS_OK and self._out.damping[0] == 0.0
        if not plain or self._watch.since is not None:  # (else nothing to book, no stop)
            self.settle(meas, status, idx, value, stacklevel=3)

    def period_handles(self) -> PeriodHandles:
        """What calling the compiled period directly takes and gives, for a runner that steps
        several controllers' periods in one call (benchmarks/bench_lockstep.py): after each
        call of :func:`.period.period_of` with these, :meth:`settle` the result when its
        status is not ``STATUS_OK``, its damping (``outputs.damping``) not 0 or
        :attr:`damped_since` not None.

        Returns
        -------
        PeriodHandles
            The live box, outputs and row (written by each period), the stand-ins of the true
            M and C w and the auxiliary argument.
        """
        return PeriodHandles(
            self._period_box(), self._aux, self._no_M, self._no_h, self._out, self._row
        )

    @property
    def damped_since(self) -> float | None:
        """The time [s] since which every period was damped (the singularity watch), or
        None; while it is not None, every period is :meth:`settle`-d."""
        return self._watch.since

    def settle(
        self, meas: Measurement, status: int, idx: int, value: float, stacklevel: int = 1
    ) -> None:
        """The bookkeeping of a compiled period that returned ``(status, idx, value)`` at
        ``meas``: the singularity watch (its warning when damping starts, its stop when
        damping lasts too long) and the stop the status says.

        Parameters
        ----------
        meas : Measurement
            The period's measurement.
        status, idx, value : int, int, float
            What :func:`.period.period_of` returned.
        stacklevel : int
            Of the damping warning, as :func:`warnings.warn`'s, counted from the caller.

        Raises
        ------
        SimulationError
            A funnel exit, a collapse of H_bm-hat, damped least squares for longer than the
            policy allows, an estimated inertia that is not positive definite, a singular
            base row, a torque not finite, estimates no longer physical.
        """
        damping = self._out.damping[0]
        t = meas.t
        if status in (kernels.STATUS_FUNNEL_Z, kernels.STATUS_FUNNEL_B):
            funnel = self.funnel_z if status == kernels.STATUS_FUNNEL_Z else self.funnel_b
            rho = float(funnel.rho(t)[idx])
            exc = FunnelExit(idx, value, funnel.lower[idx] * rho, funnel.upper[idx] * rho)
            raise self.funnel_stop(meas, exc)
        if status == kernels.STATUS_H_COLLAPSE:
            raise collapse_stop(t, value)
        # (the warning points at the caller's caller)
        self._watch.update(
            t, float(self._out.sigma_min[0]), float(damping), stacklevel=stacklevel + 1
        )
        if status == kernels.STATUS_M_NOT_PD:
            raise inertia_stop(t)
        if status == kernels.STATUS_BASE_ROW:
            raise base_row_stop(t, self.m3)
        if status == kernels.STATUS_NONFINITE:
            raise nonfinite_stop(t)
        if status == kernels.STATUS_NOT_PHYSICAL:
            raise physical_stop(t, self.physical.max_iter)


__all__ = ["CompiledPeriod", "PeriodArguments", "PeriodHandles"]
