"""The closed loop: :func:`simulate` runs a prepared :class:`~ffsm_pin.sim.setup.Setup` and
records it.

Per step the loop measures the plant (:class:`~ffsm_pin.sim.measurement.Sensor`), hands the
controller what the sensors let it see, applies the actuators' torque to the momentum-exact
plant and records raw states; the signals that are functions of recorded states (funnels,
reference, task errors, the reaction torque) are computed after the run. ``simulate`` never
raises on numerical trouble: a run that has to stop returns ``completed=False`` with the time
and the reason, and everything recorded so far.
"""

from __future__ import annotations

import math
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..control import _first_compile
from ..control.backend import numba_available
from ..control.diagnostics import reaction_torques
from ..control.interface import (
    Measurement,
    SignalLayout,
    SignalRow,
    recorded_name,
    split_reply,
)
from ..errors import ParameterError, SimulationError
from . import recorder
from .capture_run import CaptureMotion, target_motions
from .chunk_pool import ChunkPool
from .measurement import Sensor
from .plant import STATE_NONFINITE, STATE_OK
from .recorder import Recorder, Signals
from .recording import (
    recorder_shapes,
    recording_size,
    run_result,
    spool_header,
    stop_outcome,
)
from .result import RunResult
from .setup import Setup
from .storage import check_storage, rows_recorded
from .system_signals import system_outcomes, system_signals
from .wheels_run import loop_plant

#: The columns the loop writes at every recorded step (as recorder_shapes), and those of what
#: the controller saw when there are sensors.
_LOOP_COLUMNS = ("t", "q", "v", "w", "u_m", "u_cmd", "z_e", "z_e_dot", "q_b", "dw_b")
_SEEN_COLUMNS = ("meas_q_b", "meas_q_m", "meas_w", "meas_z_e", "meas_z_e_dot")

#: float64, the dtype a torque is checked against first (:func:`checked_torque`)
_FLOAT64 = np.dtype(np.float64)

#: [rad/s] the blow-up guard: a run stops when an angular rate of the plant exceeds it
RATE_LIMIT = 1e4


class ControllerFault(Exception):
    """A controller broke the interface (a bad torque or signal); the run stops."""


def checked_torque(u, n: int) -> np.ndarray:
    """``u`` as the run applies it: real numbers, shape ``(n,)``, finite, or a
    :class:`ControllerFault` that says which (the run's stop, cause ``"controller"``).

    Parameters
    ----------
    u : array_like
        The controller's torque [N m].
    n : int
        Joints.

    Returns
    -------
    ndarray
        ``u`` as float64.
    """
    if type(u) is np.ndarray and u.dtype is _FLOAT64 and u.shape == (n,):  # the usual reply
        if all(map(math.isfinite, u.tolist())):  # (the checks below, in fewer calls)
            return u
    u = np.asarray(u)
    if u.dtype.kind not in "fiu":  # (not bool, complex, strings or objects)
        raise ControllerFault(
            f"the controller returned a torque of dtype {u.dtype} ({u.tolist()!r:.80}); "
            f"expected real numbers, shape ({n},), one per joint [N m]"
        )
    if u.dtype != np.float64:
        u = u.astype(float)
    if u.shape != (n,):
        raise ControllerFault(
            f"the controller returned a torque of shape {u.shape}; expected ({n},), one per "
            "joint [N m]"
        )
    if not all(map(math.isfinite, u.tolist())):  # (np.isfinite(u).all(), three times dearer)
        raise ControllerFault(
            f"the controller returned a non-finite torque {u.tolist()} (shape ({n},))"
        )
    return u


def _standard_shapes(setup: Setup) -> dict[str, tuple[int, ...]]:
    """The shapes the summary and the figures read standard signals with
    (:data:`~ffsm_pin.control.interface.STANDARD_SIGNALS`)."""
    return {
        "sigma_min": (), "damping": (), "theta_z_hat": np.shape(setup.theta_z),
        "theta_d_hat": np.shape(setup.theta_d), "theta_b_hat": np.shape(setup.theta_b),
    }  # fmt: skip


