"""The momentum-exact plant (ffsm_pin.sim.plant): momentum conservation over long runs, what the
projection buys, and first-order convergence to an independent RK4 reference."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.errors import ParameterError
from ffsm_pin.model._state_planar import base_twist_to_local
from ffsm_pin.model.state import State as FloatingBaseState
from ffsm_pin.sim.plant import Plant

N_TERMS = 3  # sinusoids per joint torque


class SmoothTorque:
    """u_m(t): per joint a seeded sum of sinusoids, peak |u_j| between 5 and 20 N m."""

    def __init__(self, n_joints: int, seed: int):
        g = np.random.default_rng(seed)
        weights = g.uniform(0.5, 1.0, (n_joints, N_TERMS))
        peaks = g.uniform(5.0, 20.0, n_joints)
        self.amplitude = weights / weights.sum(axis=1, keepdims=True) * peaks[:, None]
        self.omega = g.uniform(0.5, 3.0, (n_joints, N_TERMS))  # [rad/s]
        self.phase = g.uniform(0.0, 2 * np.pi, (n_joints, N_TERMS))

    def __call__(self, t: float) -> np.ndarray:
        return (self.amplitude * np.sin(self.omega * t + self.phase)).sum(axis=1)


@pytest.fixture
def initial(paper_robot):
    """A moving initial state with non-zero linear and angular momentum."""
    q = paper_robot.configuration((0.3, -0.2, 0.18), [1.0, -1.0, 1.0, -1.0])
    v = np.array([0.1, 0.08, -0.02, 0.1, -0.05, 0.05, 0.02])
    return q, v


def run(plant, q, v, torque, dt, duration, every=None):
    """Integrate; return the final state and the max |momentum - momentum(0)| seen."""
    p0 = plant.momentum(q, v)
    steps = int(round(duration / dt))
    every = every or max(1, steps // 300)
    drift = np.zeros(3)
    for k in range(steps):
        q, v, _ = plant.step(q, v, torque(k * dt), dt)
        if k % every == 0 or k == steps - 1:
            drift = np.maximum(drift, np.abs(plant.momentum(q, v) - p0))
    return q, v, drift


@pytest.mark.parametrize("dt", [1e-3, 1e-2])
def test_momentum_conserved_over_30_s(paper_robot, initial, dt):
    q0, v0 = initial
    plant = Plant(paper_robot)
    plant.reset(q0, v0)
    p0 = plant.momentum(q0, v0)
    # momentum() is Pinocchio's centroidal momentum: cross-check with FloatingBaseState
    fbs = FloatingBaseState(paper_robot).update(q0, v0)
    np.testing.assert_allclose(p0, [*fbs.linear_momentum, fbs.angular_momentum], rtol=1e-14)
    assert np.abs(p0).min() > 1.0  # P_x, P_y and L all far from zero

    q, v, drift = run(plant, q0, v0, SmoothTorque(4, seed=5), dt, 30.0)
    # the arm really moved (not a trivially conserved rest state)
    assert np.abs(q[4:] - q0[4:]).max() > 0.5
    # projection: momentum restored to rounding at every step; rounding does not accumulate
    # because every step solves against the same momentum0 (observed ~3e-13 relative)
    assert np.all(drift <= 1e-10 * np.abs(p0).max())


def test_projection_matters(paper_robot, initial):
    """Plain semi-implicit Euler drifts in momentum by O(dt) (docs/model.md section 4)."""
    q0, v0 = initial
    plant = Plant(paper_robot, project_momentum=False)
    scale = np.abs(plant.momentum(q0, v0)).max()
    _, _, drift = run(plant, q0, v0, SmoothTorque(4, seed=5), 1e-3, 10.0)
    # a million times the projected plant's bound
    assert drift.max() > 1e-4 * scale


def test_projection_keeps_joint_rates(paper_robot, initial, rng):
    """project() changes the base twist only, and is the identity on a consistent state."""
    q0, v0 = initial
    plant = Plant(paper_robot)
    plant.reset(q0, v0)
    np.testing.assert_allclose(plant.project(q0, v0), v0, rtol=0, atol=1e-14)
    v = v0 + rng.normal(scale=0.1, size=v0.shape)
    v_new = plant.project(q0, v)
    np.testing.assert_array_equal(v_new[3:], v[3:])
    np.testing.assert_allclose(plant.momentum(q0, v_new), plant.momentum(q0, v0), atol=1e-13)


# ----------------------------------------------------------------------------- RK4 reference
def rk4_reference(robot, q0, v0, torque, duration, dt, hold=None):
    """Classical RK4 on Euclidean coordinates x = (x, y, theta, q_m, vx_w, vy_w, w_b, w_m) with
    the base linear velocity in the inertial frame. Accelerations from Pinocchio's ABA: with
    v_w = R(theta) v_local, d/dt v_w = R (dv_local/dt + w_b J v_local).

    ``hold`` [s] (a multiple of dt): the torque is ``torque`` sampled every ``hold`` and held,
    as the plant sees a controller's output; every stage of a step uses the held value."""
    model = robot.model
    data = model.createData()
    nq = robot.n_joints + 3
    tau = np.zeros(model.nv)

    def u_at(t, t_step):
        return torque(t) if hold is None else torque(math.floor(t_step / hold + 1e-9) * hold)

    def f(t, x, t_step):
        theta = x[2]
        c, s = math.cos(theta), math.sin(theta)
        q = np.concatenate(([x[0], x[1], c, s], x[3:nq]))
        v = x[nq:].copy()
        v[:3] = base_twist_to_local(q, x[nq : nq + 3])
        tau[3:] = u_at(t, t_step)
        a = pin.aba(model, data, q, v, tau)
        a_lin = a[:2] + v[2] * np.array([-v[1], v[0]])
        acc = a.copy()
        acc[0], acc[1] = c * a_lin[0] - s * a_lin[1], s * a_lin[0] + c * a_lin[1]
        return np.concatenate((x[nq:], acc))

    twist = FloatingBaseState(robot).update(q0, v0).base_twist_world
    x = np.concatenate((q0[:2], [math.atan2(q0[3], q0[2])], q0[4:], twist, v0[3:]))
    for k in range(int(round(duration / dt))):
        t = k * dt
        k1 = f(t, x, t)
        k2 = f(t + dt / 2, x + dt / 2 * k1, t)
        k3 = f(t + dt / 2, x + dt / 2 * k2, t)
        k4 = f(t + dt, x + dt * k3, t)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x[:nq]  # (x, y, theta, q_m)


