"""Lock-step runs: several prepared runs on one robot stepped together, each giving the
:class:`~ffsm_pin.sim.result.RunResult` its own :func:`~ffsm_pin.sim.loop.simulate` gives,
bit for bit.

A campaign's batch (:mod:`ffsm_pin.sweep.batches`) holds cases that share a robot and differ in
their draws: estimates, dispersed bodies, sensor and actuator seeds. Run one by one, most of a
case's step is Python around small arrays (benchmarks/README.md, "A step's parts in a campaign
case"). :func:`simulate_lockstep` holds the batch's states as arrays, ``(B, nq)`` and ``(B, nv)``,
and each step does for the whole batch at once what is the same arithmetic for every case: the
rest of the measurement after Pinocchio's kinematics, the sensors' noise (each case's own
stream, drawn as :class:`~ffsm_pin.sim.sensors.Sensors` draws it), **the cases' compiled
control periods in one numba call** (each case's own controller state), the actuators in one
call, the semi-implicit velocity update, the state checks and the recorded rows. Pinocchio's
calls (kinematics, ABA, ``integrate``, the centroidal map) and the plant's momentum projection
stay case by case: the physics is each case's own Pinocchio model, as in its single run.

Each case stops on its own (a funnel left, damped too long, a blow-up) with the stop message,
the rows and the summary its single run gives; the others go on. What lock-step takes is what
:func:`lockstep_obstacle` accepts: a controller that offers its compiled period to be stepped
from outside (its ``lockstep_obstacle`` None, ``period_handles``, ``settle``: the paper's
adaptive controller on the compiled backend); sensors exact, ideal or noisy without delay;
actuators without torque noise; the semi-implicit plant without substeps; no target,
capture, wheels or approach. Anything else runs through :func:`~ffsm_pin.sim.loop.simulate`,
as :func:`lockstep_groups` sorts it.
Equality with the single runs is tested bit for bit (tests/sim/test_lockstep.py) and checked
on the campaign cases by ``benchmarks/bench_lockstep.py``. See docs/campaigns.md, "Lock-step
batches".
"""

from __future__ import annotations

import math
import time
from collections.abc import Hashable, Sequence
from functools import partial
from pathlib import Path

import numpy as np
import pinocchio as pin
from numba.typed import List

from ..control import _first_compile, kernels
from ..control.backend import numba_available
from ..control.diagnostics import reaction_torques
from ..control.interface import Measurement, recorded_name
from ..errors import ParameterError, SimulationError
from . import _lockstep_kernels
from ._sensor_kernels import spatial_measurement
from .loop import RATE_LIMIT
from .recorder import Recorder
from .recording import recorder_shapes, run_result, spool_header, stop_outcome
from .result import RunResult
from .setup import Setup
from .storage import rows_recorded
from .system_signals import system_outcomes, system_signals
from .wheels_run import loop_plant

__all__ = ["lockstep_groups", "lockstep_obstacle", "simulate_lockstep"]

#: Steps whose rows a lock-step run holds for the whole batch before handing them to each
#: case's recorder.
CHUNK_STEPS = 1024


def lockstep_obstacle(setup: Setup) -> str | None:
    """Why ``setup`` cannot run in lock-step (:func:`simulate_lockstep`), or None when it can.

    Parameters
    ----------
    setup : Setup
        A prepared run.

    Returns
    -------
    str or None
        The first feature lock-step does not take, in words.
    """
    sc, ctrl = setup.scenario, setup.controller
    why = getattr(ctrl, "lockstep_obstacle", f"controller {type(ctrl).__name__}: no period "
                  "to step in lock-step (no lockstep_obstacle, period_handles)")  # fmt: skip
    if why is not None:
        return why
    checks = (
        (getattr(ctrl, "period", None) != sc.dt, "a control period other than the step"),
        (setup.target is not None or setup.approach is not None, "a [target]"),
        (sc.robot.wheels is not None, "reaction wheels"),
        (
            sc.integrator != "semi-implicit" or sc.substeps != 1,
            "an integrator other than the semi-implicit Euler step, one substep a period",
        ),  # fmt: skip
        (_sensing_mode(setup) is None, "sensors with a delay"),
        (setup.actuators is not None and setup.actuators.noisy, "actuators' torque noise"),
    )
    return next((why for bad, why in checks if bad), None)


