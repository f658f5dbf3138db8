"""FloatingBaseState (the Pinocchio side of the reduced model) against the facts of docs/model.md
section 1, checked with independent Pinocchio computations and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.model._state_planar import base_twist_to_local, base_twist_to_world
from ffsm_pin.model.state import State as FloatingBaseState
from ffsm_pin.robot import load_robot

N_STATES = 5  # random states per robot and test


def rel_err(actual, expected, floor=1.0):
    """max |actual - expected| / max(max |expected|, floor)."""
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    return float(np.abs(actual - expected).max() / max(np.abs(expected).max(), floor))


def derivative(f, h=1e-3):
    """d/dt f(t) at t = 0 by the 5-point central stencil: truncation h^4/30 |f^(5)| ~ 1e-13
    for the smooth, O(1)-per-radian functions here; rounding ~ 1e-16 |f| / h ~ 1e-12."""
    return (8 * (f(h) - f(-h)) - (f(2 * h) - f(-2 * h))) / (12 * h)


FD_TOL = 1e-9  # bound for derivative(): the two errors above, with a margin of ~100


@pytest.fixture(scope="module", params=["paper", "planar5_collinear.urdf", "planar5_offaxis.urdf"])
def robot(request, paper_robot, data_dir):
    if request.param == "paper":
        return paper_robot
    return load_robot(data_dir / request.param)


@pytest.fixture
def states(robot, rng, random_state):
    return [random_state(robot, rng) for _ in range(N_STATES)]


def test_H_is_first_row_of_M(robot, states):
    st = FloatingBaseState(robot)
    for q, v in states:
        st.update(q, v)
        # H from the centroidal map (ccrba), M from the Schur complement of CRBA: independent
        assert st.H_bb.shape == (1, 1) and st.H_bm.shape == (1, robot.n_joints)
        assert rel_err(np.hstack((st.H_bb, st.H_bm))[0], st.M[0]) < 1e-12
        # Eq. (13): A_0 = H_bb w_b + H_bm w_m (no contribution of the base linear velocity)
        w = v[2:]
        L = float(st.H_bb[0, 0] * w[0] + st.H_bm[0] @ w[1:])
        assert abs(L - st.angular_momentum) <= 1e-12 * max(1.0, abs(L))


def test_reduced_terms_do_not_depend_on_base_translation_or_pose(robot, states, rng):
    """Galilean invariance and the symmetry of the base pose: M and h = C w are functions of
    (q_m, w) only. The full RNEA terms do depend on the (base-frame) linear velocity."""
    st = FloatingBaseState(robot)
    for q, v in states:
        st.update(q, v)
        M, h, h_full = st.M.copy(), st.h.copy(), st.nonlinear_effects.copy()
        q2 = robot.configuration(rng.uniform(-5, 5, 3), q[4:])  # other base pose
        v2 = v.copy()
        v2[:2] += rng.normal(scale=2.0, size=2)  # other base linear velocity
        st.update(q2, v2)
        # 1e-12: the same quantities computed through different rounding paths
        assert rel_err(st.M, M) < 1e-12
        assert rel_err(st.h, h, floor=1e-3) < 1e-12
        assert rel_err(st.nonlinear_effects, h_full, floor=1e-3) > 1e-3  # not trivially equal


def test_mass_matrices_symmetric_positive_definite(robot, states):
    st = FloatingBaseState(robot)
    for q, v in states:
        st.update(q, v)
        for M in (st.mass_matrix, st.M):
            assert rel_err(M, M.T) < 1e-13
            assert np.linalg.eigvalsh(M).min() > 0
        # a Schur complement never exceeds the block it reduces: M_rr - M >= 0 (PSD)
        gap = st.mass_matrix[2:, 2:] - st.M
        assert np.linalg.eigvalsh(gap).min() > -1e-12 * np.abs(st.M).max()


def _ee_minus_com(robot, data, base_pose, joints):
    """(p_e - p_com, q_e) by plain forward kinematics."""
    model = robot.model
    q = robot.configuration(base_pose, joints)
    pin.framesForwardKinematics(model, data, q)
    com = pin.centerOfMass(model, data, q)
    oMe = data.oMf[robot.ee_frame_id]
    angle = math.atan2(oMe.rotation[1, 0], oMe.rotation[0, 0])
    return np.array([*(oMe.translation[:2] - com[:2]), angle])


def _fd_jacobian(robot, data, q):
    """d(p_e - p_com, q_e) / d(q_b, q_m) by central differences at the base pose of q."""
    x, y = q[0], q[1]
    angles0 = np.concatenate(([math.atan2(q[3], q[2])], q[4:]))
    f0 = _ee_minus_com(robot, data, (x, y, angles0[0]), angles0[1:])
    J = np.empty((3, robot.n_joints + 1))
    for i in range(robot.n_joints + 1):

        def f(t, i=i):
            angles = angles0.copy()
            angles[i] += t
            val = _ee_minus_com(robot, data, (x, y, angles[0]), angles[1:])
            val[2] = f0[2] + math.remainder(val[2] - f0[2], 2 * math.pi)  # no 2 pi jumps
            return val

        J[:, i] = derivative(f)
    return J


def test_jacobians_match_finite_differences(robot, states):
    data = robot.model.createData()
    st = FloatingBaseState(robot)
    for q, v in states:
        st.update(q, v)
        J_fd = _fd_jacobian(robot, data, q)
        assert rel_err(st.J_b[:, 0], J_fd[:, 0]) < FD_TOL
        assert rel_err(st.J_m, J_fd[:, 1:]) < FD_TOL
        # the attitude row is the +-1 joint-sign row (to rounding of the rotated axes)
        np.testing.assert_allclose(st.J_b[2], [1.0], rtol=0, atol=1e-15)
        np.testing.assert_allclose(st.J_m[2], robot.geometry.axis_signs, rtol=0, atol=1e-15)


def test_momenta_match_finite_differences(robot, states):
    """P = m v_com and L = sum_i m_i (c_i - p_com) x dc_i/dt + I_i dphi_i/dt, every velocity
    by differentiating positions along q(t) = integrate(q, t v) (whose velocity is v)."""
    model = robot.model
    data = model.createData()
    g = robot.geometry
    st = FloatingBaseState(robot)
    for q, v in states:
        st.update(q, v)

        def positions(t, q=q, v=v):
            qt = pin.integrate(model, q, t * v)
            pin.forwardKinematics(model, data, qt)
            out = []
            for j in range(1, model.njoints):
                oMi = data.oMi[j]
                out += list((oMi.act(model.inertias[j].lever))[:2])
                out += [oMi.rotation[0, 0], oMi.rotation[1, 0]]  # cos, sin of the body angle
            return np.array(out).reshape(-1, 4)  # rows (c_x, c_y, cos phi, sin phi) per body

        x0, xd = positions(0.0), derivative(positions)
        m = g.masses
        com = m @ x0[:, :2] / m.sum()
        v_com = m @ xd[:, :2] / m.sum()
        r = x0[:, :2] - com
        phi_dot = x0[:, 2] * xd[:, 3] - x0[:, 3] * xd[:, 2]  # cos d(sin) - sin d(cos)
        L = float(np.sum(m * (r[:, 0] * xd[:, 1] - r[:, 1] * xd[:, 0]) + g.inertias * phi_dot))

        assert rel_err(st.com_position, com) < 1e-12
        assert rel_err(st.com_velocity, v_com) < FD_TOL
        assert rel_err(st.linear_momentum, m.sum() * v_com, floor=m.sum()) < FD_TOL
        # L sums 2 (n + 1) differentiated terms of size ~ m_i |r_i| |v_i|: 10 FD_TOL of |L| + 1
        assert abs(st.angular_momentum - L) < 10 * FD_TOL * max(1.0, abs(L))


def test_base_twist_conversion(robot, states):
    """base_twist_world is the velocity of the base frame origin in the inertial frame."""
    model = robot.model
    for q, v in states:
        st = FloatingBaseState(robot).update(q, v)

        def base_pose(t, q=q, v=v):
            qt = pin.integrate(model, q, t * v)
            dqb = math.atan2(q[2] * qt[3] - q[3] * qt[2], q[2] * qt[2] + q[3] * qt[3])
            return np.array([qt[0], qt[1], dqb])  # attitude relative to q's: no 2 pi jumps

        assert rel_err(st.base_twist_world, derivative(base_pose)) < FD_TOL
        assert rel_err(base_twist_to_world(q, v), st.base_twist_world) < 1e-15
        assert rel_err(base_twist_to_local(q, st.base_twist_world), v[:3]) < 1e-14
        assert st.base_attitude == pytest.approx(math.atan2(q[3], q[2]), abs=0)
        np.testing.assert_array_equal(st.w, v[2:])
        np.testing.assert_array_equal(st.joint_angles, q[4:])


def test_ee_pose_is_the_frame_placement(robot, states):
    model = robot.model
    data = model.createData()
    for q, v in states:
        st = FloatingBaseState(robot).update(q, v)
        pin.framesForwardKinematics(model, data, q)
        oMe = data.oMf[robot.ee_frame_id]
        assert rel_err(st.ee_pose[:2], oMe.translation[:2]) < 1e-14
        assert math.cos(st.ee_pose[2]) == pytest.approx(oMe.rotation[0, 0], abs=1e-14)
        assert math.sin(st.ee_pose[2]) == pytest.approx(oMe.rotation[1, 0], abs=1e-14)
        assert -math.pi < st.ee_pose[2] <= math.pi


def test_reduced_dynamics_match_aba(robot, states, rng):
    """M dw/dt + h = (0, u_m) (Eq. 8) with the rotational accelerations of Pinocchio's ABA."""
    model = robot.model
    data = model.createData()
    st = FloatingBaseState(robot)
    for q, v in states:
        st.update(q, v)
        u = rng.uniform(-20, 20, robot.n_joints)
        tau = np.concatenate((np.zeros(3), u))
        a = pin.aba(model, data, q, v, tau)
        lhs = st.M @ a[2:] + st.h
        rhs = np.concatenate(([0.0], u))
        scale = max(np.abs(st.M @ a[2:]).max(), np.abs(st.h).max(), np.abs(u).max())
        # ABA and CRBA/RNEA agree to rounding: 1e-11 of the largest term
        assert np.abs(lhs - rhs).max() < 1e-11 * scale


