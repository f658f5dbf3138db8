"""Closed-loop runs: build everything a scenario needs, then simulate and record.

``prepare(scenario)`` does every check that can fail *before* simulating (robot, frame,
feasibility, parameter sizes, initial errors inside the funnels, reachability horizon) and
raises :class:`~ffsm_pin.errors.FfsmError` subclasses. ``simulate(setup)`` never raises on
numerical trouble: a run that has to stop returns ``completed=False`` with the time and the
reason, and everything recorded so far.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..control.backend import numba_available
from ..control.diagnostics import reaction_torques
from ..control.funnel import Funnel
from ..control.gains import GainWarning
from ..control.interface import (
    Controller,
    ControllerContext,
    ReferenceSample,
    recorded_name,
    split_reply,
)
from ..control.kinematic import error_terms, task_errors, task_size
from ..control.registry import controller_class
from ..errors import ControllerLoadError, FfsmError, ScenarioError, SimulationError
from ..model import ReducedModel, State, make_model
from ..robot import Robot, load_robot
from .actuators import Actuators
from .estimates import initial_estimates
from .initial import initial_state
from .measurement import Sensor
from .plant import Plant
from .reach import ReachWarning, reach_horizon
from .recorder import Recorder, extend
from .result import RunResult
from .scenario import Scenario
from .sensors import Sensors
from .storage import check_storage, rows_recorded


@dataclass
class Setup:
    """A scenario made concrete: robot, models, initial state, truths and controller."""

    scenario: Scenario
    robot: Robot
    model: ReducedModel
    q0: np.ndarray
    v0: np.ndarray
    theta_z: np.ndarray  # true parameters
    theta_d: np.ndarray
    theta_b: np.ndarray
    controller: Controller  # any implementation of control.interface.Controller
    reach_horizon: float | None  # time the reference leaves the reach [s], None if never
    events: list[str]
    actuators: Actuators | None = None  # between the controller and the plant (ideal: None)
    sensors: Sensors | None = None  # between the plant and the controller (exact: None)
    funnel_b: Funnel | None = None  # the performance specification, sides fixed at t = 0
    funnel_z: Funnel | None = None

    @property
    def n_task(self) -> int:
        """Components of the end-effector task."""
        return task_size(self.model.m2, self.model.m3, self.scenario.reference.task)


# ---------------------------------------------------------------------- prepare
def prepare(scenario: Scenario) -> Setup:
    """Load, validate and build everything for ``scenario``; raise FfsmError on bad input."""
    spec = scenario.robot
    spatial = spec.base == "free-flyer"
    options = {}
    if spatial:
        options = {"locked_joints": dict(spec.locked_joints) or None, "satellite": spec.satellite}
    robot = load_robot(
        spec.urdf, spec.end_effector, base=spec.base, relative_to=spec.relative_to, **options
    )
    ctrl, ref = scenario.controller, scenario.reference
    cls = controller_class(ctrl.type, scenario.source.parent if scenario.source else None)
    model = make_model(robot)
    m3 = model.m3
    n_task = task_size(model.m2, m3, ref.task)
    check_task = getattr(cls, "check_task", None)  # a controller's early refusal, if any
    if check_task is not None:
        check_task(scenario, robot.n_joints, n_task, m3)
    for name, fp, size in (("b", ctrl.funnel_b, m3), ("z", ctrl.funnel_z, n_task)):
        if fp.size != size:
            raise ScenarioError(
                f"controller.funnel ({name}) has {fp.size} components, the {ref.task!r} task "
                f"of this robot needs {size}"
            )
    if ref.n_components != n_task:
        raise ScenarioError(
            f"reference.ee has {ref.n_components} components; the {ref.task!r} task of this "
            f"robot needs {n_task}"
        )
    if len(ref.base_attitude) != m3:
        raise ScenarioError(
            f"reference.base_attitude has {len(ref.base_attitude)} values, this robot needs {m3}"
        )
    check_gains = getattr(cls, "check_gains", None)  # a controller's discrete-time conditions
    for problem in check_gains(scenario, m3) if check_gains is not None else ():
        warnings.warn(problem, GainWarning, stacklevel=2)
    q0, v0 = initial_state(robot, scenario.initial)
    st = State(robot).update(q0, v0)
    truth = (
        np.array(model.true_theta_z(st.com_velocity)),
        np.array(model.theta_d),
        np.array(model.true_theta_b(st.angular_momentum)),
    )

    def estimates():  # drawn when the controller first reads ctx.estimates
        return initial_estimates(scenario, model, truth)

    if getattr(cls, "needs_estimates", False):  # checked before the funnels, as they are read
        estimates = _constant(estimates())
    sensor = Sensor(robot, model, full_model=False)
    meas0 = sensor.measure(0.0, q0, v0)
    if ref.origin != "absolute":  # relative to the initial pose: resolved, and saved resolved
        ref = ref.resolved(meas0.z_e, meas0.q_b, model.m2)
        scenario = dataclasses.replace(scenario, reference=ref)
    q_bd = np.array(ref.base_attitude, dtype=float)
    err_b, err_z = task_errors(ref, q_bd, 0.0, meas0.q_b, meas0.z_e, m3)
    funnels = {"b": Funnel(ctrl.funnel_b, err_b), "z": Funnel(ctrl.funnel_z, err_z)}
    for label, key, funnel, err in (
        ("base attitude", "rho_b0", funnels["b"], err_b),
        ("end-effector", "rho_z0", funnels["z"], err_z),
    ):
        if getattr(cls, "needs_funnels", False) and not funnel.inside(0.0, err):
            z0 = np.round(np.atleast_1d(meas0.z_e), 4).tolist()
            qb0 = np.round(np.atleast_1d(meas0.q_b), 4).tolist()
            hint = (
                f"move reference.ee (c terms) toward the initial end-effector pose z_e(0) = {z0}"
                if key == "rho_z0"
                else f"set reference.base_attitude near q_b(0) = {qb0}"
            )
            lo, hi = funnel.bounds(0.0)
            raise ScenarioError(
                f"initial {label} error {np.round(err, 4).tolist()} is not strictly inside its "
                f"funnel at t = 0 (bounds {np.round(lo, 4).tolist()} .. "
                f"{np.round(hi, 4).tolist()}); increase controller.funnel.{key} or {hint}"
            )
    ctx = ControllerContext(
        n_joints=robot.n_joints,
        m2=model.m2,
        m3=m3,
        task=ref.task,
        n_task=n_task,
        dt=scenario.dt,
        params=dict(ctrl.params),
        reference=_reference_function(ref),
        base_attitude_reference=q_bd,
        robot=robot,
        model=model,
        initial=meas0,
        scenario=scenario,
        estimates_source=estimates,
        truth=truth,
    )
    controller = _build_controller(cls, ctx, ctrl.type)
    events = []
    horizon = reach_horizon(model, truth[0], st.com_position, scenario.reference, scenario.duration)
    if horizon is not None:
        msg = (
            f"the reference leaves the arm's reach at t = {horizon:.1f} s (the system CoM drifts "
            f"with v_0 = {np.round(truth[0][: model.m2], 4).tolist()} m/s); no controller can "
            "track it "
            "beyond that"
        )
        events.append(msg)
        warnings.warn(msg, ReachWarning, stacklevel=2)
    n = robot.n_joints
    effort = np.asarray(robot.model.effortLimit)[-n:]  # the arm joints' URDF <limit effort>
    actuators = Actuators(scenario.actuators, n, scenario.dt, effort, robot.joint_names)
    sensors = Sensors(scenario.sensors, n, m3, model.m2 + m3)
    return Setup(
        scenario, robot, model, q0, v0, *truth, controller, horizon, events,
        None if actuators.ideal else actuators, None if sensors.ideal else sensors,
        funnels["b"], funnels["z"],
    )  # fmt: skip


def _constant(value):
    """A function returning ``value``."""
    return lambda: value


def _reference_function(ref):
    """ctx.reference: t -> (z_d, dz_d, ddz_d), task-size arrays."""

    def reference(t: float) -> ReferenceSample:
        return ReferenceSample(ref.ee_pose(t), ref.ee_rate(t), ref.ee_accel(t))

    return reference


def _build_controller(cls: type, ctx: ControllerContext, kind: str) -> Controller:
    """``cls(ctx)``; a user's constructor that fails is bad input (exit 2)."""
    try:
        return cls(ctx)
    except FfsmError:
        raise
    except Exception as exc:
        raise ControllerLoadError(
            f"controller.type {kind!r}: building {cls.__name__}(ctx) failed "
            f"({type(exc).__name__}: {exc})"
        ) from exc