def test_first_order_convergence_to_rk4(paper_robot, initial):
    q0, v0 = initial
    torque = SmoothTorque(4, seed=11)
    # RK4 at 1e-4: global error ~ (1e-4)^4 * C, observed ~1e-12 when compared with dt = 2e-4,
    # ten orders below the plant errors measured here (~1e-2)
    ref = rk4_reference(paper_robot, q0, v0, torque, 1.0, 1e-4)
    errors = []
    for dt in (4e-3, 2e-3, 1e-3):
        q, _, _ = run(Plant(paper_robot), q0, v0, torque, dt, 1.0, every=10**9)
        pose = np.concatenate((q[:2], [math.atan2(q[3], q[2])], q[4:]))
        diff = pose - ref
        diff[2] = math.remainder(diff[2], 2 * math.pi)
        errors.append(np.abs(diff).max())
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    # first order: halving dt halves the error (2), with room for the O(dt^2) remainder
    assert all(1.6 <= r <= 2.5 for r in ratios), (errors, ratios)
    assert errors[-1] < 0.05  # and the error itself is small


# ----------------------------------------------------------- accuracy options (rk4, substeps)
def held(torque, period):
    """torque(t) sampled every ``period`` [s] and held (zero-order hold)."""
    return lambda t: torque(math.floor(t / period + 1e-9) * period)


def pose_error(robot, q, ref):
    pose = np.concatenate((q[:2], [math.atan2(q[3], q[2])], q[4:]))
    diff = pose - ref
    diff[2] = math.remainder(diff[2], 2 * math.pi)
    return np.abs(diff).max()


def test_rk4_fourth_order_to_rk4_reference(paper_robot, initial):
    """The Lie-group RK4 (Runge-Kutta-Munthe-Kaas) against the Euclidean RK4 reference: with
    the torque held every 20 ms, halving dt divides the error by ~16; momentum stays exact."""
    q0, v0 = initial
    period = 2e-2
    torque = held(SmoothTorque(4, seed=11), period)
    # reference at period / 40 = 5e-4: error ~ (5e-4 / 5e-3)^4 = 1e-4 of the smallest below
    ref = rk4_reference(paper_robot, q0, v0, torque, 1.0, period / 40, hold=period)
    scale = np.abs(Plant(paper_robot).momentum(q0, v0)).max()
    errors = []
    for dt in (period, period / 2, period / 4):
        q, _, drift = run(Plant(paper_robot, integrator="rk4"), q0, v0, torque, dt, 1.0)
        assert np.all(drift <= 1e-10 * scale)
        errors.append(pose_error(paper_robot, q, ref))
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(13.0 <= r <= 19.0 for r in ratios), (errors, ratios)


