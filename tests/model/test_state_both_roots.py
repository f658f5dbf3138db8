"""The one State class, tested for both roots by the same parametrized tests: what it reports
about accelerations and the reaction torque (Eq. 7) agrees with finite differences of its own
Pinocchio quantities along the motion."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude import mrp
from ffsm_pin.model import State, make_model
from ffsm_pin.robot import load_robot

H = 1e-6  # central differences: truncation ~ H^2 ~ 1e-12, rounding ~ 1e-16 / H ~ 1e-10


@pytest.fixture(scope="module", params=["planar", "free-flyer"])
def robot(request):
    if request.param == "planar":
        return load_robot("ffsm_planar4.urdf")
    return load_robot("spatial9.urdf", base="free-flyer")


def _state(robot, rng):
    q = robot.configuration(
        np.concatenate(
            (rng.uniform(-1, 1, robot.root.m2), 0.3 * rng.uniform(-1, 1, robot.root.m3))
        ),
        rng.uniform(-1.5, 1.5, robot.n_joints),
    )
    v = rng.normal(size=robot.model.nv) * 0.5
    a = rng.normal(size=robot.model.nv)
    return q, v, a


def _at(robot, q, v, a, h):
    """State after moving h along (v, a): q(t + h) to first order, v(t + h) = v + a h."""
    return State(robot).update(pin.integrate(robot.model, q, v * h), v + a * h)


def test_w_dot_is_the_derivative_of_w(robot, rng):
    for _ in range(3):
        q, v, a = _state(robot, rng)
        st = State(robot).update(q, v)
        fd = (_at(robot, q, v, a, H).w - _at(robot, q, v, a, -H).w) / (2 * H)
        np.testing.assert_allclose(st.acceleration_to_w_dot(a), fd, rtol=0, atol=1e-7)


def test_reaction_torque_matches_eq7_by_finite_differences(robot, rng):
    """F_r = M_bb dw_b/dt + 1/2 dM_bb/dt w_b (+ 1/2 w_b x M_bb w_b spatially), with M_bb = H_bb
    and dM_bb/dt from a central difference of H_bb along the motion."""
    m3 = robot.root.m3
    for _ in range(3):
        q, v, a = _state(robot, rng)
        st = State(robot).update(q, v)
        w_dot = st.acceleration_to_w_dot(a)
        Mbb_dot = (_at(robot, q, v, a, H).H_bb - _at(robot, q, v, a, -H).H_bb) / (2 * H)
        w_b = st.w[:m3]
        expected = st.H_bb @ w_dot[:m3] + 0.5 * Mbb_dot @ w_b
        if m3 == 3:
            expected = expected + 0.5 * mrp.skew(w_b) @ (st.H_bb @ w_b)
        F_r = st.reaction_torque(w_dot)
        assert F_r.shape == (m3,)
        np.testing.assert_allclose(F_r, expected, rtol=1e-6, atol=1e-8)


def test_state_agrees_with_the_model_it_parameterises(robot, rng):
    """M of the State equals the barycentric model's M(q, theta_d) (make_model picks the model
    that fits the root)."""
    model = make_model(robot)
    assert (model.m2, model.m3) == (robot.root.m2, robot.root.m3)
    q, v, _ = _state(robot, rng)
    st = State(robot).update(q, v)
    np.testing.assert_array_equal(st.joint_angles, q[robot.root.nq :])
    M = model.mass_matrix(model.theta_d, st.base_attitude, st.joint_angles)
    np.testing.assert_allclose(M, st.M, rtol=1e-10, atol=1e-10 * np.abs(st.M).max())


def test_update_dynamics_gives_the_numbers_of_update(robot, rng):
    """The known-model controller's per-period path (M, h only) is the full update's
    arithmetic: bitwise equal (the full update's M, h are checked against Pinocchio's ABA in
    tests/model/test_state.py)."""
    for _ in range(3):
        q, v, _ = _state(robot, rng)
        full = State(robot).update(q, v)
        lean = State(robot).update_dynamics(q, v)
        for key in ("M", "h", "mass_matrix", "nonlinear_effects"):
            np.testing.assert_array_equal(getattr(lean, key), getattr(full, key), err_msg=key)
    with pytest.raises(ValueError, match="state shapes"):
        State(robot).update_dynamics(q[:-1], v)


def test_update_kinematics_gives_the_numbers_of_update(robot, rng):
    """The campaign's generalized-Jacobian path (H_bb, H_bm, J_b, J_m only, no CRBA/RNEA) is
    the full update's arithmetic: the same bytes, on a fresh State and on one whose Data holds
    another state's results."""
    reused = State(robot)
    for _ in range(3):
        q, v, _ = _state(robot, rng)
        full = State(robot).update(q, v)
        q2, v2, _ = _state(robot, rng)
        reused.update(q2, v2)
        for lean in (State(robot).update_kinematics(q, v), reused.update_kinematics(q, v)):
            for key in ("H_bb", "H_bm", "J_b", "J_m"):
                assert getattr(lean, key).tobytes() == getattr(full, key).tobytes(), key
    with pytest.raises(ValueError, match="state shapes"):
        State(robot).update_kinematics(q, v[:-1])


def test_planar_mass_matrix_keeps_the_bits_of_the_triu_sum():
    """The planar M mirrors CRBA's upper triangle by an index assignment plus 0.0 instead of
    ``np.triu(M) + np.triu(M, 1).T`` (7 us of a known-model period): the same bytes, the
    signs of zeros included (the sum turns a -0.0 into +0.0; so does x + 0.0), at random
    states and at the neutral configuration at rest, where couplings vanish."""
    robot = load_robot("ffsm_planar4.urdf")
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(5)
    states = [(pin.neutral(model), np.zeros(model.nv))]
    states += [_state(robot, rng)[:2] for _ in range(5)]
    for q, v in states:
        crba = pin.crba(model, data, q).copy()
        crba[np.tril_indices(model.nv, -1)] = -0.0  # whatever CRBA leaves there is not read
        crba[0, 1] = -0.0  # a vanishing coupling with the sign a product can give it
        expected = np.triu(crba) + np.triu(crba, 1).T
        mirrored = crba.copy()
        lower = np.tril_indices(model.nv, -1)
        mirrored[lower] = mirrored.T[lower]
        mirrored += 0.0
        assert mirrored.tobytes() == expected.tobytes()
        got = State(robot).update_dynamics(q, v).mass_matrix
        reference = pin.crba(model, data, q).copy()
        assert got.tobytes() == (np.triu(reference) + np.triu(reference, 1).T).tobytes()
