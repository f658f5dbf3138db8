"""What a campaign case would cost run in lock-step with the other cases of its batch: a
prototype lock-step loop, timed against the same cases run one by one by the package's loop
and checked against them row by row.

Usage::

    python benchmarks/bench_lockstep.py                       # 8 case-1 cases, 5 s each
    python benchmarks/bench_lockstep.py --scenario spatial-realistic --duration 4
    python benchmarks/bench_lockstep.py --batch 16 --duration 10 --repeat 3

The cases are the first ``--batch`` cases of the shipped campaign ``compare-controllers`` for
``--scenario`` (``case1``, ``planar5`` or ``spatial-realistic``) and the paper's controller
(perturbed estimates, torque limits, noise on every measurement), ``--duration`` s each.

* **One by one**: each case through the package (``prepare``, ``simulate``), its loop's time
  less its after-run signals (momentum rows and F_r, which the prototype does not compute;
  their time is printed apart).
* **Lock-step** (:func:`lockstep`): the batch's states as arrays (B, nq), (B, nv); each step
  the exact measurement (Pinocchio's kinematics case by case, the rest at once where it is
  the same arithmetic: a table per root joint, :data:`MEASUREMENTS`), the sensors' noise for
  the batch at once (each case's own seeded stream, drawn in blocks as
  :class:`ffsm_pin.sim.sensors.Sensors` draws it), the batch's compiled periods in one numba
  call (each case's own box, ``CompiledPeriod.period_handles``; a period that is not plain
  is booked by its controller's ``settle``, which raises the case's stop), the actuators'
  saturation for the batch at once, the plant (ABA, ``pin.integrate`` and the plant's own
  projection kernel case by case, the semi-implicit velocity update at once), the state
  checks and the recorded rows for the batch at once. A case that stops leaves the batch.
* The bare Python plant loop of the performance issue (``bench_run.py``'s), same steps.

The prototype covers what these cases need and refuses the rest: the paper's adaptive
controller without the auxiliary system or the physical projection, sensor noise without
delay, actuators with torque limits alone, the semi-implicit plant in one substep; no
capture, wheels or target, no progress, no spool, no dw_b column, no after-run signals. It
measures what a lock-step run loop could save; it is not a run loop of the package.

Checked and printed: every recorded row's q, v, u_cmd, u_m and controller signals of every
case, lock-step against one by one (bit for bit, or the largest difference). Printed: us per
case-step, the median over ``--repeat`` rounds (one by one and lock-step in turn), and the
ratios to the bare loop.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import pinocchio as pin  # noqa: E402
from _timing import checkout  # noqa: E402
from numba import njit  # noqa: E402
from numba.typed import List  # noqa: E402

from ffsm_pin.control import kernels  # noqa: E402
from ffsm_pin.control.interface import Measurement  # noqa: E402
from ffsm_pin.control.period import PeriodOutputs, period_of  # noqa: E402
from ffsm_pin.errors import SimulationError  # noqa: E402
from ffsm_pin.scenario.devices import NOISE_KEYS  # noqa: E402
from ffsm_pin.sim.plant import Plant, _project_base  # noqa: E402  (private: see lockstep)
from ffsm_pin.sim.sensors import BLOCK  # noqa: E402

RATE_LIMIT = 1e4  # [rad/s], as the run loop's
PLANAR_RATES = [0, 1, 5]  # (dx/dt, dy/dt, attitude rate) of the frame's 6-vector
STATE_KEYS = ("q", "v", "u_cmd", "u_m")  # the recorded columns compared (and the signals)


@njit(cache=True)
def periods(boxes, rows, k, dt, t, q_b, q_m, w, z_e, z_e_dot, M, h, active, status, idx, value,
            u, damp, recorded):  # fmt: skip
    """The compiled periods of the active cases of a batch, one call: case b's measurement is
    row b of the arrays (its ``q_b`` the number ``q_b[b]``), its torque written to ``u[b]``,
    its damping to ``damp[b]``, ``(status, idx, value)`` to those arrays and its signals'
    row (``rows[b]``) to ``recorded[b, k]``."""
    for b in range(len(boxes)):
        if not active[b]:
            continue
        box = boxes[b]
        meas = (t, q_b[b], q_m[b], w[b], z_e[b], z_e_dot[b], M, h)
        status[b], idx[b], value[b] = period_of(box, dt, meas, None)
        out = PeriodOutputs(*box.out)
        for j in range(u.shape[1]):
            u[b, j] = out.u_m[j]
        damp[b] = out.damping[0]
        row = rows[b]
        for j in range(row.size):
            recorded[b, k, j] = row[j]


def cases(scenario: str, batch: int, duration: float) -> list:
    """The scenarios of the first ``batch`` lu-jia cases of ``scenario`` in
    compare-controllers."""
    from bench_step_parts import campaign_cases

    from ffsm_pin.scenario.file import scenario_from_toml

    found = campaign_cases(scenario, "lu-jia", batch)
    return [
        dataclasses.replace(scenario_from_toml(c.scenario_toml), duration=duration) for c in found
    ]


def prepared(scenarios) -> list:
    from ffsm_pin.sim.run import prepare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [prepare(sc) for sc in scenarios]


def one_by_one(scenarios) -> tuple[float, float, int, list]:
    """(loop seconds less after-run signals, after-run seconds, steps, results) of the cases
    run by the package, one after the other."""
    import ffsm_pin.sim.loop as loop
    from ffsm_pin.sweep.engine import CASE_MEMORY_BYTES

    after = [0.0]
    original = loop.system_signals

    def timed(*args, **kwargs):
        t0 = time.perf_counter()
        out = original(*args, **kwargs)
        after[0] += time.perf_counter() - t0
        return out

    loop.system_signals = timed
    try:
        results, wall = [], 0.0
        for setup in prepared(scenarios):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = loop.simulate(setup, memory_bytes=CASE_MEMORY_BYTES)  # (a worker's)
            results.append(res)
            wall += res.wall_time_s
    finally:
        loop.system_signals = original
    steps = sum(r.steps for r in results)
    return wall - after[0], after[0], steps, results


class PlanarMeasurement:
    """The exact measurement of a planar batch, as :class:`ffsm_pin.sim.measurement.Sensor`
    makes it case by case: Pinocchio's kinematics and the end-effector angle case by case,
    the base angle (continued from the last), q_m and w for the batch at once."""

    rows = np.array([0, 1, 5])  # h_g's rows the plant keeps (its root table's, private)

    def __init__(self, setups):
        self.setups, B = setups, len(setups)
        self.models = [s.robot.model for s in setups]
        self.datas = [m.createData() for m in self.models]
        self.fid = setups[0].robot.ee_frame_id
        self.xy, self.rates, self.angle = np.empty((B, 2)), np.empty((B, 3)), np.empty(B)
        self.prev = None

    def __call__(self, Q, V, live):
        # (math.atan2 as the sensor's: np.arctan2 gives other bits for some angles)
        q_b = np.array([math.atan2(sin, cos) for cos, sin in Q[:, 2:4]])
        if self.prev is not None:  # continuous attitude
            q_b += 2 * math.pi * np.round((self.prev - q_b) / (2 * math.pi))
        self.prev = q_b
        q_m, w, fid = Q[:, 4:], V[:, 2:], self.fid
        for b in live:
            model, data = self.models[b], self.datas[b]
            pin.forwardKinematics(model, data, Q[b], V[b])
            self.xy[b] = pin.updateFramePlacement(model, data, fid).translation[:2]
            twist = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED).vector
            self.rates[b] = twist[PLANAR_RATES]
            self.angle[b] = self.setups[b].model.ee_angle(q_b[b], q_m[b])
        return q_b, q_m, w, np.column_stack((self.xy, self.angle)), self.rates


class SpatialMeasurement:
    """The exact measurement of a free-flyer batch, as :class:`~ffsm_pin.sim.measurement.
    Sensor` makes it: Pinocchio's kinematics and the sensor's compiled MRP arithmetic case by
    case."""

    rows = np.arange(6)  # h_g's rows the plant keeps

    def __init__(self, setups):
        # (a private module: the sensor's own MRP arithmetic, so the bits are the sensor's)
        from ffsm_pin.sim._sensor_kernels import spatial_measurement

        B, n = len(setups), setups[0].model.n_joints
        self.models = [s.robot.model for s in setups]
        self.datas = [m.createData() for m in self.models]
        self.fid = setups[0].robot.ee_frame_id
        self.kernel = spatial_measurement
        self.q_b, self.w = np.empty((B, 3)), np.empty((B, n + 3))
        self.z_e, self.z_e_dot = np.empty((B, 6)), np.empty((B, 6))

    def __call__(self, Q, V, live):
        fid = self.fid
        for b in live:
            model, data = self.models[b], self.datas[b]
            pin.forwardKinematics(model, data, Q[b], V[b])
            oMf = pin.updateFramePlacement(model, data, fid)
            twist = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            q_b, _, z_e, z_e_dot, w = self.kernel(Q[b], V[b], oMf.homogeneous, twist.vector)
            self.q_b[b], self.z_e[b], self.z_e_dot[b], self.w[b] = q_b, z_e, z_e_dot, w
        return self.q_b, Q[:, 7:], self.w, self.z_e, self.z_e_dot


#: The batch's measurement and root rows per root joint (what differs between the geometries).
MEASUREMENTS = {"planar": PlanarMeasurement, "free-flyer": SpatialMeasurement}


def lockstep(setups) -> tuple[float, int, dict]:
    """Run the prepared ``setups`` (one robot, the cases above) in lock-step: (seconds,
    case-steps, recorded arrays ``q``, ``v``, ``u_cmd``, ``u_m`` and the controllers' signal
    rows ``signals`` (B, rows, ...), and ``rows`` (B,) recorded per case)."""
    B = len(setups)
    s0 = setups[0]
    sc = s0.scenario
    dt, substeps, n_steps = sc.dt, sc.substeps, int(round(sc.duration / sc.dt))
    n = s0.model.n_joints
    for s in setups:
        law = s.controller.law
        if law.auxiliary is not None or law.physical is not None or not law.adaptive:
            raise SystemExit("the prototype takes adaptive lu-jia cases without aux, physical")
        if s.sensors is None or s.sensors.spec.delay or s.target is not None:
            raise SystemExit("the prototype takes noisy sensors without delay and no target")
        a = s.actuators
        if a is None or a.lagged or a.rate_limited or a.noisy:
            raise SystemExit("the prototype takes actuators with torque limits alone")
    measure = MEASUREMENTS[s0.robot.base](setups)
    momentum_rows = measure.rows
    plants = [Plant(s.robot, integrator=s.scenario.integrator) for s in setups]
    Q = np.array([s.q0 for s in setups])
    V = np.array([s.v0 for s in setups])
    for p, q, v in zip(plants, Q, V, strict=True):
        p.reset(q.copy(), v.copy())
        if p.integrator != "semi-implicit" or p.project_position or substeps != 1:
            raise SystemExit("the prototype steps the semi-implicit plant, one substep")
    nb, n_lin = plants[0].n_base, plants[0].n_linear  # base velocity size, its linear part
    models, pdatas = [p.model for p in plants], [p.data for p in plants]
    h0 = np.array([p.momentum0 for p in plants])
    tau, acc = np.zeros(V.shape), np.empty(V.shape)
    handles = [s.controller.law.period_handles() for s in setups]
    boxes, row_list = List([h.box for h in handles]), List([h.row for h in handles])
    M_none, h_none = handles[0].M, handles[0].h
    laws = [s.controller.law for s in setups]
    limits = np.array([s.actuators.limit for s in setups])
    # the sensors' noise: each case's stream, BLOCK measurements drawn at once
    sizes = [s0.sensors.sigma[k].size for k in NOISE_KEYS]
    bounds = np.cumsum([0, *sizes])
    sl = {k: slice(bounds[i], bounds[i + 1]) for i, k in enumerate(NOISE_KEYS)}
    sigma = [np.concatenate([s.sensors.sigma[k] for k in NOISE_KEYS]) for s in setups]
    noise = np.empty((B, BLOCK, bounds[-1]))
    row = BLOCK
    rows = n_steps + 1
    rec = {
        "q": np.full((B, rows, Q.shape[1]), np.nan), "v": np.full((B, rows, V.shape[1]), np.nan),
        "u_cmd": np.full((B, rows, n), np.nan), "u_m": np.full((B, rows, n), np.nan),
    }  # fmt: skip
    signal_rows = np.full((B, rows, handles[0].row.size), np.nan)
    booked = np.zeros(B, dtype=np.bool_)  # the controller's damped_since is not None
    active = np.ones(B, dtype=np.bool_)
    done = np.full(B, rows)  # rows recorded per case
    steps = np.full(B, n_steps)  # per case, as its run reports them
    status = np.zeros(B, dtype=np.int64)
    idx = np.zeros(B, dtype=np.int64)
    value = np.zeros(B)
    U = np.zeros((B, n))
    damp = np.zeros(B)
    wall0 = time.perf_counter()
    for k in range(n_steps + 1):
        t = k * dt
        live = np.flatnonzero(active)
        if live.size == 0:
            break
        q_b, q_m, w, z_e, z_e_dot = measure(Q, V, live)
        # what the controllers see: each case's noise of this measurement
        if row == BLOCK:
            for b in range(B):
                noise[b] = setups[b].sensors.rng.standard_normal((BLOCK, bounds[-1])) * sigma[b]
            row = 0
        z = noise[:, row]
        row += 1
        base = z[:, sl["base_attitude"]]
        seen_q_b = q_b + (base[:, 0] if q_b.ndim == 1 else base)
        seen_q_m = q_m + z[:, sl["joints"]]
        seen_w = w + np.concatenate((z[:, sl["base_rate"]], z[:, sl["joint_rates"]]), axis=1)
        seen_z_e = z_e + z[:, sl["ee_pose"]]
        seen_z_e_dot = z_e_dot + z[:, sl["ee_velocity"]]
        periods(boxes, row_list, k, dt, t, seen_q_b, seen_q_m, seen_w, seen_z_e, seen_z_e_dot,
                M_none, h_none, active, status, idx, value, U, damp, signal_rows)  # fmt: skip
        # the bookkeeping of a period that is not plain (a stop raises), case by case
        book = active & ((status != kernels.STATUS_OK) | (damp != 0.0) | booked)
        for b in np.flatnonzero(book):
            meas = Measurement(t, seen_q_b[b], seen_q_m[b], seen_w[b], seen_z_e[b],
                               seen_z_e_dot[b], None, None)  # fmt: skip
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    laws[b].settle(meas, int(status[b]), int(idx[b]), float(value[b]))
            except SimulationError:
                active[b] = False
                done[b] = steps[b] = k
            booked[b] = laws[b].damped_since is not None
        live = np.flatnonzero(active)
        u_m = np.minimum(np.maximum(U, -limits), limits)  # the actuators (limits alone)
        u_m = np.minimum(np.maximum(u_m + 0.0, -limits), limits)
        rec["q"][:, k], rec["v"][:, k], rec["u_cmd"][:, k], rec["u_m"][:, k] = Q, V, U, u_m
        if k == n_steps:
            break
        # the plant, semi-implicit Euler as Plant.step: ABA and the configuration case by case,
        # the velocity update at once, the momentum projection by the plant's own kernel (a
        # private one, read here so that lock-step stays bit for bit)
        tau[:, nb:] = u_m
        for b in live:
            acc[b] = pin.aba(models[b], pdatas[b], Q[b], V[b], tau[b])
        V = V + dt * acc
        dq = dt * V
        Q = Q.copy()
        for b in live:
            model, data = models[b], pdatas[b]
            Q[b] = pin.integrate(model, Q[b], dq[b])
            _project_base(pin.computeCentroidalMap(model, data, Q[b]), V[b], h0[b], momentum_rows)
        bad = ~(np.isfinite(Q).all(axis=1) & np.isfinite(V).all(axis=1))
        bad |= np.abs(V[:, n_lin:]).max(axis=1) > RATE_LIMIT
        for b in np.flatnonzero(bad & active):
            active[b] = False
            done[b], steps[b] = k + 1, k
    wall = time.perf_counter() - wall0
    return wall, max(int(steps.sum()), 1), {**rec, "signals": signal_rows, "rows": done}


def compare(results, rec, layout) -> str:
    """Lock-step against one by one, row by row (q, v, u_cmd, u_m and the controller's signals
    of its ``layout``): how many cases are equal bit for bit, the largest difference of the
    others."""
    from ffsm_pin.control.interface import recorded_name

    equal, worst = 0, 0.0
    for b, res in enumerate(results):
        rows = min(int(rec["rows"][b]), len(res["t"]))
        pairs = [(np.asarray(res[key])[:rows], rec[key][b, :rows]) for key in STATE_KEYS]
        for key, (start, stop, shape) in layout.slots.items():
            lock = rec["signals"][b, :rows, start:stop].reshape(rows, *shape)
            pairs.append((np.asarray(res[recorded_name(key)])[:rows], lock))
        same = True
        for one, lock in pairs:
            if not np.array_equal(one, lock):
                same = False
                worst = max(worst, float(np.nanmax(np.abs(one - lock))))
        equal += same
    text = f"{equal} of {len(results)} cases bit for bit equal"
    return text if equal == len(results) else f"{text}; largest difference {worst:.3g}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--scenario", default="case1", choices=["case1", "planar5", "spatial-realistic"]
    )
    ap.add_argument("--batch", type=int, default=8, help="cases (default 8)")
    ap.add_argument("--duration", type=float, default=5.0, help="simulated s per case")
    ap.add_argument("--repeat", type=int, default=3, help="rounds (default 3)")
    a = ap.parse_args()
    from bench_run import bare_loop

    scenarios = cases(a.scenario, a.batch, a.duration)
    lockstep(prepared([dataclasses.replace(sc, duration=0.05) for sc in scenarios]))  # compile
    one, lock, after, bare = [], [], [], []
    check = ""
    for _ in range(a.repeat):
        wall, after_s, steps, results = one_by_one(scenarios)
        one.append(wall / steps)
        after.append(after_s / steps)
        wall, steps_l, rec = lockstep(prepared(scenarios))
        lock.append(wall / steps_l)
        check = compare(results, rec, prepared(scenarios[:1])[0].controller.signal_layout)
        b = bare_loop(a.scenario, a.duration)
        bare.append(b["python_wall_time_s"] / b["steps"])
    py = statistics.median(bare) * 1e6
    o, k = statistics.median(one) * 1e6, statistics.median(lock) * 1e6
    print(f"ffsm-pin lock-step prototype: {checkout(ROOT)}, load {os.getloadavg()[0]:.1f}")
    print(f"{a.batch} {a.scenario} lu-jia cases of compare-controllers, {a.duration} s each, "
          f"{a.repeat} rounds; us per case-step, median")  # fmt: skip
    print(f"  one by one (loop less after-run)  {o:7.2f}  {o / py:5.2f}x the bare Python loop")
    print(f"  after-run signals (one by one)    {statistics.median(after) * 1e6:7.2f}")
    print(f"  lock-step prototype               {k:7.2f}  {k / py:5.2f}x the bare Python loop")
    print(f"  lock-step / one by one            {k / o:7.3f}")
    print(f"  bare Python loop                  {py:7.2f}")
    print(f"  rows: {check}")


if __name__ == "__main__":
    main()
