"""SpatialState (the Pinocchio side of the spatial model) against docs/spatial.md sections 1-5:
forward dynamics (ABA), the centroidal map, finite differences of the end-effector pose and of
the reduced inertia, momentum conservation along an integrated trajectory."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ffsm_pin.attitude import mrp
from ffsm_pin.model.state import State as SpatialState

PROPERTY = settings(derandomize=True, max_examples=12, deadline=None)
SEEDS = st.integers(0, 10_000)
N_LINKS = st.integers(2, 8)
FD_TOL = 1e-8  # 5-point stencil at h = 1e-3: truncation h^4 ~ 1e-12, rounding 1e-16/h ~ 1e-13


def derivative(f, h=1e-3):
    return (8 * (f(h) - f(-h)) - (f(2 * h) - f(-2 * h))) / (12 * h)


def rel(a, b, floor=1.0):
    return float(np.abs(np.asarray(a) - b).max() / max(np.abs(b).max(), floor))


@PROPERTY
@given(seed=SEEDS, n=N_LINKS)
def test_reduced_dynamics_match_aba(spatial_chain, spatial_state, seed, n):
    """M dw/dt + h = (0_3, u_m) with dw/dt from Pinocchio's ABA (Eq. 8)."""
    robot = spatial_chain(n, seed % 3)
    rng = np.random.default_rng(seed)
    q, v = spatial_state(robot, rng)
    s = SpatialState(robot).update(q, v)
    u = rng.normal(scale=10.0, size=n)
    a = pin.aba(robot.model, robot.model.createData(), q, v, np.concatenate((np.zeros(6), u)))
    w_dot = s.acceleration_to_w_dot(a)
    scale = max(np.abs(s.M).max() * np.abs(w_dot).max(), np.abs(u).max())
    assert rel(s.M @ w_dot + s.h, np.concatenate((np.zeros(3), u))) < 1e-12 * scale
    assert rel(s.M, s.M.T) < 1e-13
    assert np.linalg.eigvalsh(s.M).min() > 0


@PROPERTY
@given(seed=SEEDS, n=N_LINKS)
def test_momentum_rows(spatial_chain, spatial_state, seed, n):
    """H (centroidal map, ccrba) = first rows of M (Schur complement of CRBA), A_0 = H w."""
    robot = spatial_chain(n, seed % 3)
    q, v = spatial_state(robot, np.random.default_rng(seed))
    s = SpatialState(robot).update(q, v)
    assert rel(np.hstack((s.H_bb, s.H_bm)), s.M[:3]) < 1e-12
    assert rel(s.H_bb @ s.w[:3] + s.H_bm @ s.w[3:], s.angular_momentum) < 1e-12
    # the full RNEA velocity terms and the inertial base twist (same names as the planar state)
    data = robot.model.createData()
    assert (
        rel(s.nonlinear_effects, pin.rnea(robot.model, data, q, v, np.zeros(robot.model.nv)))
        < 1e-12
    )
    R0 = pin.Quaternion(q[3:7]).toRotationMatrix()
    assert rel(s.base_twist_world, np.concatenate((R0 @ v[:3], R0 @ v[3:6]))) < 1e-14
    # v_0 from the momentum equals the CoM Jacobian times v
    Jc = pin.jacobianCenterOfMass(robot.model, robot.model.createData(), q)
    assert rel(s.com_velocity, Jc @ v) < 1e-12


def _trajectory_states(robot, q, v, ts):
    out = []
    for t in ts:
        out.append(SpatialState(robot).update(pin.integrate(robot.model, q, v * t), v))
    return out


@pytest.mark.parametrize("n", [2, 5, 7])
def test_h_base_rows_and_M_bb_rate(spatial_chain, spatial_state, rng, n):
    """h_b = (dM/dt w)_b (docs/spatial.md section 4) and M_bb_dot, by central differences of M
    along q(t) = integrate(q, v t) (with constant Pinocchio v, w_b = R_0 w_B is constant)."""
    robot = spatial_chain(n)
    q, v = spatial_state(robot, rng)
    s = SpatialState(robot).update(q, v)
    M_dot = derivative(
        lambda t: SpatialState(robot).update(pin.integrate(robot.model, q, v * t), v).M
    )
    assert rel(M_dot[:3] @ s.w, s.h[:3]) < FD_TOL
    assert rel(M_dot[:3, :3], s.M_bb_dot) < FD_TOL


@pytest.mark.parametrize("n", [2, 4, 7])
def test_jacobians_against_finite_differences(spatial_chain, spatial_state, rng, n):
    """J_b w_b + J_m w_m = d/dt (p_e - p_com, q_e) (Eq. 3), L_b w_b = dq_b/dt (Eq. 1)."""
    robot = spatial_chain(n)
    q, v = spatial_state(robot, rng)
    s = SpatialState(robot).update(q, v)

    def pose(t):
        st_ = SpatialState(robot).update(pin.integrate(robot.model, q, v * t), v)
        return np.concatenate(
            (st_.ee_pose[:3] - st_.com_position, st_.ee_pose[3:], st_.base_attitude)
        )

    fd = derivative(pose)
    pred = np.concatenate((s.J_b @ s.w[:3] + s.J_m @ s.w[3:], s.L_b @ s.w[:3]))
    assert rel(pred, fd) < FD_TOL
    # the ee pose itself: Pinocchio's frame placement, attitude on the |s| <= 1 branch
    assert s.ee_pose[3:] @ s.ee_pose[3:] <= 1 + 1e-15
    R_e = mrp.to_rotation(s.ee_pose[3:])
    assert np.abs(R_e - s.ee_rotation).max() < 1e-13


