"""The plant on a free-flyer root (ffsm_pin.sim.plant with JointModelFreeFlyer): 6 conserved
momenta kept exact by the projection, and the order of both integrators measured by halving dt
against an independent RK4 (quaternion as four numbers, renormalised) on Pinocchio's ABA.

The robots are random spatial chains (tests/sim/spatial_chain.py): arbitrary joint axes and
joint-origin rotations, CoMs off the axes, full inertia tensors."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spatial_chain import (
    held_torques,
    pinocchio_acceleration,
    pinocchio_model,
    plant_replay,
    pose_error,
    quaternion_rk4_replay,
    random_state,
    spatial_chain_urdf,
)

from ffsm_pin.errors import ParameterError
from ffsm_pin.sim.integrators import _chart_rate, chart_block, gauss_solve
from ffsm_pin.sim.plant import Plant

# Momentum: the projection solves A_g,base v_base = h0 - A_g,joints w_m against the same h0 at
# every step, so rounding does not accumulate; 1e-9 relative is the brief's bound (observed
# ~3e-15), and plain semi-implicit Euler misses it by orders of magnitude (test below).
DRIFT_TOL = 1e-9


def chain(n_joints: int, seed: int) -> pin.Model:
    return pinocchio_model(spatial_chain_urdf(n_joints, seed))


@pytest.fixture(scope="module")
def arm6():
    model = chain(6, 4)
    q0, v0 = random_state(model, np.random.default_rng(4), speed=0.5)
    return model, q0, v0


def test_root_and_momentum_rows(arm6):
    model, q0, v0 = arm6
    plant = Plant(model)
    assert plant.root == "JointModelFreeFlyer" and plant.n_base == 6
    h = plant.momentum(q0, v0)
    # P = m_total v_com (inertial frame), independent of the centroidal map
    data = model.createData()
    pin.centerOfMass(model, data, q0, v0)
    np.testing.assert_allclose(h[:3], data.mass[0] * data.vcom[0], rtol=1e-13, atol=1e-13)
    # L about the CoM, inertial frame: sum over bodies of (I_k w_k + m_k (c_k - c) x dc_k/dt)
    pin.forwardKinematics(model, data, q0, v0)
    L = np.zeros(3)
    for k in range(1, model.njoints):
        oMi, Y = data.oMi[k], model.inertias[k]
        v_world = oMi.act(data.v[k])  # spatial velocity about the inertial origin
        c_k = oMi.act(Y.lever)
        dc_k = v_world.linear + np.cross(v_world.angular, c_k)
        I_world = oMi.rotation @ Y.inertia @ oMi.rotation.T
        L += I_world @ v_world.angular + Y.mass * np.cross(c_k - data.com[0], dc_k)
    np.testing.assert_allclose(h[3:], L, rtol=1e-12, atol=1e-12)


def test_unknown_integrator_and_root():
    with pytest.raises(ParameterError, match="'semi-implicit', 'rk4'"):
        Plant(chain(4, 0), integrator="euler")
    fixed = pin.buildModelFromXML(spatial_chain_urdf(4, 0))  # no floating root
    with pytest.raises(ParameterError, match="JointModelFreeFlyer"):
        Plant(fixed)


@settings(max_examples=15, deadline=None)
@given(
    n_joints=st.integers(4, 7),
    seed=st.integers(0, 10_000),
    kick=st.floats(0.01, 1.0),
)
def test_projection_is_exact(n_joints, seed, kick):
    """project() restores all six momenta at a new configuration, keeps the joint rates, and is
    the identity on a state that already has them."""
    model = chain(n_joints, seed)
    g = np.random.default_rng(seed)
    q0, v0 = random_state(model, g)
    plant = Plant(model)
    plant.reset(q0, v0)
    np.testing.assert_allclose(plant.project(q0, v0), v0, rtol=0, atol=1e-12)
    q = pin.integrate(model, q0, kick * g.normal(size=model.nv))
    v = v0 + kick * g.normal(size=model.nv)
    v_new = plant.project(q, v)
    np.testing.assert_array_equal(v_new[6:], v[6:])
    h0 = plant.momentum0
    assert np.abs(plant.momentum(q, v_new) - h0).max() <= 1e-12 * np.abs(h0).max()


@pytest.mark.parametrize("integrator", ["semi-implicit", "rk4"])
def test_momentum_drift_with_large_torques(integrator):
    """2 s of torques up to 100 N m on 3-8 kg links (joint rates of tens of rad/s; at 200 N m
    the explicit step at 1 ms goes unstable, which says nothing about momentum)."""
    model = chain(7, 9)
    q0, v0 = random_state(model, np.random.default_rng(9))
    torques = held_torques(7, seed=9, duration=2.0, period=1e-3, peak=100.0)
    q, v, drift = plant_replay(Plant(model, integrator=integrator), q0, v0, torques, 1e-3, 1)
    assert np.abs(v[6:]).max() > 10.0  # violent indeed
    assert drift <= DRIFT_TOL, drift


def test_projection_matters(arm6):
    model, q0, v0 = arm6
    torques = held_torques(6, seed=1, duration=2.0, period=1e-3, peak=20.0)
    plant = Plant(model, project_momentum=False)
    _, _, drift = plant_replay(plant, q0, v0, torques, 1e-3, 1)
    assert drift > 1e3 * DRIFT_TOL


def naive_rk4_step(model, data, q, v, tau, dt):
    """RK4 with pin.integrate stages and a plain weighted sum of the stage velocities: the
    scheme that is NOT fourth order on the group (kept to show the order test can fail)."""
    a1 = pin.aba(model, data, q, v, tau).copy()
    v2 = v + dt / 2 * a1
    a2 = pin.aba(model, data, pin.integrate(model, q, dt / 2 * v), v2, tau).copy()
    v3 = v + dt / 2 * a2
    a3 = pin.aba(model, data, pin.integrate(model, q, dt / 2 * v2), v3, tau).copy()
    v4 = v + dt * a3
    a4 = pin.aba(model, data, pin.integrate(model, q, dt * v3), v4, tau).copy()
    q_new = pin.integrate(model, q, dt / 6 * (v + 2 * v2 + 2 * v3 + v4))
    return q_new, v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)


def _orders(errors):
    return [errors[i] / errors[i + 1] for i in range(len(errors) - 1)]


@pytest.fixture(scope="module")
def order_case(arm6):
    """1 s of torques held for 4 ms; reference: quaternion RK4 at 0.2 ms. Its own error is
    about |ref(0.4 ms) - ref(0.2 ms)| / 15, returned as ``ref_error``."""
    model, q0, v0 = arm6
    period = 4e-3
    torques = held_torques(6, seed=4, duration=1.0, period=period, peak=10.0)
    qacc = pinocchio_acceleration(model)
    q_ref, _ = quaternion_rk4_replay(qacc, q0, v0, torques, period, 20)
    q_coarse, _ = quaternion_rk4_replay(qacc, q0, v0, torques, period, 10)
    ref_error = max(max(pose_error(q_coarse, q_ref)) / 15.0, 1e-16)
    return model, q0, v0, torques, period, q_ref, ref_error


@pytest.mark.parametrize(
    "integrator, bounds",
    [("semi-implicit", (1.7, 2.3)), ("rk4", (13.0, 19.0))],
)
def test_order_by_halving_dt(order_case, integrator, bounds):
    """Errors of base position, base attitude and joints each fall by 2^order per halving."""
    model, q0, v0, torques, period, q_ref, ref_error = order_case
    errors = []
    for sub in (1, 2, 4):  # dt = 4, 2, 1 ms
        plant = Plant(model, integrator=integrator)
        q, _, drift = plant_replay(plant, q0, v0, torques, period, sub)
        assert drift <= DRIFT_TOL
        errors.append(pose_error(q, q_ref))
    errors = np.array(errors)  # rows: dt; columns: position, attitude, joints
    # every error must sit far above the reference's own (observed: 6e-15 vs >= 9e-14)
    assert errors.min() > 5 * ref_error, (errors.min(), ref_error)
    for col in errors.T:
        assert all(bounds[0] <= r <= bounds[1] for r in _orders(col)), (integrator, errors)


def test_naive_rk4_is_not_fourth_order(order_case):
    """The same test catches the naive group RK4: its attitude error falls ~4x per halving."""
    model, q0, v0, torques, period, q_ref, _ = order_case
    data = model.createData()
    tau = np.zeros(model.nv)
    errors = []
    for sub in (1, 2, 4):
        q, v = q0, v0
        for u in torques:
            tau[6:] = u
            for _ in range(sub):
                q, v = naive_rk4_step(model, data, q, v, tau, period / sub)
        errors.append(pose_error(q, q_ref))
    attitude = [e[1] for e in errors]
    assert max(_orders(attitude)) < 8.0, attitude  # second order: ~4


def test_chart_rate_block_and_gauss_solve(arm6, rng):
    """The RK4 chart rate solves only the root block of J = dIntegrate (the revolute joints'
    block is the identity): equal to the full solve; gauss_solve equals LAPACK."""
    model, q0, v0 = arm6
    assert chart_block(model) == 6
    for _ in range(5):
        theta = 0.3 * rng.normal(size=model.nv)
        full = np.linalg.solve(pin.dIntegrate(model, q0, theta, pin.ArgumentPosition.ARG1), v0)
        np.testing.assert_allclose(_chart_rate(model, q0, theta, v0, 6), full, atol=1e-14)
        A, b = rng.normal(size=(6, 6)), rng.normal(size=6)
        x = np.zeros(6)
        gauss_solve(A.copy(), b.copy(), x)
        np.testing.assert_allclose(A @ x, b, atol=1e-12)
    nan = np.zeros(6)
    gauss_solve(np.full((6, 6), np.nan), np.ones(6), nan)  # no exception: run.py sees NaN
    assert np.isnan(nan).all()