# ---------------------------------------------------------------------- simulate
def recorder_shapes(setup: Setup) -> dict[str, tuple[int, ...]]:
    """Shape of one recorded row of every per-step signal the loop itself records, and of
    the controller's signals it declares (``signal_shapes``, under their recorded names)."""
    m = setup.model
    nq, nv, n = setup.robot.model.nq, setup.robot.model.nv, m.n_joints
    m3, nt = m.m3, setup.n_task
    planar = m3 == 1
    nw = n + m3
    # per-step signals; the funnels, their bounds, the reference, the true task errors and the
    # reaction torque are computed after the run (_after_run_signals)
    declared = getattr(setup.controller, "signal_shapes", None) or {}
    return {
        "t": (), "q": (nq,), "v": (nv,), "w": (nw,), "u_m": (n,), "z_e": (nt,),
        "q_b": (m3,), "P": (m.m2,),
        "L": () if planar else (3,), "dw_b": () if planar else (3,), "z_e_dot": (nt,),
        "u_cmd": (n,),
        **({} if setup.sensors is None else {  # what the controller saw
            "meas_q_b": (m3,), "meas_q_m": (n,), "meas_w": (nw,), "meas_z_e": (nt,),
            "meas_z_e_dot": (nt,),
        }),
        **{recorded_name(k): tuple(shape) for k, shape in declared.items()},
    }  # fmt: skip