def _sensing_mode(setup: Setup) -> str | None:
    """What the controller sees: ``"exact"`` (no sensors), ``"ideal"`` (sensors that change
    nothing, recorded as seen), ``"noisy"`` (noise without delay); None: anything else."""
    s = setup.sensors
    if s is None:
        return "exact"
    if s.ideal:
        return "ideal"
    return "noisy" if s.noisy and s.spec.delay == 0 else None


def lockstep_key(setup: Setup) -> Hashable:
    """What the runs of one lock-step share: the robot's root joint and sizes, the task, the
    step and the steps, the sensors' mode, ideal actuators or not, the recorded signals."""
    sc, m = setup.scenario, setup.robot.model
    ideal = setup.actuators is None or setup.actuators.ideal
    shapes = tuple(sorted(recorder_shapes(setup).items()))
    steps = int(round(sc.duration / sc.dt))
    return (setup.robot.base, m.nq, m.nv, setup.n_task, sc.dt, steps, _sensing_mode(setup),
            ideal, shapes)  # fmt: skip


def lockstep_groups(setups: Sequence[Setup], smallest: int = 2) -> list[list[int]]:
    """The indices of ``setups`` that can run in lock-step, in groups that share a
    :func:`lockstep_key` (in order of their first index); groups of fewer than ``smallest``
    runs are left out (a run alone gains nothing).

    Parameters
    ----------
    setups : sequence of Setup
        Prepared runs.
    smallest : int
        The fewest runs of a group.

    Returns
    -------
    list of list of int
        The groups.
    """
    groups: dict[Hashable, list[int]] = {}
    for i, setup in enumerate(setups):
        if lockstep_obstacle(setup) is None:
            groups.setdefault(lockstep_key(setup), []).append(i)
    return [g for g in groups.values() if len(g) >= smallest]


class _PlanarSensing:
    """The exact measurement of a planar batch, the arithmetic of
    :class:`~ffsm_pin.sim.measurement.Sensor`: Pinocchio's kinematics and the end-effector
    angle case by case, the continued base angle, q_m and w for the batch at once."""

    rates = np.array([0, 1, 5])  # (dx/dt, dy/dt, attitude rate) of the frame's 6-vector

    def __init__(self, setups: Sequence[Setup]):
        B = len(setups)
        self.models = [s.robot.model for s in setups]
        self.datas = [m.createData() for m in self.models]
        self.angles = [s.model.ee_angle for s in setups]  # type: ignore[attr-defined]
        self.fid = setups[0].robot.ee_frame_id
        self.z_e, self.z_e_dot = np.empty((B, 3)), np.empty((B, 3))
        self.prev: np.ndarray | None = None

    def measure(self, Q, V, live):
        # (math.atan2, the sensor's: numpy's arctan2 gives other bits for some angles)
        q_b = np.array([math.atan2(s, c) for c, s in Q[:, 2:4]])
        if self.prev is not None:  # continuous attitude
            q_b += 2 * math.pi * np.round((self.prev - q_b) / (2 * math.pi))
        self.prev = q_b
        q_m, fid = Q[:, 4:], self.fid
        for b in live:
            model, data = self.models[b], self.datas[b]
            pin.forwardKinematics(model, data, Q[b], V[b])
            self.z_e[b] = pin.updateFramePlacement(model, data, fid).translation
            twist = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED).vector
            self.z_e_dot[b] = twist[self.rates]
            self.z_e[b, 2] = self.angles[b](q_b[b], q_m[b])
        return q_b, q_m, V[:, 2:], self.z_e, self.z_e_dot

    def base_acceleration(self, acc, live):
        return acc[:, 2]