@pytest.mark.parametrize("integrator", ["semi-implicit", "rk4"])
def test_momentum_drift_large_torques(paper_robot, initial, integrator):
    """10 s of torques of 50-200 N m peak per joint at dt = 1 ms: drift <= 1e-9 relative."""
    q0, v0 = initial
    torque = SmoothTorque(4, seed=3)
    torque.amplitude *= 10.0
    plant = Plant(paper_robot, integrator=integrator)
    q, v, drift = run(plant, q0, v0, torque, 1e-3, 10.0)
    assert np.abs(v[3:]).max() > 1.0  # the arm is really driven
    assert np.all(drift <= 1e-9 * np.abs(plant.momentum(q0, v0)).max()), drift


def test_advance_is_repeated_steps(paper_robot, initial):
    """advance(dt, N) is N steps of dt / N with the torque held, and reports the first a."""
    q0, v0 = initial
    u = np.array([20.0, -10.0, 5.0, -2.5])
    for integrator in ("semi-implicit", "rk4"):
        plant = Plant(paper_robot, integrator=integrator)
        plant.reset(q0, v0)
        q, v, a = plant.advance(q0, v0, u, 1e-2, 4)
        first = plant.step(q0, v0, u, 2.5e-3)
        q1, v1 = first.q, first.v
        for _ in range(3):
            q1, v1, _ = plant.step(q1, v1, u, 2.5e-3)
        np.testing.assert_array_equal(q, q1)
        np.testing.assert_array_equal(v, v1)
        np.testing.assert_array_equal(a, plant.acceleration(q0, v0, u))
        one = plant.advance(q0, v0, u, 1e-2)  # substeps = 1 is step()
        np.testing.assert_array_equal(one.q, plant.step(q0, v0, u, 1e-2).q)


def test_substeps_converge_first_order(paper_robot, initial):
    """Semi-implicit with substeps N under a torque held every 4 ms: the error to the RK4
    reference falls ~N times (the substeps really refine the plant, not the controller)."""
    q0, v0 = initial
    period = 4e-3
    torque = held(SmoothTorque(4, seed=11), period)
    ref = rk4_reference(paper_robot, q0, v0, torque, 1.0, period / 8, hold=period)
    errors = []
    for n in (1, 2, 4):
        plant = Plant(paper_robot)
        plant.reset(q0, v0)
        q, v = q0, v0
        for k in range(int(round(1.0 / period))):
            q, v, _ = plant.advance(q, v, torque(k * period), period, n)
        errors.append(pose_error(paper_robot, q, ref))
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(1.6 <= r <= 2.5 for r in ratios), (errors, ratios)


def test_bad_integrator_and_substeps(paper_robot, initial):
    with pytest.raises(ParameterError, match="valid choices: 'semi-implicit', 'rk4'"):
        Plant(paper_robot, integrator="RK4")
    with pytest.raises(ParameterError, match="substeps must be >= 1"):
        Plant(paper_robot).advance(*initial, np.zeros(4), 1e-3, 0)


def _two_body(root: str) -> pin.Model:
    """A base (planar or free-flyer root, an asymmetric box) and one revolute link."""
    model = pin.Model()
    joint = pin.JointModelPlanar() if root == "planar" else pin.JointModelFreeFlyer()
    base = model.addJoint(0, joint, pin.SE3.Identity(), "base")
    model.appendBodyToJoint(base, pin.Inertia.FromBox(3.0, 1.0, 2.0, 0.5), pin.SE3.Identity())
    arm = model.addJoint(base, pin.JointModelRZ(), pin.SE3(np.eye(3), np.ones(3)), "arm")
    model.appendBodyToJoint(arm, pin.Inertia.FromBox(1.0, 1.0, 0.1, 0.1), pin.SE3.Identity())
    return model


@pytest.mark.parametrize("root", ["planar", "free-flyer"])
def test_state_status_is_the_three_numpy_checks(root, rng):
    """Plant.state_status (one compiled pass) against what the loop checked with numpy: any
    non-finite entry of q or v, then any angular rate (v after the linear base entries)
    beyond the limit; the linear base velocity does not count."""
    from ffsm_pin.sim.plant import STATE_BLOW_UP, STATE_NONFINITE, STATE_OK

    model = _two_body(root)
    plant = Plant(model)

    def numpy_checks(q, v):
        if not (np.isfinite(q).all() and np.isfinite(v).all()):
            return STATE_NONFINITE
        return STATE_BLOW_UP if np.abs(v[plant.n_linear :]).max() > 1e4 else STATE_OK

    seen = set()
    for _ in range(400):
        q, v = (
            pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq)),
            rng.normal(size=model.nv),
        )
        kind = rng.integers(5)
        if kind == 1:
            q[rng.integers(model.nq)] = rng.choice([np.nan, np.inf, -np.inf])
        elif kind == 2:
            v[rng.integers(model.nv)] = rng.choice([np.nan, np.inf, -np.inf])
        elif kind == 3:  # a large entry anywhere in v, linear base entries included
            v[rng.integers(model.nv)] = rng.choice([-1, 1]) * rng.uniform(0.5e4, 2e4)
        elif kind == 4:
            v[rng.integers(plant.n_linear, model.nv)] = 1e4  # at the limit: not beyond it
        expected = numpy_checks(q, v)
        assert plant.state_status(q, v, 1e4) == expected
        seen.add(expected)
    assert seen == {STATE_OK, STATE_NONFINITE, STATE_BLOW_UP}