def _signal_fault(key: str, value) -> ControllerFault | None:
    """Why a controller's signal ``value`` cannot be recorded (not real numbers), or None."""
    if type(value) in (float, int, np.float64) or (
        type(value) is np.ndarray and value.dtype.kind in "fiu"
    ):
        return None
    kind = np.asarray(value).dtype.kind if not isinstance(value, Mapping) else "O"
    if kind in "fiu" and not isinstance(value, (bool, np.bool_)):
        return None
    return ControllerFault(
        f"the controller's signal {key!r} is a {type(value).__name__}, not real numbers; "
        "each signal needs the same name, shape and type (numbers) every period"
    )


def _frozen(meas: Measurement) -> Measurement:
    """A copy of ``meas`` that a controller writing into its arrays cannot change."""
    q_b = meas.q_b.copy() if isinstance(meas.q_b, np.ndarray) else meas.q_b
    return meas._replace(
        q_b=q_b, q_m=meas.q_m.copy(), w=meas.w.copy(), z_e=meas.z_e.copy(),
        z_e_dot=meas.z_e_dot.copy(),
    )  # fmt: skip


def simulate(
    setup: Setup,
    progress=None,
    record_every: int = 1,
    spool_dir: str | Path | None = None,
    memory_bytes: int | None = None,
    pool: ChunkPool | None = None,
) -> RunResult:
    """Run the closed loop for the scenario's duration; see the module docstring.

    A Ctrl-C (``KeyboardInterrupt``) ends the run like a stop: the result holds every row
    recorded so far, ``stop_cause = "interrupted"``. A controller that raises, or returns a
    torque of the wrong shape or not finite, stops the run with ``stop_cause = "controller"``.

    Parameters
    ----------
    setup : Setup
        The prepared run (:func:`prepare`).
    progress : callable or None
        Called with the simulated time [s] every 0.1 s of it, or None.
    record_every : int
        Record every this many steps (and the last step).
    spool_dir : str, Path or None
        Where a recording longer than the recorder's memory chunk is spilled
        (``ffsm_pin.sim.recorder``); the system's temporary folder when None.
    memory_bytes : int or None
        The recorder's memory chunk [bytes]: the rows held in memory before they are spilled
        to ``spool_dir``; None: :data:`~ffsm_pin.sim.recorder.CHUNK_BYTES`. A larger chunk
        spares a long run the spill's copies (a campaign's cases: ``ffsm_pin.sweep.engine``)
        at that memory, and a run killed before its first spill leaves nothing to recover.
    pool : ChunkPool or None
        Where the recorder's large arrays come from: memory reused within a process
        (:mod:`ffsm_pin.sim.chunk_pool`, a campaign worker's), or fresh memory when None. The
        same rows either way.

    Returns
    -------
    RunResult
        The recorded signals, whether the run completed and, if not, when and why it stopped.

    Raises
    ------
    ParameterError
        ``memory_bytes`` is not a positive whole number.
    StorageError
        The recording would not fit on the disk of ``spool_dir``
        (:func:`~ffsm_pin.sim.storage.check_storage`).
    """
    sc = setup.scenario
    dt, duration = sc.dt, sc.duration
    n_steps = int(round(duration / dt))
    record_every = max(1, int(record_every))
    if memory_bytes is not None and (type(memory_bytes) is not int or memory_bytes < 1):
        raise ParameterError(
            f"simulate: memory_bytes = {memory_bytes!r}: must be a positive whole number of "
            f"bytes, or None (the recorder's chunk, {recorder.CHUNK_BYTES} bytes)"
        )
    # the rows a run records go to disk past the first chunk (ffsm_pin.sim.recorder)
    check_storage(*recording_size(setup), record_every, spool_dir or tempfile.gettempdir())
    controller = setup.controller
    model = setup.model
    # the plant; with [robot.satellite.wheels] the robot and its wheels (sim/wheels_run.py)
    plant, wheels = loop_plant(setup)
    needs_dynamics = bool(getattr(controller, "needs_dynamics", False))
    sensor = Sensor(setup.robot, model, full_model=needs_dynamics)  # Pinocchio M, C w
    shapes = recorder_shapes(setup)
    n_rows = rows_recorded(n_steps, record_every)
    # a controller's declared SignalLayout: its columns side by side, a row copied whole
    layout: SignalLayout | None = getattr(controller, "signal_layout", None)
    packed = [recorded_name(key) for key in layout.shapes] if layout else []

    # a spool says what it holds before its rows: a killed run is recovered from it alone
    def header() -> dict:  # (made only when a spool is: a run that fits in memory has none)
        return spool_header(setup, record_every)

    def recorder_of(shapes: dict) -> Recorder:  # (again at the first period, for its signals)
        return Recorder(
            shapes,
            n_rows,
            spool_dir,
            chunk_bytes=memory_bytes,
            packed=packed,
            header=header,
            pool=pool,
        )

    rec = recorder_of(shapes)
    A, A_signals = rec.arrays, rec.block
    q, v = setup.q0.copy(), setup.v0.copy()
    plant.reset(q, v)
    stop: SimulationError | None = None  # what stopped the run (None: it completed)
    next_progress = 0.0
    m3, nt, n = model.m3, setup.n_task, model.n_joints
    _first_compile.finish()  # a first run: the second process has the kernels below cached
    sensor.measure(0.0, q, v)  # compile / load the kernels before the clock starts
    # likewise F_r's after-run pass (true model, Eq. 7), on one row of zeros
    reaction = reaction_torques(model, setup.theta_d, numba_available())
    reaction(np.zeros((1, m3)), np.zeros((1, n)), np.zeros((1, n + m3)),
             np.zeros((1, *shapes["dw_b"])))  # fmt: skip
    sensor.reset()  # the run measures t = 0 again
    plant.project(q, v)  # likewise the plant's compiled projection (result unused)
    plant.state_status(q, v, RATE_LIMIT)  # and its state check
    n_lin = plant.n_linear  # base linear velocity entries of v
    actuators, sensors = setup.actuators, setup.sensors
    saturated = 0  # control periods with some joint at its torque limit
    names: dict[str, str] = {}  # controller signal -> recorded name
    standard = _standard_shapes(setup)
    first: tuple[Measurement, Measurement] | None = None
    # the recorder's columns, looked up once (its arrays outlive every spill; a recorder
    # rebuilt for the controller's signals at the first period is looked up again)
    A_t, A_q, A_v, A_w, A_u_m, A_u_cmd, A_z_e, A_z_e_dot, A_q_b, A_dw_b = (
        A[key] for key in _LOOP_COLUMNS
    )
    no_column = np.empty((0,))  # (what the controller saw: recorded with sensors only)
    A_mq_b, A_mq_m, A_mw, A_mz_e, A_mz_e_dot = (A.get(key, no_column) for key in _SEEN_COLUMNS)
    signal_columns: list[tuple[str, np.ndarray]] = []
    # the [target] body stepped torque-free (sim/target_run.py); with [capture], the hook
    # that grasps it and swaps the plant for the merged robot's (sim/capture_run.py)
    target, capture = target_motions(setup)
    wall0 = time.perf_counter()
    k = 0
    try:
        for k in range(n_steps + 1):
            t = k * dt
            if capture is not None:  # grasp on the true state; then the merged robot's plant
                plant, sensor, v = capture.at_period(t, q, v, plant, sensor)
            if progress is not None and t >= next_progress:
                progress(t)
                next_progress += 0.1
            meas = sensor.measure(t, q, v)
            record = k % record_every == 0 or k == n_steps
            seen = meas if sensors is None else sensors.observe(meas)  # noise, delay
            # what was measured is recorded before the controller runs, so that a controller
            # writing into its measurement cannot change the recorded truth (at the first
            # period, whose row goes to the recorder built after it, from copies)
            if k == 0:
                first = (_frozen(meas), _frozen(seen))
            elif record:
                i = rec.i
                A_t[i], A_q[i], A_v[i], A_w[i] = t, q, v, meas.w
                A_z_e[i], A_z_e_dot[i] = meas.z_e[:nt], meas.z_e_dot[:nt]
                A_q_b[i] = meas.q_b
                if sensors is not None:  # what the controller saw
                    A_mq_b[i], A_mq_m[i], A_mw[i] = seen.q_b, seen.q_m, seen.w
                    A_mz_e[i], A_mz_e_dot[i] = seen.z_e[:nt], seen.z_e_dot[:nt]
                if target is not None:
                    target.write(A, i)
            try:
                if capture is not None:  # a grasp this period: the controller's on_capture
                    capture.notify(controller)
                u_cmd, signals = split_reply(controller.step(seen))
                u_cmd = checked_torque(u_cmd, n)
                if wheels is not None:  # the controller's wheel torques, or the wheels' own
                    wheels.command(controller, seen)
                if k == 0:  # the controller's signals: names and shapes from the first period
                    names = {key: recorded_name(key) for key in signals}
                    for key, value in signals.items():
                        fault = _signal_fault(key, value)
                        if fault is not None:
                            raise fault
                    new = {names[key]: np.shape(val) for key, val in signals.items()}
                    if any(shapes.get(key, shape) != shape for key, shape in new.items()):
                        raise ControllerFault(
                            f"the controller's signals {new} differ from its signal_shapes"
                        )
                    wrong = {k_: s_ for k_, s_ in new.items() if standard.get(k_, s_) != s_}
                    if wrong:
                        raise ControllerFault(
                            f"the controller's standard signals {wrong} need the shapes "
                            f"{ {k_: standard[k_] for k_ in wrong} } (docs/controllers.md)"
                        )
                    if set(new) - set(shapes):
                        shapes = {**shapes, **new}
                        rec = recorder_of(shapes)
                        A, A_signals = rec.arrays, rec.block
                        A_t, A_q, A_v, A_w, A_u_m, A_u_cmd, A_z_e, A_z_e_dot, A_q_b, A_dw_b = (
                            A[key] for key in _LOOP_COLUMNS
                        )
                        A_mq_b, A_mq_m, A_mw, A_mz_e, A_mz_e_dot = (
                            A.get(key, no_column) for key in _SEEN_COLUMNS
                        )
                    # the controller's columns, looked up once (they outlive every spill)
                    signal_columns = [(key, A[names[key]]) for key in signals]
                    assert first is not None
                    m0, s0 = first
                    A_t[0], A_q[0], A_v[0], A_w[0] = t, q, v, m0.w
                    A_z_e[0], A_z_e_dot[0] = m0.z_e[:nt], m0.z_e_dot[:nt]
                    A_q_b[0] = m0.q_b
                    if sensors is not None:
                        A_mq_b[0], A_mq_m[0], A_mw[0] = s0.q_b, s0.q_m, s0.w
                        A_mz_e[0], A_mz_e_dot[0] = s0.z_e[:nt], s0.z_e_dot[:nt]
                    if target is not None:
                        target.write(A, 0)
            except SimulationError as exc:
                stop = exc
                break
            except KeyboardInterrupt:
                raise
            except BaseException as exc:  # a controller's own failure (sys.exit too) is a stop
                what = str(exc) if isinstance(exc, ControllerFault) else (
                    f"the controller raised {type(exc).__name__}: {exc}"
                )  # fmt: skip
                stop = SimulationError(f"t = {t:.4f} s: {what}", time=t, cause="controller")
                break
            if capture is not None and capture.outcome.time == t:  # the grasp, for --recover
                rec.note("capture", capture.record())
            final = k == n_steps
            u_m = u_cmd
            if actuators is not None:
                u_m = actuators.apply(u_m)
                saturated += actuators.last_saturated
            if not final:
                q_new, v_new, a = plant.advance(q, v, u_m, dt, sc.substeps)
                if target is not None:  # torque-free: the robot does not touch it (yet)
                    target.advance(dt)
            else:
                a = plant.acceleration(q, v, u_m)
            if record:
                i = rec.i
                try:
                    if type(signals) is SignalRow and signals.layout is layout:
                        if len(signals.row) != A_signals.shape[1]:  # (not broadcast)
                            raise ValueError(
                                f"a row of {len(signals.row)} entries for a layout of "
                                f"{A_signals.shape[1]}"
                            )
                        A_signals[i] = signals.row
                    else:
                        if len(signals) != len(signal_columns):
                            raise KeyError(
                                sorted(map(repr, set(signals).symmetric_difference(names)))
                            )
                        for key, column in signal_columns:
                            value = signals[key]
                            fault = _signal_fault(key, value)
                            if fault is not None:
                                raise TypeError(str(fault))
                            column[i] = value
                except (KeyError, ValueError, IndexError, TypeError) as exc:
                    stop = SimulationError(
                        f"t = {t:.4f} s: the controller's signals changed after the first "
                        f"period ({type(exc).__name__}: {exc}); each signal needs the same "
                        "name, shape and type every period",
                        time=t, cause="controller",
                    )  # fmt: skip
                    break
                A_u_m[i], A_u_cmd[i] = u_m, u_cmd
                if wheels is not None:
                    wheels.write(A, i, v)
                A_dw_b[i] = sensor.base_angular_acceleration(a)  # for F_r (Eq. 7)
                rec.commit()
            if final:
                break
            status = plant.state_status(q_new, v_new, RATE_LIMIT)
            if status != STATE_OK:
                stop = state_stop(status, t + dt, v_new, n_lin)
                break
            q, v = q_new, v_new
    except KeyboardInterrupt:  # Ctrl-C: a stop like any other; the rows so far are kept
        stop = interrupted_stop(k * dt)
    # the whole system's signals and summary keys: with the target, with the wheels
    signals = system_signals(setup, rec.finish(), capture, wheels, reaction, plant)
    outcomes = system_outcomes(signals, capture, wheels, k + 1)
    wall = time.perf_counter() - wall0  # the loop and the signals computed after it
    if progress is not None:
        progress(min(k * dt, duration))
    return loop_result(setup, signals, k, wall, stop, saturated, capture, outcomes)