class _SpatialSensing:
    """The exact measurement of a free-flyer batch: Pinocchio's kinematics and the sensor's
    compiled MRP arithmetic case by case; the base acceleration by the measured R_0."""

    def __init__(self, setups: Sequence[Setup]):
        B, n = len(setups), setups[0].model.n_joints
        self.models = [s.robot.model for s in setups]
        self.datas = [m.createData() for m in self.models]
        self.fid = setups[0].robot.ee_frame_id
        self.q_b, self.w, self.R0 = np.empty((B, 3)), np.empty((B, n + 3)), np.empty((B, 3, 3))
        self.z_e, self.z_e_dot, self.dw_b = np.empty((B, 6)), np.empty((B, 6)), np.empty((B, 3))

    def measure(self, Q, V, live):
        fid = self.fid
        for b in live:
            model, data = self.models[b], self.datas[b]
            pin.forwardKinematics(model, data, Q[b], V[b])
            oMf = pin.updateFramePlacement(model, data, fid)
            twist = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            q_b, R0, z_e, z_e_dot, w = spatial_measurement(Q[b], V[b], oMf.homogeneous,
                                                           twist.vector)  # fmt: skip
            self.q_b[b], self.R0[b], self.z_e[b], self.z_e_dot[b], self.w[b] = (
                q_b,
                R0,
                z_e,
                z_e_dot,
                w,
            )
        return self.q_b, Q[:, 7:], self.w, self.z_e, self.z_e_dot

    def base_acceleration(self, acc, live):
        for b in live:  # (ndarray.dot, as the sensor's: the same BLAS call)
            self.dw_b[b] = self.R0[b].dot(acc[b, 3:6])
        return self.dw_b


#: The batch's exact measurement per root joint (``robot.base``): what differs between the
#: geometries, as the sensor's and the plant's tables.
_SENSING: dict[str, type[_PlanarSensing] | type[_SpatialSensing]] = {
    "planar": _PlanarSensing,
    "free-flyer": _SpatialSensing,
}


def simulate_lockstep(
    setups: Sequence[Setup],
    spool_dir: str | Path | None = None,
    memory_bytes: int | None = None,
) -> list[RunResult]:
    """Run ``setups`` in lock-step; see the module docstring.

    Each result is the one ``simulate(setup, spool_dir=spool_dir, memory_bytes=memory_bytes)``
    gives (every row recorded), bit for bit, but for ``wall_time_s``: the case's share of the
    batch's loop (by its steps) and its own signals computed after the run. A Ctrl-C stops
    every run still going, as a single run's.

    Parameters
    ----------
    setups : sequence of Setup
        Prepared runs, each accepted by :func:`lockstep_obstacle`, all of one
        :func:`lockstep_key`.
    spool_dir : str, Path or None
        As :func:`~ffsm_pin.sim.loop.simulate`'s.
    memory_bytes : int or None
        As :func:`~ffsm_pin.sim.loop.simulate`'s.

    Returns
    -------
    list of RunResult
        In the order of ``setups``.

    Raises
    ------
    ParameterError
        A setup lock-step does not take, or setups of different keys.
    """
    for i, setup in enumerate(setups):
        why = lockstep_obstacle(setup)
        if why is not None:
            raise ParameterError(f"simulate_lockstep: run {i} ({setup.scenario.name}): {why}")
    if len({lockstep_key(s) for s in setups}) > 1:
        raise ParameterError(
            "simulate_lockstep: the runs differ in robot, task, step, duration, sensors, "
            "actuators or signals; run each group of lockstep_groups() on its own"
        )
    if not setups:
        return []
    run = _Lockstep(setups, spool_dir, memory_bytes)
    wall0 = time.perf_counter()
    run.loop()
    return run.results(time.perf_counter() - wall0)


