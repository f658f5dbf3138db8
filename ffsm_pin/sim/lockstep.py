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

Each case stops on its own (a funnel left, damped too long, a torque not finite, a blow-up)
with the stop message, the rows and the summary its single run gives; the others go on.
What lock-step takes is what :func:`lockstep_obstacle` accepts: a controller that offers its
compiled period over a batch (``lockstep_obstacle`` None, ``lockstep_handles``, ``settle``:
:mod:`ffsm_pin.control.lockstep`; the paper's controller and both baselines on the compiled
backend), sensors exact, ideal or noisy without delay, actuators without torque noise, the
semi-implicit plant in one substep, no target, capture, wheels or approach. Anything else
runs through :func:`~ffsm_pin.sim.loop.simulate`, as :func:`lockstep_groups` sorts it.
Equality with the single runs is tested bit for bit (tests/sim/test_lockstep.py) and checked
on the campaign's cases by ``benchmarks/bench_lockstep.py``. See docs/campaigns.md, "Lock-step
batches".
"""

from __future__ import annotations

import time
from collections.abc import Hashable, Sequence
from functools import partial
from pathlib import Path

import numba
import numpy as np
import pinocchio as pin

from ..control import _first_compile
from ..control.backend import numba_available
from ..control.diagnostics import reaction_torques
from ..control.interface import SignalLayout, recorded_name
from ..errors import ParameterError, SimulationError
from . import _lockstep_kernels
from ._lockstep_parts import SENSING, Actuation, Control, Noise, sensing_mode
from .chunk_pool import ChunkPool
from .loop import RATE_LIMIT, interrupted_stop, loop_result, state_stop
from .recorder import Recorder
from .recording import (
    recorder_shapes,
    recording_size,
    spool_header,
)
from .result import RunResult
from .setup import Setup
from .storage import rows_recorded
from .system_signals import system_outcomes, system_signals
from .wheels_run import loop_plant

__all__ = ["lockstep_groups", "lockstep_obstacle", "simulate_lockstep"]

#: Steps whose rows a lock-step run holds for the whole batch before handing them to each
#: case's recorder.
CHUNK_STEPS = 1024

#: [bytes] The most a lock-step group's recordings hold together (:func:`lockstep_groups`): a
#: group's runs keep their rows until they all end, where runs one by one hold one run's at a
#: time (about 30 MB for 30 s of case 1, 130 MB for 20 s of ``spatial-realistic``).
GROUP_BYTES = 2**30


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
    why = getattr(ctrl, "lockstep_obstacle", f"controller {type(ctrl).__name__}: no batch "
                  "period (no lockstep_obstacle, lockstep_handles)")  # fmt: skip
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
        (sensing_mode(setup) is None, "sensors with a delay"),
        (setup.actuators is not None and setup.actuators.noisy, "actuators' torque noise"),
    )
    return next((why for bad, why in checks if bad), None)


def lockstep_key(setup: Setup) -> Hashable:
    """What the runs of one lock-step share: the controller's class (its batch kernel) and the
    compiled type of its item (options that change its bundles), the robot's root joint and
    sizes, the task, the step and the steps, the sensors' mode, ideal actuators or not, the
    recorded signals."""
    sc, m = setup.scenario, setup.robot.model
    ideal = setup.actuators is None or setup.actuators.ideal
    shapes = tuple(sorted(recorder_shapes(setup).items()))
    steps = int(round(sc.duration / sc.dt))
    item = numba.typeof(setup.controller.lockstep_handles().item)  # type: ignore[attr-defined]
    return (type(setup.controller), item, setup.robot.base, m.nq, m.nv, setup.n_task, sc.dt,
            steps, sensing_mode(setup), ideal, shapes)  # fmt: skip


def lockstep_groups(
    setups: Sequence[Setup], smallest: int = 2, memory_bytes: int = GROUP_BYTES
) -> list[list[int]]:
    """The indices of ``setups`` that can run in lock-step, in groups that share a
    :func:`lockstep_key` (in order of their first index), each cut so that its runs'
    recordings (:func:`~.recording.recording_size`, held together until the runs end) fit in
    ``memory_bytes``; groups of fewer than ``smallest`` runs are left out (a run alone gains
    nothing).

    Parameters
    ----------
    setups : sequence of Setup
        Prepared runs.
    smallest : int
        The fewest runs of a group.
    memory_bytes : int
        The most bytes of recordings a group holds (a run larger than it: a group alone).

    Returns
    -------
    list of list of int
        The groups.
    """
    groups: dict[Hashable, list[list[int]]] = {}
    held: dict[Hashable, int] = {}  # bytes of the key's last group
    for i, setup in enumerate(setups):
        if lockstep_obstacle(setup) is not None:
            continue
        key = lockstep_key(setup)
        steps, row = recording_size(setup)
        size = (steps + 1) * row
        if key not in groups or held[key] + size > memory_bytes:
            groups.setdefault(key, []).append([])
            held[key] = 0
        groups[key][-1].append(i)
        held[key] += size
    return [g for cut in groups.values() for g in cut if len(g) >= smallest]


def simulate_lockstep(
    setups: Sequence[Setup],
    spool_dir: str | Path | None = None,
    memory_bytes: int | None = None,
    pool: ChunkPool | None = None,
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
    pool : ChunkPool or None
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
    run = _Lockstep(setups, spool_dir, memory_bytes, pool)
    wall0 = time.perf_counter()
    run.loop()
    return run.results(time.perf_counter() - wall0)


class _Lockstep:
    """The state of a lock-step run: the batch's arrays, each case's recorder and stop."""

    def __init__(self, setups, spool_dir, memory_bytes, pool):
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
        # the momentum projection's terms: each case's conserved momentum, its rows, the maps
        self.momentum0 = np.array([p.momentum0 for p in self.plants])
        self.momentum_rows = self.plants[0].conserved_rows
        self.Ag = np.empty((B, 6, self.V.shape[1]))
        self.sensing = SENSING[s0.robot.base](setups)
        self.handles = [s.controller.lockstep_handles() for s in setups]  # type: ignore[attr-defined]
        self.reactions = [reaction_torques(s.model, s.theta_d, numba_available()) for s in setups]
        # each case's recorder, as its single run's (rows handed over a chunk at a time); the
        # controller's signals a row each step, packed as its layout's or split into columns
        n_rows = rows_recorded(self.n_steps, 1)
        ctrl = s0.controller
        layout = getattr(ctrl, "signal_layout", None)
        packed = [recorded_name(key) for key in layout.shapes] if layout else []
        self.split = [] if layout else [
            (recorded_name(key), start, stop, shape)
            for key, (start, stop, shape) in SignalLayout(ctrl.signal_shapes).slots.items()  # type: ignore[attr-defined]
        ]  # fmt: skip
        self.shapes = recorder_shapes(s0)
        self.recorders = [
            Recorder(
                recorder_shapes(s),
                n_rows,
                spool_dir,
                chunk_bytes=memory_bytes,
                pool=pool,
                packed=packed,
                header=partial(spool_header, s, 1),
            )  # fmt: skip
            for s in setups
        ]
        signal_keys = {*packed, *(name for name, *_ in self.split), "t"}
        self.columns = [k for k in self.shapes if k not in signal_keys]
        T = min(CHUNK_STEPS, n_rows)
        self.buf = {k: np.full((B, T, *self.shapes[k]), np.nan) for k in self.columns}
        self.signal_rows = np.full((B, T, self.handles[0].width), np.nan)
        self.active = np.ones(B, dtype=np.bool_)
        self.rows = np.zeros(B, dtype=np.int64)  # rows committed by a stopped case
        self.flushed = 0  # steps handed to the recorders
        self.steps = np.full(B, self.n_steps)
        self.stops: list[SimulationError | None] = [None] * B
        self.saturated = np.zeros(B, dtype=np.int64)  # periods with a joint at its limit
        self.n_base, self.n_lin = self.plants[0].n_base, self.plants[0].n_linear
        self.tau, self.acc = np.zeros(self.V.shape), np.zeros(self.V.shape)
        self.state = np.zeros(B, dtype=np.int64)  # the plant's state check per case

    def flush(self, k: int) -> None:
        """Hand the rows of the steps before ``k`` to each case's recorder (a case still
        going has committed them all; a stopped one its :attr:`rows`)."""
        t = np.arange(self.flushed, k) * self.dt  # (the loop's k * dt, bit for bit)
        for b, rec in enumerate(self.recorders):
            count = (k if self.active[b] else min(int(self.rows[b]), k)) - self.flushed
            if count > 0:
                columns = {key: self.buf[key][b, :count] for key in self.columns}
                columns["t"] = t[:count]
                rows = self.signal_rows[b, :count]
                for name, start, stop, shape in self.split:  # (unpacked signals)
                    columns[name] = rows[:, start:stop].reshape(count, *shape)
                rec.write_rows(columns, None if self.split else rows)
        self.flushed = k

    def loop(self) -> None:
        """Step every case to its end or its stop."""
        setups, dt = self.setups, self.dt
        T = self.signal_rows.shape[1]
        noise = Noise(setups)
        control = Control(setups, self.handles)
        acts = Actuation(setups)
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
                exact = self.sensing.measure(self.Q, self.V, live)
                seen = noise.add(exact)
                self.record_measurement(j, exact, seen)
                for b, exc in control.step(t, dt, seen, self.active, self.signal_rows, j):
                    self.stop(b, exc, k, k)  # the case stops; its row is not recorded
                if len(live) != np.count_nonzero(self.active):
                    live = np.flatnonzero(self.active)
                u_m = acts.apply(control.u, self.active)
                self.advance(k, t, u_m, live, j, control.u)
        except KeyboardInterrupt:  # Ctrl-C: every run still going stops, its rows kept
            for going in np.flatnonzero(self.active):
                self.stop(going, interrupted_stop(k * dt), k, k)
        self.flush(self.n_steps + 1)
        acts.finish()
        self.saturated = acts.periods_at

    def record_measurement(self, j: int, exact: tuple, seen: tuple) -> None:
        """Row ``j`` of the buffers: the state, what was measured and what was seen."""
        buf, B, nt = self.buf, len(self.setups), self.nt
        q_b, _, w, z_e, z_e_dot = exact
        buf["q"][:, j], buf["v"][:, j], buf["w"][:, j] = self.Q, self.V, w
        buf["z_e"][:, j], buf["z_e_dot"][:, j] = z_e[:, :nt], z_e_dot[:, :nt]
        buf["q_b"][:, j] = q_b.reshape(B, -1)
        if "meas_q_b" in buf:  # (with sensors)
            s_q_b, s_q_m, s_w, s_z_e, s_z_e_dot = seen
            buf["meas_q_b"][:, j], buf["meas_q_m"][:, j] = s_q_b.reshape(B, -1), s_q_m
            buf["meas_w"][:, j], buf["meas_z_e"][:, j] = s_w, s_z_e[:, :nt]
            buf["meas_z_e_dot"][:, j] = s_z_e_dot[:, :nt]

    def advance(self, k, t, u_m, live, j, u_cmd) -> None:
        """The plant's step ``k`` for the live cases, as :meth:`~.plant.Plant.step`: ABA,
        the semi-implicit velocity update for the batch, ``pin.integrate`` and the momentum
        projection case by case; the row's torques and base acceleration; the state checks
        (a case whose state is not finite or blows up stops, keeping its last state)."""
        dt, plants, buf, Q, V = self.dt, self.plants, self.buf, self.Q, self.V
        self.tau[:, self.n_base :] = u_m
        acc = self.acc
        for b in live:
            acc[b] = pin.aba(plants[b].model, plants[b].data, Q[b], V[b], self.tau[b])
        buf["u_m"][:, j], buf["u_cmd"][:, j] = u_m, u_cmd
        buf["dw_b"][:, j] = self.sensing.base_acceleration(acc, live)
        if k == self.n_steps:
            return
        if len(live) == len(plants):
            V_new = V + dt * acc
        else:
            V_new = V.copy()
            V_new[live] = V[live] + dt * acc[live]
        dq = dt * V_new
        Q_new, Ag = Q.copy(), self.Ag
        for b in live:
            p = plants[b]
            Q_new[b] = pin.integrate(p.model, Q[b], dq[b])
            Ag[b] = pin.computeCentroidalMap(p.model, p.data, Q_new[b])
        # Plant.step's momentum projection, the batch's in one call
        _lockstep_kernels.restore_momenta(Ag, V_new, self.momentum0, self.momentum_rows, live)
        if _lockstep_kernels.state_checks(Q_new, V_new, self.n_lin, RATE_LIMIT, self.active,
                                          self.state):  # fmt: skip
            for b in np.flatnonzero(self.state):  # (a stopped case keeps its last state)
                stop = state_stop(int(self.state[b]), t + dt, V_new[b], self.n_lin)
                self.stop(b, stop, k, k + 1)
                Q_new[b], V_new[b] = Q[b], V[b]
        self.Q, self.V = Q_new, V_new

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
            steps = int(self.steps[b])
            signals = system_signals(setup, self.recorders[b].finish(), None, None,
                                     self.reactions[b], self.plants[b])  # fmt: skip
            outcomes = system_outcomes(signals, None, None, steps + 1)
            share = wall * (steps + 1) / total + time.perf_counter() - t0
            saturated = int(self.saturated[b])
            out.append(loop_result(setup, signals, steps, share, self.stops[b], saturated,
                                   None, outcomes))  # fmt: skip
        return out
