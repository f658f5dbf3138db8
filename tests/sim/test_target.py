"""The capture target (ffsm_pin.sim.target, issue 40): torque-free motion against the closed form
of a symmetric top and against an independent high-accuracy integration of Euler's equations;
momentum kept to rounding, energy bounded; Pinocchio's free-flyer conventions; one-line
refusals of bad input."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

from ffsm_pin.errors import ParameterError
from ffsm_pin.sim.target import Target, TargetState, torque_free_step


def _rotation(seed: int) -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _run(target, state, dt, n, momentum=None):
    states = [state]
    for _ in range(n):
        states.append(torque_free_step(target, states[-1], dt, momentum))
    return states


def _angle(Ra, Rb) -> float:
    return float(np.linalg.norm(pin.log3(Ra.T @ Rb)))


@pytest.fixture(scope="module")
def tumbling():
    """An asymmetric body with principal axes off the target frame, CoM off its origin."""
    Q = _rotation(3)
    target = Target(
        12.0, Q @ np.diag([2.0, 3.0, 4.5]) @ Q.T, com=(0.05, -0.02, 0.1), size=(1.0, 1.0, 1.0)
    )
    state = TargetState.from_rpy(
        [1.0, -2.0, 0.5], [0.3, -0.2, 0.5], [0.1, 0.02, -0.05], [0.4, -0.3, 1.2]
    )
    return target, state


# ---- closed form of the symmetric top -------------------------------------------------------


def test_symmetric_top_matches_the_closed_form():
    """I = diag(I1, I1, I3) about an axis a off the frame's axes: the body rates turn about a
    at Omega = (I3 - I1)/I1 w3 and R(t) = exp(t L/I1) R0 exp(-Omega t a) (the flows of
    |Pi|^2/2I1 and of the rest commute)."""
    I1, I3 = 2.0, 3.5
    Q = _rotation(7)
    target = Target(10.0, Q @ np.diag([I1, I1, I3]) @ Q.T)
    a = Q[:, 2]  # symmetry axis in the body frame
    state = TargetState.from_rpy([0, 0, 0], [0.3, -0.2, 0.5], [0, 0, 0], [0.4, -0.3, 1.2])
    w0 = state.angular_velocity
    w3 = float(a @ w0)
    omega = (I3 - I1) / I1 * w3
    L = state.angular_momentum(target)
    dt, n = 1e-3, 10_000
    worst_att = worst_rate = 0.0
    for k, s in enumerate(_run(target, state, dt, n)):
        if k % 500:
            continue
        t = k * dt
        R = pin.exp3(t * L / I1) @ state.pose.rotation @ pin.exp3(-omega * t * a)
        worst_att = max(worst_att, _angle(R, s.pose.rotation))
        # body rates: w3 constant, the transverse part turned by +Omega t about a
        w = pin.exp3(omega * t * a) @ w0
        worst_rate = max(worst_rate, float(np.abs(s.angular_velocity - w).max()))
    assert worst_att < 1e-9  # measured ~5e-12
    assert worst_rate < 1e-9


def test_asymmetric_body_matches_an_independent_integration(tumbling):
    """Euler's equations I dw/dt = (I w) x w and dR/dt = R [w]x integrated by scipy's DOP853 at
    rtol = atol = 1e-13 (R as nine numbers, no splitting, no Lie group)."""
    target, state = tumbling
    I = np.array(target.inertia)

    def rhs(_t, y):
        R, w = y[:9].reshape(3, 3), y[9:]
        return np.concatenate(((R @ pin.skew(w)).ravel(), np.linalg.solve(I, np.cross(I @ w, w))))

    dt, n = 1e-3, 5000
    ref = solve_ivp(
        rhs,
        (0.0, n * dt),
        np.concatenate((state.pose.rotation.ravel(), state.angular_velocity)),
        method="DOP853",
        rtol=1e-13,
        atol=1e-13,
        t_eval=np.arange(0, n + 1, 250) * dt,
    )
    states = _run(target, state, dt, n)
    for j, k in enumerate(range(0, n + 1, 250)):
        R_ref = ref.y[:9, j].reshape(3, 3)
        assert _angle(R_ref, states[k].pose.rotation) < 1e-9  # measured ~1e-11
        np.testing.assert_allclose(states[k].angular_velocity, ref.y[9:, j], rtol=0, atol=1e-9)
    # the CoM moves on a straight line at its velocity; the frame's origin is CoM - R c
    end = states[-1]
    np.testing.assert_allclose(
        end.com_position(target),
        state.com_position(target) + n * dt * state.velocity,
        rtol=0,
        atol=1e-12,
    )


def test_fourth_order(tumbling):
    """Halving dt divides the attitude error after 4 s by ~16 (a fourth-order method)."""
    target, state = tumbling
    fine = _run(target, state, 2.5e-4, 16_000)[-1].pose.rotation
    errors = [
        _angle(fine, _run(target, state, dt, round(4.0 / dt))[-1].pose.rotation)
        for dt in (2e-2, 1e-2)
    ]
    assert 12.0 < errors[0] / errors[1] < 20.0


# ---- conservation ---------------------------------------------------------------------------


def test_momentum_kept_to_rounding_over_ten_thousand_steps(tumbling):
    target, state = tumbling
    P0, L0 = state.linear_momentum(target), state.angular_momentum(target)
    about = np.array([0.3, -1.0, 2.0])  # a fixed world point: L about it is kept too
    Lp0 = state.angular_momentum(target, about)
    n = 10_000
    # stateless use: L recomputed from each state (roundings add up, a random walk)
    free = _run(target, state, 1e-3, n)
    # the loop's use: the initial L passed at every step (one rounding, whatever n)
    held = _run(target, state, 1e-3, n, momentum=L0)
    for states, tol in ((free, 1e-12), (held, 1e-14)):
        for s in states[:: n // 20]:
            assert np.array_equal(s.linear_momentum(target), P0)
            assert np.abs(s.angular_momentum(target) - L0).max() < tol * np.linalg.norm(L0)
            assert np.abs(s.angular_momentum(target, about) - Lp0).max() < 1e-12 * np.linalg.norm(
                Lp0
            )


def test_energy_error_is_bounded_and_fourth_order(tumbling):
    """10^4 steps of 20 ms and of 10 ms (over 100 periods of the fastest rate): the energy
    error's maximum over the last fifth of the run is that of the first (no drift), and
    halving dt divides it by ~16."""
    target, state = tumbling
    E0, L0 = state.kinetic_energy(target), state.angular_momentum(target)
    peaks = []
    for dt in (2e-2, 1e-2):
        err = np.abs(
            [
                s.kinetic_energy(target) / E0 - 1
                for s in _run(target, state, dt, 10_000, momentum=L0)
            ]
        )
        first, last = err[:2000].max(), err[-2000:].max()
        assert last < 1.01 * first
        peaks.append(first)
    assert peaks[1] < 1e-9
    assert 12.0 < peaks[0] / peaks[1] < 20.0


# ---- Pinocchio's conventions ----------------------------------------------------------------


def test_pinocchio_free_flyer_round_trip_and_momentum(tumbling):
    """to_pinocchio gives the (q, v) of a free-flyer joint at the target frame: a one-body
    Pinocchio model with the target's inertia has the same linear momentum, angular momentum
    about the CoM and kinetic energy as TargetState computes."""
    target, state = tumbling
    model = pin.Model()
    jid = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "target")
    model.appendBodyToJoint(jid, target.spatial_inertia(), pin.SE3.Identity())
    data = model.createData()
    q, v = state.to_pinocchio(target)
    hg = pin.computeCentroidalMomentum(model, data, q, v)
    np.testing.assert_allclose(hg.linear, state.linear_momentum(target), rtol=0, atol=1e-13)
    np.testing.assert_allclose(hg.angular, state.angular_momentum(target), rtol=0, atol=1e-13)
    np.testing.assert_allclose(data.com[0], state.com_position(target), rtol=0, atol=1e-13)
    assert pin.computeKineticEnergy(model, data, q, v) == pytest.approx(
        state.kinetic_energy(target), rel=1e-13
    )
    back = TargetState.from_pinocchio(target, q, v)
    assert np.allclose(back.pose.homogeneous, state.pose.homogeneous, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back.velocity, state.velocity, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back.angular_velocity, state.angular_velocity, rtol=0, atol=0)


def test_box_default_inertia_is_the_uniform_box():
    t = Target.box((0.4, 0.6, 1.0), 6.0, grasp_xyz=(0.2, 0.0, 0.1), grasp_rpy=(0, 0, 0.5))
    # a uniform box by Pinocchio's own formula
    np.testing.assert_allclose(
        t.inertia, pin.Inertia.FromBox(6.0, 0.4, 0.6, 1.0).inertia, rtol=1e-15, atol=0
    )
    np.testing.assert_allclose(t.grasp.translation, (0.2, 0.0, 0.1))
    np.testing.assert_allclose(t.grasp.rotation, pin.rpy.rpyToMatrix(0, 0, 0.5))
    moments, axes = t.principal
    np.testing.assert_allclose(axes @ np.diag(moments) @ axes.T, t.inertia, atol=1e-15)
    assert np.linalg.det(axes) == pytest.approx(1.0)


# ---- bad input: one line --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("build", "words"),
    [
        (lambda: Target(0.0, np.eye(3)), "positive mass"),
        (lambda: Target(-1.0, np.eye(3)), "positive mass"),
        (lambda: Target(1.0, [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]), "non-symmetric"),
        (lambda: Target(1.0, np.diag([1.0, 1.0, -0.1])), "positive definite"),
        (lambda: Target(1.0, np.diag([1.0, 1.0, 2.5])), "triangle inequality"),
        (lambda: Target(1.0, (1.0, 2.0)), "expected 6 numbers"),
        (lambda: Target.box((0.4, 0.4, 0.4), 2.0, grasp_xyz=(0.0, 0.0, 0.25)), "outside"),
        (lambda: Target.box((0.4, 0.0, 0.4), 2.0, inertia=np.eye(3)), "edges must be > 0"),
        (
            lambda: Target(1.0, np.eye(3), grasp=pin.SE3(np.diag([1.0, 1.0, -1.0]), np.zeros(3))),
            "proper rotation",
        ),
    ],
)
def test_bad_target_is_one_line(build, words):
    with pytest.raises(ParameterError, match=words) as err:
        build()
    assert "\n" not in str(err.value)


def test_grasp_on_a_face_is_inside_and_bad_dt_refused():
    t = Target.box((0.4, 0.4, 0.4), 2.0, grasp_xyz=(0.2, -0.2, 0.0))  # on an edge: inside
    state = TargetState.from_rpy([0, 0, 0], [0, 0, 0])
    for dt in (0.0, -1e-3, float("nan")):
        with pytest.raises(ParameterError, match="dt must be > 0"):
            torque_free_step(t, state, dt)
