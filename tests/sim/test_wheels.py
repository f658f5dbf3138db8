"""Reaction wheels (ffsm_pin.sim.wheels, issue 40) and the plant's base-wrench hook.

* the pure-momentum wheels against the same robot with the wheels as Pinocchio bodies
  (revolute rotors): the same total momentum at the start, and trajectories that converge to
  it at first order in dt;
* L_total = L_robot + R_b A h kept to rounding (projection), and without the projection a
  drift that vanishes with dt (which it does not without the gyroscopic term);
* the plant's ``base_wrench``: none or zero leaves its results bit for bit; a torque changes
  the momentum by its impulse;
* limits and one-line refusals."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin import load_robot
from ffsm_pin.errors import ParameterError
from ffsm_pin.sim.plant import Plant
from ffsm_pin.sim.wheels import WheeledPlant, Wheels

SKEWED = np.array([[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]])
ROTOR_MASS, ROTOR_TRANSVERSE = 1.5, 0.03  # [kg], [kg m^2]


@pytest.fixture(scope="module")
def spatial9():
    return load_robot("spatial9.urdf", base="free-flyer")


@pytest.fixture(scope="module")
def wheels():
    # four wheels, the fourth skewed (normalised by Wheels)
    return Wheels(SKEWED, [0.05, 0.06, 0.04, 0.05], 1.0, 20.0)


def _models(robot, wheels, seed=0):
    """(exact, reduced): the robot with the wheels as revolute rotor bodies on the bus, and the
    robot whose bus carries the rotors' mass and transverse inertia only (the axial moment is
    the wheels' h)."""
    spots = np.random.default_rng(seed).normal(size=(3, wheels.n)) * 0.2
    exact, reduced = pin.Model(robot.model), pin.Model(robot.model)
    for i in range(wheels.n):
        a = wheels.axes[:, i]
        transverse = ROTOR_TRANSVERSE * (np.eye(3) - np.outer(a, a))
        place = pin.SE3(np.eye(3), spots[:, i])
        joint = exact.addJoint(1, pin.JointModelRevoluteUnaligned(a), place, f"wheel{i}")
        rotor = pin.Inertia(
            ROTOR_MASS, np.zeros(3), wheels.inertia[i] * np.outer(a, a) + transverse
        )
        exact.appendBodyToJoint(joint, rotor, pin.SE3.Identity())
        reduced.appendBodyToJoint(1, pin.Inertia(ROTOR_MASS, np.zeros(3), transverse), place)
    return exact, reduced


def _state(robot, seed=0):
    rng = np.random.default_rng(seed)
    q = robot.neutral()
    q[3:7] = pin.Quaternion(pin.exp3(rng.normal(size=3))).coeffs()
    q[7:] = rng.uniform(-1.0, 1.0, robot.n_joints)
    return q, rng.normal(size=robot.model.nv) * 0.2, rng.normal(size=4) * 0.5


def _run_reduced(plant, q, v, h, u, tau_w, dt, duration):
    plant.total0 = None
    for _ in range(round(duration / dt)):
        q, v, h, _, _ = plant.advance(q, v, h, u, tau_w, dt)
    return q, v, h


def test_pure_momentum_wheels_converge_to_the_wheels_as_bodies(spatial9, wheels):
    exact, reduced = _models(spatial9, wheels)
    q, v, h = _state(spatial9)
    nv = spatial9.model.nv
    wp = WheeledPlant(reduced, wheels, integrator="rk4")
    # the same physical state: each rotor spins at h_i / J_s,i - a_i . w_b relative to the bus
    q_e = np.concatenate((q, np.zeros(wheels.n)))
    v_e = np.concatenate((v, wheels.spin_rates(h, v[3:6])))
    pe = Plant(exact, integrator="rk4")
    total = wp.total_momentum(q, v, h)
    assert np.abs(pe.momentum(q_e, v_e) - total).max() < 1e-13 * np.abs(total).max()
    u = np.linspace(-0.5, 0.5, spatial9.n_joints)
    tau_w = np.array([0.3, -0.2, 0.1, 0.25])  # below the limits: h exact in both
    errors = []
    for dt in (4e-3, 2e-3):
        q_r, v_r, h_r = _run_reduced(wp, q, v, h, u, tau_w, dt, 0.5)
        q_x, v_x = q_e, v_e
        pe.momentum0 = None
        for _ in range(round(0.5 / dt)):
            q_x, v_x, _ = pe.advance(q_x, v_x, np.concatenate((u, tau_w)), dt)
        h_x = wheels.inertia * (wheels.axes.T @ v_x[3:6] + v_x[nv:])
        np.testing.assert_allclose(h_r, h + 0.5 * tau_w, rtol=0, atol=1e-12)
        assert np.abs(h_x - h_r).max() < 1e-6
        assert np.abs(wp.total_momentum(q_r, v_r, h_r) - total).max() < 1e-12 * np.abs(total).max()
        errors.append(np.abs(v_x[:nv] - v_r).max())
        assert np.abs(q_x[: q.size] - q_r).max() < 2e-5  # measured 3e-6 (dt = 4 ms)
    assert 1.7 < errors[0] / errors[1] < 2.3  # first order: the bus torque held over a step