def recording_size(setup: Setup) -> tuple[int, int]:
    """(steps, bytes per recorded row) of a run of ``setup``: the per-step signals and those
    :func:`_after_run_signals` adds (funnels, their bounds, the reference, the errors, F_r)."""
    sc = setup.scenario
    steps = int(round(sc.duration / sc.dt))
    per_step = sum(int(np.prod(shape)) for shape in recorder_shapes(setup).values())
    m3, nt = setup.model.m3, setup.n_task
    return steps, 8 * (per_step + 5 * m3 + 6 * nt)


#: The recorded columns the signals computed after the run are functions of.
AFTER_RUN_INPUTS = ("t", "q_b", "z_e", "q", "w", "dw_b")


def _after_run_signals(setup: Setup, reaction: Callable[..., np.ndarray]):
    """The recorded signals computed after the run, a block of rows at a time, from the
    recorded t, q_b and z_e: funnels and their bounds, the reference, and the true task errors
    of Eqs. (16)-(17) (as :func:`~ffsm_pin.control.kinematic.task_errors`, on which the
    specification's funnels are judged); from the recorded q_b, q, w and the base's angular
    acceleration dw_b: the reaction torque F_r of Eq. (7) with the true model, one compiled
    pass (``reaction``: :func:`~ffsm_pin.control.diagnostics.reaction_torques`)."""
    ref = setup.scenario.reference
    nq_root = setup.robot.root.nq  # q = (root, q_m)
    q_bd = np.asarray(ref.base_attitude, dtype=float)
    m3 = setup.model.m3
    funnel_b, funnel_z = setup.funnel_b, setup.funnel_z
    assert funnel_b is not None and funnel_z is not None  # prepare() sets both
    funnels = (("b", funnel_b), ("z", funnel_z))

    def per_row(block) -> dict[str, np.ndarray]:
        t = block["t"]
        out = {}
        for name, funnel in funnels:
            rho = funnel.rho(t[:, None])  # (samples, components)
            out[f"rho_{name}"] = rho
            out[f"bound_{name}_lower"] = funnel.lower * rho
            out[f"bound_{name}_upper"] = funnel.upper * rho
        out["z_e_d"], out["z_e_d_dot"] = ref.sample(t)
        out["err_b"], out["err_z"] = error_terms(block["q_b"], q_bd, block["z_e"], out["z_e_d"], m3)
        q_m = block["q"][:, nq_root:]
        out["F_r"] = reaction(block["q_b"], q_m, block["w"], block["dw_b"])
        return out

    truth = {"theta_z": setup.theta_z, "theta_d": setup.theta_d, "theta_b": setup.theta_b}
    return per_row, truth


class _ControllerFault(Exception):
    """A controller broke the interface (a bad torque or signal); the run stops."""


def _checked_torque(u, n: int) -> np.ndarray:
    u = np.asarray(u, dtype=float)
    if u.shape != (n,):
        raise _ControllerFault(
            f"the controller returned a torque of shape {u.shape}; expected ({n},), one per "
            "joint [N m]"
        )
    if not np.isfinite(u).all():
        raise _ControllerFault(
            f"the controller returned a non-finite torque {u.tolist()} (shape ({n},))"
        )
    return u


