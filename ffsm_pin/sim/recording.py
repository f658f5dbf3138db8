"""What a run records and how a recording becomes a result: the shapes of a recorded row
(:func:`recorder_shapes`) and the size of a run's recording (:func:`recording_size`), the
spool's header (:func:`spool_header`), the signals computed after the run from the recorded
states (funnels, reference, errors, momentum, F_r: :func:`recorded_signals`) and the
:class:`~ffsm_pin.sim.result.RunResult` (:func:`run_result`). Used by the run loop
(:mod:`ffsm_pin.sim.loop`) and by the recovery of a spool (:mod:`ffsm_pin.sim.recover`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from .._numerics import blas, versions
from ..control.backend import numba_available
from ..control.diagnostics import reaction_torques, rows_beside
from ..control.interface import recorded_name
from ..control.kinematic import error_terms
from ..errors import SimulationError
from .capture_run import capture_signals
from .plant import Plant
from .recorder import Signals, extend
from .result import RunResult
from .setup import Setup
from .target_run import TARGET_SIGNALS
from .wheels_run import WHEEL_COLUMNS, wheel_shapes


def recorder_shapes(setup: Setup) -> dict[str, tuple[int, ...]]:
    """Shape of one recorded row of every per-step signal the loop itself records, and of
    the controller's signals it declares (``signal_layout``'s and ``signal_shapes``, under
    their recorded names)."""
    m = setup.model
    nq, nv, n = setup.robot.model.nq, setup.robot.model.nv, m.n_joints
    m3, nt = m.m3, setup.n_task
    planar = m3 == 1
    nw = n + m3
    # per-step signals; the funnels, their bounds, the reference, the true task errors, the
    # momentum and the reaction torque are computed after the run (_after_run_signals)
    layout = getattr(setup.controller, "signal_layout", None)
    declared = {**(layout.shapes if layout else {}),
                **(getattr(setup.controller, "signal_shapes", None) or {})}  # fmt: skip
    return {
        "t": (), "q": (nq,), "v": (nv,), "w": (nw,), "u_m": (n,), "z_e": (nt,),
        "q_b": (m3,), "dw_b": () if planar else (3,), "z_e_dot": (nt,),
        "u_cmd": (n,),
        **({} if setup.sensors is None else {  # what the controller saw
            "meas_q_b": (m3,), "meas_q_m": (n,), "meas_w": (nw,), "meas_z_e": (nt,),
            "meas_z_e_dot": (nt,),
        }),
        **{recorded_name(k): tuple(shape) for k, shape in declared.items()},
        **({} if setup.target is None else TARGET_SIGNALS),  # the target's pose and twist
        **wheel_shapes(setup),  # the wheels' momenta, speeds and torques
        **capture_signals(setup),  # with [capture]: the grasp frames' distance and speed
    }  # fmt: skip


def recording_size(setup: Setup) -> tuple[int, int]:
    """(steps, bytes per recorded row) of a run of ``setup``: the per-step signals and those
    :func:`_after_run_signals` adds (funnels, their bounds, the reference, the errors, the
    momentum P and L, F_r)."""
    sc = setup.scenario
    steps = int(round(sc.duration / sc.dt))
    per_step = sum(int(np.prod(shape)) for shape in recorder_shapes(setup).values())
    m2, m3, nt = setup.model.m2, setup.model.m3, setup.n_task
    return steps, 8 * (per_step + m2 + m3 + 5 * m3 + 6 * nt)


def spool_header(setup: Setup, record_every: int) -> dict:
    """What a run's spool records before its rows (:mod:`ffsm_pin.sim.recover`): the scenario
    as run, the recording interval [steps] and the step [s].

    Parameters
    ----------
    setup : Setup
        The run's setup.
    record_every : int
        The recording interval [steps].

    Returns
    -------
    dict
        The header.
    """
    from ..scenario.writer import scenario_to_toml

    return {
        "scenario_toml": scenario_to_toml(setup.scenario),
        "scenario_name": setup.scenario.name,
        "record_every": int(record_every),
        "dt": setup.scenario.dt,
        "blas": blas(),  # what the run computes with, for its recovered summary
        "versions": versions(),
    }


#: The recorded columns the signals computed after the run are functions of.
AFTER_RUN_INPUTS = ("t", "q_b", "z_e", "q", "v", "w", "dw_b")


def _after_run_signals(
    setup: Setup,
    reaction: Callable[..., np.ndarray],
    momentum: Callable[[Mapping[str, np.ndarray]], tuple],
):
    """The recorded signals computed after the run, a block of rows at a time, from the
    recorded t, q_b and z_e: funnels and their bounds, the reference, and the true task errors
    of Eqs. (16)-(17) (as :func:`~ffsm_pin.control.kinematic.task_errors`, on which the
    specification's funnels are judged); from the recorded q and v: the conserved momentum
    P, L (``momentum``: :meth:`~ffsm_pin.sim.plant.Plant.momentum_rows`, Pinocchio's
    centroidal momentum, independent of the plant's projection); from the recorded q_b, q, w
    and the base's angular acceleration dw_b: the reaction torque F_r of Eq. (7) with the true
    model (``reaction``: :func:`~ffsm_pin.control.diagnostics.reaction_torques`, on pieces of
    the rows beside the rest, :func:`~ffsm_pin.control.diagnostics.rows_beside`). ``momentum``
    reads a block of rows (a run with ``[capture]``: the whole system's,
    :meth:`~ffsm_pin.sim.capture_run.CaptureMotion.momentum_rows`)."""
    ref = setup.scenario.reference
    given = ref if setup.approach is None else setup.approach  # the reference the law had
    nq_root = setup.robot.root.nq  # q = (root, q_m)
    q_bd = np.asarray(ref.base_attitude, dtype=float)
    m3 = setup.model.m3
    funnel_b, funnel_z = setup.funnel_b, setup.funnel_z
    assert funnel_b is not None and funnel_z is not None  # prepare() sets both
    funnels = (("b", funnel_b), ("z", funnel_z))

    def per_row(block) -> dict[str, np.ndarray]:
        t = block["t"]
        q_m = block["q"][:, nq_root:]
        # F_r beside the rest (its kernel releases the GIL; Pinocchio's momentum holds it)
        rows = (block["q_b"], q_m, block["w"], block["dw_b"])
        f_r, out = rows_beside(reaction, rows, lambda: _row_signals(block, t))
        out["F_r"] = f_r
        return out

    def _row_signals(block, t) -> dict[str, np.ndarray]:
        out = {}
        for name, funnel in funnels:
            rho = funnel.rho(t[:, None])  # (samples, components)
            out[f"rho_{name}"] = rho
            out[f"bound_{name}_lower"] = funnel.lower * rho
            out[f"bound_{name}_upper"] = funnel.upper * rho
        out["z_e_d"], out["z_e_d_dot"] = given.sample(t)
        out["err_b"], out["err_z"] = error_terms(block["q_b"], q_bd, block["z_e"], out["z_e_d"], m3)
        out["P"], out["L"] = momentum(block)
        return out

    truth = {"theta_z": setup.theta_z, "theta_d": setup.theta_d, "theta_b": setup.theta_b}
    return per_row, truth


def recorded_signals(
    setup: Setup,
    raw: Signals,
    reaction: Callable[..., np.ndarray] | None = None,
    plant=None,
    momentum: Callable[[Mapping[str, np.ndarray]], tuple] | None = None,
    constants: Mapping[str, np.ndarray] | None = None,
) -> Signals:
    """The recorded per-step rows ``raw`` with the signals computed after the run (funnels,
    reference, errors, momentum, F_r: :func:`_after_run_signals`) and the true parameters.

    ``reaction`` and ``plant``: the run's F_r pass and plant, made anew when None (a
    recovered spool, :mod:`ffsm_pin.sim.recover`).

    Parameters
    ----------
    setup : Setup
        The run's setup.
    raw : Signals
        The recorded per-step rows.
    reaction : callable or None
        The run's F_r pass (:func:`~ffsm_pin.control.diagnostics.reaction_torques`).
    plant : Plant or None
        The run's plant.
    momentum : callable or None
        (P, L) of a block of recorded rows; None: the plant's
        (:meth:`~ffsm_pin.sim.plant.Plant.momentum_rows` of ``q``, ``v``).
    constants : mapping of str to ndarray or None
        More signals without a time axis (a capture's true parameters after it,
        :mod:`~ffsm_pin.sim.held_truth`).

    Returns
    -------
    Signals
        Every signal of the run.
    """
    if reaction is None:
        reaction = reaction_torques(setup.model, setup.theta_d, numba_available())
    if plant is None:
        plant = Plant(setup.robot, integrator=setup.scenario.integrator)
    inputs: tuple[str, ...] = AFTER_RUN_INPUTS
    if momentum is None:
        rows = plant.momentum_rows
        momentum = lambda block: rows(block["q"], block["v"])  # noqa: E731
    else:  # (a run with [capture] or wheels: the target's and wheels' rows too)
        inputs = (*inputs, *(k for k in (*TARGET_SIGNALS, *WHEEL_COLUMNS) if k in raw))
    per_row, truth = _after_run_signals(setup, reaction, momentum)
    return extend(raw, per_row, {**truth, **(constants or {})}, inputs)


def stop_outcome(stop: SimulationError | None) -> dict:
    """The result's fields of a run's stop: ``stop`` the exception the law raised or the one
    the loop made for its own stops (None: the run completed)."""
    if stop is None:
        return dict(completed=True, stop_reason=None, stop_time=None, stop_cause=None,
                    stop_funnel=None)  # fmt: skip
    return dict(completed=False, stop_reason=str(stop), stop_time=stop.time,
                stop_cause=stop.cause, stop_funnel=stop.funnel)  # fmt: skip


def run_result(setup: Setup, signals: Signals, **outcome) -> RunResult:
    """The :class:`RunResult` of a run of ``setup`` with the recorded ``signals``;
    ``outcome``: the fields the run decided (steps, wall time, completion and stop, events,
    saturation, capture).

    Parameters
    ----------
    setup : Setup
        The run's setup.
    signals : Signals
        Its signals (:func:`recorded_signals`).

    Returns
    -------
    RunResult
        The result.
    """
    sc, perf = setup.scenario, setup.scenario.performance
    # what the controller says of itself: its variant, what its sigma_min measures
    scheme = getattr(setup.controller, "scheme", None)
    measure = getattr(setup.controller, "sigma_measure", None)
    # what the run computed with: this process's, unless the caller knows (a recovered run)
    made_by: dict[str, Any] = {} if "blas" in outcome else {"blas": blas(), "versions": versions()}
    return RunResult(
        scheme=scheme if isinstance(scheme, str) else None,
        robot=setup.robot.name,
        dt=sc.dt,
        duration=sc.duration,
        signals=signals,
        scenario_name=sc.name,
        integrator=sc.integrator,
        substeps=sc.substeps,
        rhoinf_b=perf.funnel_b.rhoinf,
        rhoinf_z=perf.funnel_z.rhoinf,
        damping_threshold=perf.singularity_threshold,
        description=sc.description,
        controller=sc.controller.type,
        sigma_measure=measure if isinstance(measure, str) else None,
        estimates=dict(setup.drawn_estimates) or None,
        target=setup.target,
        **made_by,
        **outcome,
    )