def test_drift_without_projection_vanishes_with_dt(spatial9, wheels, monkeypatch):
    """Without the projection the total momentum drifts by O(dt) only if the bus torque is
    right: dropping its gyroscopic part (w_b x A h) leaves a drift that dt does not shrink."""
    q, v, h = _state(spatial9, 1)
    u, tau_w = np.zeros(spatial9.n_joints), np.array([0.3, -0.2, 0.1, 0.25])

    def drifts():
        out = []
        for dt in (4e-3, 2e-3):
            wp = WheeledPlant(spatial9, wheels, integrator="rk4", project_momentum=False)
            total = wp.total_momentum(q, v, h)
            q_r, v_r, h_r = _run_reduced(wp, q, v, h, u, tau_w, dt, 0.5)
            out.append(np.abs(wp.total_momentum(q_r, v_r, h_r) - total).max())
        return out

    right = drifts()
    assert right[0] < 1e-3 and 1.7 < right[0] / right[1] < 2.3
    monkeypatch.setattr(Wheels, "bus_torque", lambda self, h, tau, w: -(self.axes @ tau))
    wrong = drifts()
    assert wrong[1] > 0.8 * wrong[0] and wrong[1] > 20 * right[1]


def test_planar_wheels_keep_the_total_Lz(paper_robot):
    wheels = Wheels("xyz", 0.02, 0.5, 5.0)
    wp = WheeledPlant(paper_robot, wheels)
    rng = np.random.default_rng(2)
    q, v = paper_robot.neutral(), rng.normal(size=paper_robot.model.nv) * 0.2
    h = np.array([0.3, -0.1, 0.4])
    total = wp.total_momentum(q, v, h)
    tau_w = np.array([0.0, 0.0, 0.2])
    q_r, v_r, h_r = _run_reduced(wp, q, v, h, np.zeros(paper_robot.n_joints), tau_w, 2e-3, 1.0)
    assert h_r[2] == pytest.approx(0.6, abs=1e-12)
    assert np.abs(wp.total_momentum(q_r, v_r, h_r) - total).max() < 1e-13 * np.abs(total).max()
    # the robot's own L_z gave what the wheel took
    dL = wp.plant.momentum(q_r, v_r)[2] - wp.plant.momentum(q, v)[2]
    assert dL == pytest.approx(-0.2, abs=1e-12 * np.abs(total).max())


def test_limits(wheels):
    rng = np.random.default_rng(4)
    dt = 0.1
    for _ in range(200):
        h = rng.uniform(-25.0, 25.0, wheels.n).clip(-20.0, 20.0)
        tau = rng.normal(size=wheels.n) * 3.0
        out = wheels.limit(h, tau, dt)
        assert (np.abs(out) <= wheels.max_torque + 1e-15).all()
        assert (np.abs(h + dt * out) <= wheels.max_momentum * (1 + 1e-15)).all()
        inside = (np.abs(tau) <= 1.0) & (np.abs(h + dt * tau) <= 20.0)
        np.testing.assert_array_equal(out[inside], tau[inside])
    np.testing.assert_allclose(np.linalg.norm(wheels.axes, axis=0), 1.0, rtol=1e-15)
    np.testing.assert_array_equal(Wheels("xyz", 0.1, 1.0, 1.0).axes, np.eye(3))
    w = Wheels.from_mapping({"inertia": 0.1})
    assert w.n == 3 and np.isinf(w.max_torque).all() and np.isinf(w.max_momentum).all()