@pytest.mark.parametrize("root", ["planar", "free-flyer"])
def test_momentum_rows_are_momentum_row_by_row(root, rng):
    """The momentum a run computes after its loop (Plant.momentum_rows, on the recorded rows)
    is bitwise Plant.momentum of each row, split as split_momentum splits it."""
    model = _two_body(root)
    plant = Plant(model)
    lo, hi = -np.ones(model.nq), np.ones(model.nq)
    q_rows = np.array([pin.randomConfiguration(model, lo, hi) for _ in range(7)])
    v_rows = rng.normal(size=(7, model.nv))
    P, L = plant.momentum_rows(q_rows, v_rows)
    assert P.shape == (7, plant.n_linear) and L.shape == ((7,) if root == "planar" else (7, 3))
    for i in range(7):
        P_i, L_i = plant.split_momentum(plant.momentum(q_rows[i], v_rows[i]))
        assert np.array_equal(P[i], P_i) and np.array_equal(L[i], L_i)
    P0, L0 = plant.momentum_rows(q_rows[:0], v_rows[:0])  # no rows (a run stopped at once)
    assert P0.shape == (0, plant.n_linear) and L0.shape[0] == 0


@pytest.mark.parametrize("integrator", ["semi-implicit", "rk4"])
@pytest.mark.parametrize("root", ["planar", "free-flyer"])
def test_position_projection_keeps_the_com_on_its_line(root, integrator, rng):
    """With project_position the CoM (Pinocchio's, at every step) is on c(0) + P t / m to
    rounding, the root joint placed off the world's axes (the root's translation entries are
    in its parent frame); without it the integrator leaves it by more than 1e-11 m. The shift is
    a translation of the whole system: the momentum is kept, and the velocities and the rest of
    q are those of the run without it, to rounding."""
    model = _two_body(root)
    turn = (
        pin.rpy.rpyToMatrix(0.0, 0.0, 0.7)
        if root == "planar"
        else pin.rpy.rpyToMatrix(0.3, -0.5, 0.7)
    )
    model.jointPlacements[1] = pin.SE3(turn, np.array([0.2, -0.1, 0.4]))
    model.gravity.setZero()  # (free-floating: no external force)
    data = model.createData()
    q0 = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    v0 = rng.normal(size=model.nv)
    on = Plant(model, integrator=integrator, project_position=True)
    off = Plant(model, integrator=integrator)
    on.reset(q0, v0)
    off.reset(q0, v0)
    c0 = pin.centerOfMass(model, data, q0).copy()
    P0 = pin.computeCentroidalMomentum(model, data, q0, v0).linear.copy()
    m = pin.computeTotalMass(model)
    assert np.abs(P0).max() > 0.1  # (a line that moves)
    dt, n = 1e-2, 300
    q1, v1, q2, v2 = q0, v0, q0, v0
    departure = 0.0
    for k in range(1, n + 1):
        u = np.array([3.0 * np.sin(2.0 * k * dt)])
        q1, v1, _ = on.step(q1, v1, u, dt)
        q2, v2, _ = off.step(q2, v2, u, dt)
        line = c0 + (k * dt) * P0 / m
        assert np.abs(pin.centerOfMass(model, data, q1) - line).max() < 1e-13 * (1 + k * dt)
        departure = max(departure, np.abs(pin.centerOfMass(model, data, q2) - line).max())
    assert departure > 1e-11  # (measured: semi-implicit 1e-2 m, RK4 3e-10 and 1e-8 m)
    assert np.abs(on.momentum(q1, v1) - on.momentum0).max() < 1e-12
    n_lin = on.n_linear
    assert np.abs(v1 - v2).max() < 1e-9 and np.abs(q1[n_lin:] - q2[n_lin:]).max() < 1e-9
    # the translation of the root is the CoM's departure, in the root's parent frame
    shift = turn.T @ (pin.centerOfMass(model, data, q1) - pin.centerOfMass(model, data, q2))
    assert np.abs(q1[:n_lin] - q2[:n_lin] - shift[:n_lin]).max() < 1e-9
    assert on.with_robot(model).project_position and not off.with_robot(model).project_position