def test_angular_momentum_constant_along_aba_trajectory(spatial_chain, spatial_state, rng):
    """Eq. (13): A_0 = H_bb w_b + H_bm w_m is constant (w_b inertial) under any joint torques,
    along an RK4 integration of ABA (pin.integrate for the configuration). Its drift over 0.5 s
    at dt = 1e-3 is bounded by the integrator's error (~dt^2 for the base pose stages, about
    1e-7 relative here), far below the change of the base-frame vector R_0^T A_0."""
    robot = spatial_chain(6)
    model, data = robot.model, robot.model.createData()
    q, v = spatial_state(robot, rng)
    u_amp = rng.normal(scale=5.0, size=robot.n_joints)

    def f(t, q_, v_):
        tau = np.concatenate((np.zeros(6), u_amp * np.sin(3 * t)))
        return pin.aba(model, data, q_, v_, tau).copy()

    s0 = SpatialState(robot).update(q, v)
    A0 = s0.angular_momentum.copy()
    A0_base = s0.base_rotation.T @ A0
    dt, t = 1e-3, 0.0
    for _ in range(500):
        k1v, k1a = v, f(t, q, v)
        q2 = pin.integrate(model, q, k1v * dt / 2)
        k2v, k2a = v + k1a * dt / 2, f(t + dt / 2, q2, v + k1a * dt / 2)
        q3 = pin.integrate(model, q, k2v * dt / 2)
        k3v, k3a = v + k2a * dt / 2, f(t + dt / 2, q3, v + k2a * dt / 2)
        q4 = pin.integrate(model, q, k3v * dt)
        k4v, k4a = v + k3a * dt, f(t + dt, q4, v + k3a * dt)
        q = pin.integrate(model, q, (k1v + 2 * k2v + 2 * k3v + k4v) * dt / 6)
        v = v + (k1a + 2 * k2a + 2 * k3a + k4a) * dt / 6
        t += dt
    s1 = SpatialState(robot).update(q, v)
    drift = np.abs(s1.angular_momentum - A0).max() / np.abs(A0).max()
    change_base = np.abs(s1.base_rotation.T @ s1.angular_momentum - A0_base).max()
    assert drift < 1e-6
    assert change_base > 1e3 * drift * np.abs(A0).max()  # the inertial frame matters


def test_reaction_torque_of_a_frozen_arm(spatial_chain, spatial_state, rng):
    """With w_m = 0 and dw_m/dt = 0, Eq. (7) gives F_r = 0, and Eq. (6) is Euler's equation
    of the locked system: M_bb dw_b/dt + w_b x (M_bb w_b) = 0."""
    robot = spatial_chain(5)
    q, v = spatial_state(robot, rng)
    v[6:] = 0.0
    s = SpatialState(robot).update(q, v)
    M = s.M
    w_b_dot = np.linalg.solve(M[:3, :3], -s.h[:3])  # rows 1-3 of Eq. (8) with dw_m/dt = 0
    w_dot = np.concatenate((w_b_dot, np.zeros(robot.n_joints)))
    # cross-check that acceleration with Pinocchio: the torque that keeps the arm frozen
    tau_m = M[3:] @ w_dot + s.h[3:]
    a = pin.aba(robot.model, robot.model.createData(), q, v, np.concatenate((np.zeros(6), tau_m)))
    assert rel(s.acceleration_to_w_dot(a), w_dot) < 1e-11
    assert np.abs(s.reaction_torque(w_dot)).max() < 1e-11 * max(1.0, np.abs(M).max())
    w_b = s.w[:3]
    euler = M[:3, :3] @ w_b_dot + np.cross(w_b, M[:3, :3] @ w_b)
    assert np.abs(euler).max() < 1e-11 * max(1.0, np.abs(M).max())


def test_reduced_terms_invariant_to_base_translation(spatial_chain, spatial_state, rng):
    """M and h are functions of (q_b, q_m, w) only: base position and linear velocity (with w
    fixed) change neither (the CoM frame removes them)."""
    robot = spatial_chain(4)
    q, v = spatial_state(robot, rng)
    s = SpatialState(robot).update(q, v)
    M, h = s.M.copy(), s.h.copy()
    q2 = q.copy()
    q2[:3] += rng.uniform(-5, 5, 3)
    v2 = v.copy()
    v2[:3] += rng.normal(size=3)
    s.update(q2, v2)
    assert rel(s.M, M) < 1e-12
    assert rel(s.h, h) < 1e-12


@pytest.mark.parametrize("n", [3])
def test_outputs_are_read_only(spatial_chain, spatial_state, rng, n):
    robot = spatial_chain(n)
    s = SpatialState(robot).update(*spatial_state(robot, rng))
    for name in ("M", "h", "H_bb", "H_bm", "J_b", "J_m", "L_b", "w", "ee_pose", "com_velocity"):
        with pytest.raises(ValueError):
            getattr(s, name)[...] = 0.0