@pytest.mark.parametrize(
    ("table", "words"),
    [
        ({"inertia": 0.0}, "inertia: every value must be > 0"),
        ({"inertia": [0.1, 0.0, 0.1]}, "inertia: every value must be > 0"),
        ({"inertia": [0.1, 0.1]}, "expected one number or 3"),
        ({"inertia": 0.1, "axes": [[1, 0], [0, 0], [0, 0]]}, r"wheel\(s\) \[1\] have a zero"),
        ({"inertia": 0.1, "axes": "xy"}, "'xyz' or a 3 x N"),
        ({"inertia": 0.1, "axes": [1, 0, 0]}, "3 x N matrix"),
        ({"inertia": 0.1, "max_torque": 0.0}, "max_torque: every value must be > 0"),
        ({"inertia": 0.1, "max_momentum": -1.0}, "max_momentum: every value must be > 0"),
        ({"inertia": 0.1, "max_torgue": 1.0}, "did you mean 'max_torque'"),
        ({"axes": "xyz"}, "'inertia'.*is missing"),
    ],
)
def test_bad_wheels_are_one_line(table, words):
    with pytest.raises(ParameterError, match=words) as err:
        Wheels.from_mapping(table)
    assert "\n" not in str(err.value)


# ---- the plant's base-wrench hook -----------------------------------------------------------


@pytest.mark.parametrize(
    ("urdf", "base"), [("ffsm_planar4.urdf", "planar"), ("spatial9.urdf", "free-flyer")]
)
@pytest.mark.parametrize("integrator", ["semi-implicit", "rk4"])
def test_no_or_zero_wrench_is_bit_for_bit_the_plant(urdf, base, integrator):
    robot = load_robot(urdf, base=base)
    rng = np.random.default_rng(5)
    q0, v0 = robot.neutral(), rng.normal(size=robot.model.nv) * 0.3
    u = rng.normal(size=robot.n_joints)
    n_base = 3 if base == "planar" else 6
    runs = []
    for mode in ("plain", "none", "zero", "after"):
        plant = Plant(robot, integrator=integrator)
        plant.reset(q0, v0)
        q, v = q0, v0
        if mode == "after":  # a wrench on another plant step must not stay in the next ones
            plant.step(q, v, u, 1e-3, base_wrench=np.ones(n_base))
        for _ in range(50):
            if mode == "plain":
                q, v, a = plant.advance(q, v, u, 2e-3, substeps=2)
            elif mode == "zero":
                q, v, a = plant.advance(q, v, u, 2e-3, 2, np.zeros(n_base))
            else:
                q, v, a = plant.advance(q, v, u, 2e-3, 2, None)
        runs.append((q, v, a))
    for other in runs[1:]:
        for x, y in zip(runs[0], other, strict=True):
            assert np.array_equal(x, y)


@pytest.mark.parametrize(
    ("urdf", "base"), [("ffsm_planar4.urdf", "planar"), ("spatial9.urdf", "free-flyer")]
)
def test_a_base_torque_changes_the_momentum_by_its_impulse(urdf, base):
    """Bus torque tau_b (body frame), no projection, RK4: L changes by the integral of
    R_b tau_b (trapezoid over the steps, O(dt^2)), P does not change."""
    robot = load_robot(urdf, base=base)
    wp = WheeledPlant(robot, Wheels("xyz", 0.1), integrator="rk4", project_momentum=False)
    plant = wp.plant
    rng = np.random.default_rng(6)
    q, v = robot.neutral(), rng.normal(size=robot.model.nv) * 0.3
    torque = np.array([0.2, -0.1, 0.3])
    wrench = wp._wrench(torque)
    plant.reset(q, v)
    h0 = plant.momentum(q, v)
    impulse, dt = np.zeros(3), 1e-3
    for _ in range(200):
        q1, v1, _ = plant.step(q, v, np.zeros(robot.n_joints), dt, base_wrench=wrench)
        impulse += 0.5 * dt * (wp.bus_rotation(q) + wp.bus_rotation(q1)) @ torque
        q, v = q1, v1
    change = plant.momentum(q, v) - h0
    expected = np.array([0, 0, impulse[2]]) if base == "planar" else np.r_[0, 0, 0, impulse]
    assert np.abs(change - expected).max() < 1e-6 * np.abs(expected).max()