class _Lockstep:
    """The state of a lock-step run: the batch's arrays, each case's recorder and stop."""

    def __init__(self, setups, spool_dir, memory_bytes):
        self.setups = setups
        s0 = setups[0]
        sc = s0.scenario
        B, n = len(setups), s0.model.n_joints
        self.dt, self.n_steps, self.n, self.nt = (
            sc.dt,
            int(round(sc.duration / sc.dt)),
            n,
            s0.n_task,
        )
        self.plants = [loop_plant(s)[0] for s in setups]
        self.Q = np.array([s.q0 for s in setups])
        self.V = np.array([s.v0 for s in setups])
        for plant, q, v in zip(self.plants, self.Q, self.V, strict=True):
            plant.reset(q.copy(), v.copy())
        self.sensing = _SENSING[s0.robot.base](setups)
        self.handles = [s.controller.period_handles() for s in setups]  # type: ignore[attr-defined]
        self.reactions = [reaction_torques(s.model, s.theta_d, numba_available()) for s in setups]
        # each case's recorder, as its single run's (rows handed over a chunk at a time)
        n_rows = rows_recorded(self.n_steps, 1)
        layout = s0.controller.signal_layout  # type: ignore[attr-defined]
        packed = [recorded_name(key) for key in layout.shapes]
        self.shapes = recorder_shapes(s0)
        self.recorders = [
            Recorder(
                recorder_shapes(s),
                n_rows,
                spool_dir,
                chunk_bytes=memory_bytes,
                packed=packed,
                header=partial(spool_header, s, 1),
            )  # fmt: skip
            for s in setups
        ]
        self.columns = [k for k in self.shapes if k not in packed]
        T = min(CHUNK_STEPS, n_rows)
        self.buf = {k: np.full((B, T, *self.shapes[k]), np.nan) for k in self.columns}
        self.signal_rows = np.full((B, T, self.handles[0].row.size), np.nan)
        self.active = np.ones(B, dtype=np.bool_)
        self.rows = np.zeros(B, dtype=np.int64)  # rows committed per case
        self.flushed = 0  # steps handed to the recorders
        self.steps = np.full(B, self.n_steps)
        self.stops: list[SimulationError | None] = [None] * B
        self.saturated = np.zeros(B, dtype=np.int64)  # periods with a joint at its limit
        self.per_joint = np.zeros((B, n), dtype=np.int64)
        self.wall = 0.0

    def flush(self, k: int) -> None:
        """Hand the rows of the steps before ``k`` to each case's recorder."""
        for b, rec in enumerate(self.recorders):
            count = min(int(self.rows[b]), k) - self.flushed
            if count > 0:
                rec.write_rows({key: self.buf[key][b, :count] for key in self.columns},
                               self.signal_rows[b, :count])  # fmt: skip
        self.flushed = k

    def loop(self) -> None:  # noqa: C901, PLR0912, PLR0915 - the run loop, step by step
        setups, dt, n, nt = self.setups, self.dt, self.n, self.nt
        B, T, buf = len(setups), self.signal_rows.shape[1], self.buf
        Q, V = self.Q, self.V
        plants = self.plants
        n_base, n_lin = plants[0].n_base, plants[0].n_linear
        tau, acc = np.zeros(V.shape), np.zeros(V.shape)
        boxes = List([h.box for h in self.handles])
        rows = List([h.row for h in self.handles])
        M_none, h_none = self.handles[0].M, self.handles[0].h
        controllers: list = [s.controller for s in setups]  # (each: period_handles, settle)
        sensors = [s.sensors for s in setups]
        mode = _sensing_mode(setups[0])
        noisy, seen_cols = mode == "noisy", mode != "exact"
        if noisy:
            sl = sensors[0].noise_slices  # type: ignore[union-attr]
            noise = np.empty((B, 0, 0))
        acts = [s.actuators for s in setups]
        ideal = acts[0] is None or acts[0].ideal  # type: ignore[union-attr]
        if not ideal:
            X = np.array([a.x for a in acts])  # type: ignore[union-attr]
            limit = np.array([a.limit for a in acts])  # type: ignore[union-attr]
            alpha = np.array([a.alpha for a in acts], dtype=float)  # type: ignore[union-attr]
            lagged = np.array([a.lagged for a in acts])  # type: ignore[union-attr]
            max_change = np.array([a.max_change for a in acts])  # type: ignore[union-attr]
            rate_lim = np.array([a.rate_limited for a in acts])  # type: ignore[union-attr]
            zeros, U_m, sat = np.zeros(n), np.empty((B, n)), np.zeros(B, dtype=np.bool_)
            limits = (limit, alpha, lagged, max_change, rate_lim)  # each case's, as a bundle
        status, idx = np.zeros(B, dtype=np.int64), np.zeros(B, dtype=np.int64)
        value, damp, U = np.zeros(B), np.zeros(B), np.zeros((B, n))
        period_out = (status, idx, value, U, damp)  # what the periods write, per case
        booked = np.zeros(B, dtype=np.bool_)  # damped_since is not None: settle every period
        block_row = 0
        _first_compile.finish()
        k = 0
        try:
            for k in range(self.n_steps + 1):
                t, j = k * dt, k - self.flushed
                if j == T:
                    self.flush(k)
                    j = 0
                live = np.flatnonzero(self.active)
                if live.size == 0:
                    break
                q_b, q_m, w, z_e, z_e_dot = self.sensing.measure(Q, V, live)
                if noisy:  # each case's noise of this measurement, drawn a block at a time
                    if block_row == noise.shape[1]:
                        noise = np.array([s.noise_block() for s in sensors])  # type: ignore[union-attr]
                        block_row = 0
                    z = noise[:, block_row]
                    block_row += 1
                    base = z[:, sl["base_attitude"]]
                    s_q_b = q_b + (base[:, 0] if q_b.ndim == 1 else base)
                    s_q_m = q_m + z[:, sl["joints"]]
                    s_w = w + np.concatenate(
                        (z[:, sl["base_rate"]], z[:, sl["joint_rates"]]), axis=1
                    )
                    s_z_e, s_z_e_dot = z_e + z[:, sl["ee_pose"]], z_e_dot + z[:, sl["ee_velocity"]]
                else:
                    s_q_b, s_q_m, s_w, s_z_e, s_z_e_dot = q_b, q_m, w, z_e, z_e_dot
                buf["t"][:, j], buf["q"][:, j], buf["v"][:, j], buf["w"][:, j] = t, Q, V, w
                buf["z_e"][:, j], buf["z_e_dot"][:, j] = z_e[:, :nt], z_e_dot[:, :nt]
                buf["q_b"][:, j] = q_b.reshape(B, -1)
                if seen_cols:
                    buf["meas_q_b"][:, j], buf["meas_q_m"][:, j] = s_q_b.reshape(B, -1), s_q_m
                    buf["meas_w"][:, j], buf["meas_z_e"][:, j] = s_w, s_z_e[:, :nt]
                    buf["meas_z_e_dot"][:, j] = s_z_e_dot[:, :nt]
                seen = (s_q_b, s_q_m, s_w, s_z_e, s_z_e_dot)
                _lockstep_kernels.periods(boxes, rows, dt, t, seen, M_none, h_none, self.active,
                                          period_out, self.signal_rows, j)  # fmt: skip
                book = self.active & ((status != kernels.STATUS_OK) | (damp != 0.0) | booked)
                for b in np.flatnonzero(book):  # a period that is not plain: its bookkeeping
                    q_b_seen = float(s_q_b[b]) if s_q_b.ndim == 1 else s_q_b[b]
                    meas = Measurement(
                        t, q_b_seen, s_q_m[b], s_w[b], s_z_e[b], s_z_e_dot[b], None, None
                    )
                    try:
                        controllers[b].settle(meas, int(status[b]), int(idx[b]), float(value[b]))
                    except SimulationError as exc:  # the case stops; its row is not recorded
                        self.stop(b, exc, k, k)
                    booked[b] = controllers[b].damped_since is not None
                live = np.flatnonzero(self.active)
                if ideal:
                    u_m = U
                else:
                    _lockstep_kernels.actuate_all(U, X, limits, zeros, U_m, self.active, sat)
                    u_m = U_m
                    at = sat & self.active
                    self.saturated += at
                    self.per_joint[at] += np.abs(U_m[at]) >= limit[at]
                tau[:, n_base:] = u_m
                for b in live:
                    acc[b] = pin.aba(plants[b].model, plants[b].data, Q[b], V[b], tau[b])
                buf["u_m"][:, j], buf["u_cmd"][:, j] = u_m, U
                buf["dw_b"][:, j] = self.sensing.base_acceleration(acc, live)
                self.rows[live] += 1
                if k == self.n_steps:
                    break
                # the plant, as Plant.step: the semi-implicit velocity update for the batch,
                # pin.integrate and the momentum projection case by case
                V_new = V.copy()
                V_new[live] = V[live] + dt * acc[live]
                dq = dt * V_new
                Q_new = Q.copy()
                for b in live:
                    p = plants[b]
                    Q_new[b] = pin.integrate(p.model, Q[b], dq[b])
                    p.restore_momentum(Q_new[b], V_new[b])  # (Plant.step's projection)
                # the state checks of the loop, for the batch (a stopped case keeps its last
                # state, finite)
                finite = np.isfinite(Q_new).all(axis=1) & np.isfinite(V_new).all(axis=1)
                with np.errstate(invalid="ignore"):
                    rate = np.abs(V_new[:, n_lin:]).max(axis=1)
                for b in live[~finite[live] | (rate[live] > RATE_LIMIT)]:
                    if not finite[b]:
                        what = "the plant state became non-finite"
                    else:  # (1e4: RATE_LIMIT)
                        what = (f"numerical blow-up, a rate exceeded 1e4 rad/s (max |w| = "
                                f"{np.max(np.abs(V_new[b, n_lin:])):.3g})")  # fmt: skip
                    blow = SimulationError(f"t = {t + dt:.4f} s: {what}", time=t + dt,
                                          cause="nonfinite")  # fmt: skip
                    self.stop(b, blow, k, k + 1)
                    Q_new[b], V_new[b] = Q[b], V[b]
                Q, V = Q_new, V_new
        except KeyboardInterrupt:  # Ctrl-C: every run still going stops, its rows kept
            self.rows[self.active] = np.minimum(self.rows[self.active], k)
            for b in np.flatnonzero(self.active):
                self.stop(b, SimulationError(f"t = {k * dt:.4f} s: interrupted (Ctrl-C)",
                                             time=k * dt, cause="interrupted"), k, k)  # fmt: skip
        self.flush(self.n_steps + 1)
        if not ideal:
            for a, x, counts in zip(acts, X, self.per_joint, strict=True):
                a.x[:] = x  # type: ignore[union-attr]
                a.saturated_periods += counts  # type: ignore[union-attr]

    def stop(self, b: int | np.integer, exc: SimulationError, steps: int, rows: int) -> None:
        """Case ``b`` stops: ``exc`` says why, after ``steps`` steps and ``rows`` rows."""
        self.active[b] = False
        self.stops[b], self.steps[b], self.rows[b] = exc, steps, rows

    def results(self, wall: float) -> list[RunResult]:
        """Each case's result, as its single run makes it after its loop."""
        total = max(1, int(self.steps.sum()) + len(self.setups))
        out = []
        for b, setup in enumerate(self.setups):
            t0 = time.perf_counter()
            steps, acts = int(self.steps[b]), setup.actuators
            signals = system_signals(setup, self.recorders[b].finish(), None, None,
                                     self.reactions[b], self.plants[b])  # fmt: skip
            outcomes = system_outcomes(signals, None, None, steps + 1)
            share = wall * (steps + 1) / total + time.perf_counter() - t0
            out.append(run_result(
                setup, signals, steps=steps, wall_time_s=share, **stop_outcome(self.stops[b]),
                events=setup.events + list(getattr(setup.controller, "events", [])),
                saturation_fraction=int(self.saturated[b]) / (steps + 1) if acts else 0.0,
                saturation_per_joint=acts.saturation_per_joint(steps + 1) if acts
                else [0.0] * self.n, capture=None, outcomes=outcomes,
            ))  # fmt: skip
        return out