def state_stop(status: int, t: float, v: np.ndarray, n_linear: int) -> SimulationError:
    """The stop of a plant state at ``t`` [s] that its check (:meth:`~.plant.Plant.
    state_status`) did not pass: not finite, or a rate above :data:`RATE_LIMIT`.

    Parameters
    ----------
    status : int
        ``STATE_NONFINITE`` or ``STATE_BLOW_UP``.
    t : float
        Time of the state [s].
    v : ndarray
        Its velocity (Pinocchio convention).
    n_linear : int
        Linear base velocity entries of ``v`` (the rates come after them).

    Returns
    -------
    SimulationError
        The stop (cause ``"nonfinite"``).
    """
    if status == STATE_NONFINITE:
        what = "the plant state became non-finite"
    else:  # STATE_BLOW_UP (1e4: RATE_LIMIT)
        what = (f"numerical blow-up, a rate exceeded 1e4 rad/s (max |w| = "
                f"{np.max(np.abs(v[n_linear:])):.3g})")  # fmt: skip
    return SimulationError(f"t = {t:.4f} s: {what}", time=t, cause="nonfinite")


def interrupted_stop(t: float) -> SimulationError:
    """The stop of a run a Ctrl-C ended at ``t`` [s] (cause ``"interrupted"``)."""
    return SimulationError(f"t = {t:.4f} s: interrupted (Ctrl-C)", time=t, cause="interrupted")