def test_update_checks_shapes(paper_robot):
    st = FloatingBaseState(paper_robot)
    with pytest.raises(ValueError, match="state shapes"):
        st.update(np.zeros(5), np.zeros(7))


def test_reaction_torque_matches_pinocchio(paper_robot):
    """Eqs. (6)-(7): F_r = M_bb dw_b/dt + 1/2 dM_bb/dt w_b = -(M_bm dw_m/dt + C_bm w_m).

    Independent of the barycentric regressors: dM_bb/dt is a central difference of
    Pinocchio's centroidal map (A_g[5, 2] = M_bb) along the motion, the accelerations come
    from ABA, and the second form uses Pinocchio's reduced M and C w with
    C_bm w_m = (C w)_b - C_bb w_b. Bound: central difference with eps = 1e-6, error ~1e-9.
    """
    from ffsm_pin.model.planar import BarycentricModel

    model = paper_robot.model
    data = model.createData()
    bm = BarycentricModel(paper_robot.geometry)
    st = FloatingBaseState(paper_robot)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = paper_robot.configuration(rng.normal(size=3), rng.uniform(-2, 2, 4))
        v = rng.normal(size=model.nv)
        tau = np.concatenate(([0.0, 0.0, 0.0], rng.normal(scale=5.0, size=4)))
        a = pin.aba(model, data, q, v, tau).copy()
        st.update(q, v)
        eps = 1e-6
        A_plus = pin.computeCentroidalMap(model, data, pin.integrate(model, q, eps * v))[5, 2]
        A_minus = pin.computeCentroidalMap(model, data, pin.integrate(model, q, -eps * v))[5, 2]
        M_bb_dot = (A_plus - A_minus) / (2 * eps)
        w, w_dot = st.w, a[2:]
        expected = st.M[0, 0] * w_dot[0] + 0.5 * M_bb_dot * w[0]
        second_form = -(st.M[0, 1:] @ w_dot[1:] + st.h[0] - 0.5 * M_bb_dot * w[0])
        got = bm.reaction_torque(bm.theta_d, st.base_attitude, q[4:], w, w_dot)
        scale = max(1.0, abs(expected))
        assert abs(got - expected) < 1e-7 * scale
        assert abs(second_form - expected) < 1e-7 * scale