def simulate(
    setup: Setup,
    progress=None,
    record_every: int = 1,
    spool_dir: str | Path | None = None,
) -> RunResult:
    """Run the closed loop for the scenario's duration; see the module docstring.

    Parameters
    ----------
    setup:
        The prepared run (:func:`prepare`).
    progress:
        Called with the simulated time [s] every 0.1 s of it, or None.
    record_every:
        Record every this many steps (and the last step).
    spool_dir:
        Where a recording longer than the recorder's memory chunk is spilled
        (``ffsm_pin.sim.recorder``); the system's temporary folder when None.

    A Ctrl-C (``KeyboardInterrupt``) ends the run like a stop: the result holds every row
    recorded so far, ``stop_cause = "interrupted"``. A controller that raises, or returns a
    torque of the wrong shape or not finite, stops the run with ``stop_cause = "controller"``.
    """
    sc = setup.scenario
    dt, duration = sc.dt, sc.duration
    n_steps = int(round(duration / dt))
    record_every = max(1, int(record_every))
    # the rows a run records go to disk past the first chunk (ffsm_pin.sim.recorder)
    check_storage(*recording_size(setup), record_every, spool_dir or tempfile.gettempdir())
    controller = setup.controller
    model = setup.model
    plant = Plant(setup.robot, integrator=sc.integrator)
    needs_dynamics = bool(getattr(controller, "needs_dynamics", False))
    sensor = Sensor(setup.robot, model, full_model=needs_dynamics)  # Pinocchio M, C w
    shapes = recorder_shapes(setup)
    n_rows = rows_recorded(n_steps, record_every)
    rec = Recorder(shapes, n_rows, spool_dir)
    A = rec.arrays
    q, v = setup.q0.copy(), setup.v0.copy()
    plant.reset(q, v)
    completed, stop_reason, stop_time = True, None, None
    stop_cause = stop_funnel = None
    next_progress = 0.0
    m3, nt, n = model.m3, setup.n_task, model.n_joints
    spatial = m3 > 1
    sensor.measure(0.0, q, v)  # compile / load the kernels before the clock starts
    # likewise F_r's after-run pass (true model, Eq. 7), on one row of zeros
    reaction = reaction_torques(model, setup.theta_d, numba_available())
    reaction(np.zeros((1, m3)), np.zeros((1, n)), np.zeros((1, n + m3)),
             np.zeros((1, *shapes["dw_b"])))  # fmt: skip
    sensor._q_b_prev = None  # the run measures t = 0 again
    plant.project(q, v)  # likewise the plant's compiled projection (result unused)
    n_lin = 3 if spatial else 2  # base linear velocity entries of v
    actuators, sensors = setup.actuators, setup.sensors
    saturated = 0  # control periods with some joint at its torque limit
    names: dict[str, str] = {}  # controller signal -> recorded name
    wall0 = time.perf_counter()
    k = 0
    try:
        for k in range(n_steps + 1):
            t = k * dt
            if progress is not None and t >= next_progress:
                progress(t)
                next_progress += 0.1
            meas = sensor.measure(t, q, v)
            record = k % record_every == 0 or k == n_steps
            seen = meas if sensors is None else sensors.observe(meas)  # noise, delay
            try:
                u_cmd, signals = split_reply(controller.step(seen))
                u_cmd = _checked_torque(u_cmd, n)
                if k == 0:  # the controller's signals: names and shapes from the first period
                    names = {key: recorded_name(key) for key in signals}
                    new = {names[key]: np.shape(val) for key, val in signals.items()}
                    if any(shapes.get(key, shape) != shape for key, shape in new.items()):
                        raise _ControllerFault(
                            f"the controller's signals {new} differ from its signal_shapes"
                        )
                    if set(new) - set(shapes):
                        shapes = {**shapes, **new}
                        rec = Recorder(shapes, n_rows, spool_dir)
                        A = rec.arrays
            except SimulationError as exc:
                completed, stop_reason, stop_time = False, str(exc), exc.time
                stop_cause, stop_funnel = exc.cause, exc.funnel
                break
            except Exception as exc:  # a controller's own failure is a stop, not a crash
                what = str(exc) if isinstance(exc, _ControllerFault) else (
                    f"the controller raised {type(exc).__name__}: {exc}"
                )  # fmt: skip
                completed, stop_time, stop_cause = False, t, "controller"
                stop_reason = f"t = {t:.4f} s: {what}"
                break
            final = k == n_steps
            u_m = u_cmd
            if actuators is not None:
                u_m = actuators.apply(u_m)
                saturated += actuators.last_saturated
            if not final:
                q_new, v_new, a = plant.advance(q, v, u_m, dt, sc.substeps)
            else:
                a = plant.acceleration(q, v, u_m)
            if record:
                i = rec.i
                try:
                    for key, val in signals.items():
                        A[names[key]][i] = val
                except (KeyError, ValueError) as exc:
                    completed, stop_time, stop_cause = False, t, "controller"
                    stop_reason = (
                        f"t = {t:.4f} s: the controller's signals changed after the first "
                        f"period ({type(exc).__name__}: {exc}); each signal needs the same "
                        "name and shape every period"
                    )
                    break
                A["t"][i] = t
                A["q"][i], A["v"][i], A["w"][i], A["u_m"][i] = q, v, meas.w, u_m
                A["u_cmd"][i] = u_cmd
                A["z_e"][i], A["z_e_dot"][i] = meas.z_e[:nt], meas.z_e_dot[:nt]
                A["q_b"][i] = meas.q_b
                if sensors is not None:  # what the controller saw
                    A["meas_q_b"][i], A["meas_q_m"][i], A["meas_w"][i] = seen.q_b, seen.q_m, seen.w
                    A["meas_z_e"][i] = seen.z_e[:nt]
                    A["meas_z_e_dot"][i] = seen.z_e_dot[:nt]
                mom = plant.momentum(q, v)
                # dw_b/dt for F_r (Eq. 7, after the run): spatial in the inertial frame,
                # R_0(q_b) of this measurement (docs/spatial.md 1)
                if spatial:
                    A["P"][i], A["L"][i] = mom[:3], mom[3:]
                    A["dw_b"][i] = sensor.R0 @ a[3:6]
                else:
                    A["P"][i], A["L"][i] = mom[:2], mom[2]
                    A["dw_b"][i] = a[2]
                rec.commit()
            if final:
                break
            if not (np.isfinite(q_new).all() and np.isfinite(v_new).all()):
                completed, stop_time, stop_cause = False, t + dt, "nonfinite"
                stop_reason = f"t = {t + dt:.4f} s: the plant state became non-finite"
                break
            if np.abs(v_new[n_lin:]).max() > 1e4:
                completed, stop_time, stop_cause = False, t + dt, "nonfinite"
                stop_reason = (
                    f"t = {t + dt:.4f} s: numerical blow-up, a rate exceeded 1e4 rad/s "
                    f"(max |w| = {np.max(np.abs(v_new[n_lin:])):.3g})"
                )
                break
            q, v = q_new, v_new
    except KeyboardInterrupt:  # Ctrl-C: a stop like any other; the rows so far are kept
        completed, stop_time, stop_cause = False, k * dt, "interrupted"
        stop_reason = f"t = {k * dt:.4f} s: interrupted (Ctrl-C)"
    per_row, truth = _after_run_signals(setup, reaction)
    signals = extend(rec.finish(), per_row, truth, AFTER_RUN_INPUTS)
    wall = time.perf_counter() - wall0  # the loop and the signals computed after it
    if progress is not None:
        progress(min(k * dt, duration))
    kind = sc.controller.type
    return RunResult(
        scheme=sc.controller.scheme if kind == "lu-jia" else None,
        robot=setup.robot.name,
        dt=dt,
        duration=duration,
        steps=k,
        wall_time_s=wall,
        completed=completed,
        stop_reason=stop_reason,
        signals=signals,
        scenario_name=sc.name,
        stop_time=stop_time,
        stop_cause=stop_cause,
        stop_funnel=stop_funnel,
        integrator=sc.integrator,
        substeps=sc.substeps,
        events=setup.events + list(getattr(controller, "events", [])),
        rhoinf_b=sc.controller.funnel_b.rhoinf,
        rhoinf_z=sc.controller.funnel_z.rhoinf,
        damping_threshold=sc.controller.singularity.threshold,
        description=sc.description,
        saturation_fraction=saturated / (k + 1) if actuators is not None else 0.0,
        controller=kind,
    )