def loop_result(
    setup: Setup,
    signals: Signals,
    steps: int,
    wall: float,
    stop: SimulationError | None,
    saturated: int,
    capture: CaptureMotion | None = None,
    outcomes: tuple = (),
) -> RunResult:
    """The result of a run loop that took ``steps`` steps in ``wall`` [s] (its after-run
    signals included), stopped by ``stop`` (None: completed), with ``saturated`` control
    periods at a torque limit (a single run's, :func:`simulate`, and a lock-step case's,
    :mod:`.lockstep`).

    Parameters
    ----------
    setup : Setup
        The run's setup.
    signals : Signals
        Its signals, the after-run ones included.
    steps : int
        Steps taken.
    wall : float
        The loop's wall time [s].
    stop : SimulationError or None
        What stopped the run; None: it completed.
    saturated : int
        Control periods with some joint at its torque limit.
    capture : CaptureMotion or None
        The capture hook (its outcome is reported).
    outcomes : tuple
        The capture's and the wheels' summary keys (``system_outcomes``).

    Returns
    -------
    RunResult
        The result.
    """
    actuators, n = setup.actuators, setup.model.n_joints
    return run_result(
        setup,
        signals,
        steps=steps,
        wall_time_s=wall,
        **stop_outcome(stop),
        events=setup.events + list(getattr(setup.controller, "events", [])),
        saturation_fraction=saturated / (steps + 1) if actuators is not None else 0.0,
        saturation_per_joint=(
            actuators.saturation_per_joint(steps + 1) if actuators else [0.0] * n
        ),
        capture=None if capture is None else capture.outcome,
        outcomes=outcomes,
    )
