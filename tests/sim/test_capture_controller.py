"""The controller after capture (issue 40): the ``on_capture`` hook, the held body joining the
estimates of lu-jia, adaptive-ct and gjm-ct (numpy and compiled), and the event's estimates.

With exact estimates and ``[capture] estimates = "true"`` the controller's model after the hook
is the merged robot's: M(q), C(q, w) w, H_bb and H_bm of the estimates equal Pinocchio's on
the merged robot (the box a payload of the hand) to rounding; before the hook they are off by
the box. Capture exists for free-flyer robots only (docs/capture.md, "Capture is for
free-flyer robots"), so the checks are spatial."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pinocchio as pin
import pytest
from capture_grasp import (
    capture_scenario,
    grasp_at_half_a_second,
    merged_measurement,
    replies_after_capture,
)

from ffsm_pin.control.adaptive_ct import AdaptiveComputedTorque
from ffsm_pin.control.gjm_ct import GjmComputedTorque
from ffsm_pin.control.held_body import CaptureEvent, held_body_increment
from ffsm_pin.control.lu_jia import LuJiaController
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.capture_run import held_body_estimate
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.measurement import Sensor
from ffsm_pin.sim.setup import prepare

CONTROLLERS = {
    "lu-jia": LuJiaController,
    "adaptive-ct": AdaptiveComputedTorque,
    "gjm-ct": GjmComputedTorque,
}


@pytest.fixture(scope="module")
def grasp():
    """The capture case's robot (exact estimates) grasping its box at t = 0.5 s
    (capture_grasp.py), its hook not given the run's truths."""
    return grasp_at_half_a_second(4, truths=False)


def _model_errors(ctx, state, merged, q, v):
    """max |.| of (M, C w, H_bb, H_bm) of the estimates in ``state`` less the merged robot's
    (Pinocchio's reduced M and C w of the merged robot), each relative to the true one's."""
    meas = Sensor(merged, ctx.model, full_model=True).measure(0.5, q, v)
    m, m3 = ctx.model, ctx.m3
    M = m.mass_matrix(state.theta_d, meas.q_b, meas.q_m)
    h = m.velocity_product(state.theta_d, meas.q_b, meas.q_m, meas.w)
    H_bb, H_bm, _ = m.momentum_matrices(state.theta_b, meas.q_b, meas.q_m)
    pairs = ((M, meas.M), (h, meas.h), (H_bb, meas.M[:m3, :m3]), (H_bm, meas.M[:m3, m3:]))
    return [float(np.abs(a - b).max() / np.abs(b).max()) for a, b in pairs]


@pytest.mark.parametrize("kind", list(CONTROLLERS))
def test_true_estimates_give_the_merged_robots_model(grasp, kind):
    """Exact estimates, the hook with the held body's true inertia: the controller's M, C w,
    H_bb, H_bm equal the merged robot's within 1e-10 relative (measured ~1e-15); before the
    hook they miss the box by more than 1 %."""
    setup, motion, merged, q, v, _ = grasp
    ctx = setup.controller.context
    ctrl = CONTROLLERS[kind](ctx, backend="numpy")
    state = ctrl.law.state if kind == "lu-jia" else ctrl.state
    before = _model_errors(ctx, state, merged, q, v)
    assert min(before[0], before[2], before[3]) > 1e-2  # (C w: the arm's rates are small)
    event = motion.event
    assert event is not None and event.estimates == "true" and event.time == 0.5
    assert abs(event.held.mass - setup.target.mass) < 1e-12
    ctrl.on_capture(event)
    assert max(_model_errors(ctx, state, merged, q, v)) < 1e-10
    assert any("joined the parameter estimates" in e for e in ctrl.events)


@pytest.mark.parametrize("kind", list(CONTROLLERS))
def test_the_compiled_period_sees_the_update(grasp, kind):
    """After the hook the compiled period and the numpy reference give the same torque (the
    estimates live in the state arrays the kernels read), and a different one from a
    controller not told of the box."""
    replies = replies_after_capture(grasp, CONTROLLERS[kind], grasp.motion.event)
    u = {backend: np.asarray(reply[0]) for backend, reply in replies.items()}
    ctx = grasp.setup.controller.context
    unaware = np.asarray(CONTROLLERS[kind](ctx, backend="numba").step(merged_measurement(grasp))[0])
    scale = np.abs(u["numpy"]).max()
    np.testing.assert_allclose(u["numba"], u["numpy"], rtol=0, atol=1e-9 * scale)
    assert np.abs(unaware - u["numpy"]).max() > 1e-4 * scale


def test_unknown_tells_nothing_and_perturbed_is_seeded(grasp):
    """With "unknown" an event without the body, the estimates unchanged. "perturbed": the body
    drawn by the [controller.estimates] rule, the same draw twice, a mass within the spread
    and not the true one; its increment moves the parameters less than the true one's does
    by the mass ratio's order."""
    setup, motion, *_ = grasp
    ctx = setup.controller.context
    ctrl = GjmComputedTorque(ctx, backend="numpy")
    before = [x.copy() for x in ctrl.state]
    ctrl.on_capture(CaptureEvent(0.5, "unknown"))
    assert all(np.array_equal(a, b) for a, b in zip(before, ctrl.state, strict=True))
    true = motion._held.act(setup.target.spatial_inertia())
    a, b = held_body_estimate(true, setup), held_body_estimate(true, setup)
    assert a == b and a != true
    spread = setup.scenario.controller.estimates.spread
    assert abs(a.mass / true.mass - 1.0) <= spread
    inc_true = held_body_increment(setup.robot, ctx.model, true)
    inc_drawn = held_body_increment(setup.robot, ctx.model, a)
    rel = np.abs(inc_drawn.theta_d - inc_true.theta_d).max() / np.abs(inc_true.theta_d).max()
    assert 0.0 < rel < 3 * spread


def test_in_a_run_the_estimates_jump_by_the_held_body_at_the_grasp():
    """The capture case (lu-jia) run with "unknown" and with "true" to just past the grasp:
    bit for bit the same until the grasp; at the grasp's row the recorded theta_d-hat and
    theta_z-hat (at t, after the hook, before the period's update) differ by exactly the held
    body's increment (1e-12 relative), v_0 the system's; the run notes the event."""
    runs = {}
    for est in ("unknown", "true"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            setup = prepare(capture_scenario(est, initial="perturbed", duration=3.2))
        runs[est] = (setup, simulate(setup))
    (setup, a), (_, b) = runs["unknown"], runs["true"]
    t_c = b.capture.time
    assert a.capture.time == t_c
    i = int(np.flatnonzero(np.asarray(b["t"]) >= t_c)[0])
    for key in ("q", "v", "u_m", "theta_d_hat"):
        assert np.array_equal(np.asarray(a[key])[:i], np.asarray(b[key])[:i]), key
    data = setup.robot.model.createData()
    held = None
    for motion_state in (b["target_pose"][i],):  # the held box's pose at the grasp's row
        oMt = pin.XYZQUATToSE3(motion_state)
        pin.framesForwardKinematics(setup.robot.model, data, np.asarray(b["q"])[i])
        held = data.oMf[setup.robot.ee_frame_id].actInv(oMt).act(setup.target.spatial_inertia())
    inc = held_body_increment(setup.robot.estimated, setup.model, held)
    jump_d = np.asarray(b["theta_d_hat"])[i] - np.asarray(a["theta_d_hat"])[i]
    jump_z = np.asarray(b["theta_z_hat"])[i] - np.asarray(a["theta_z_hat"])[i]
    assert np.abs(jump_d - inc.theta_d).max() < 1e-12 * np.abs(inc.theta_d).max()
    assert np.abs(jump_z[3:] - inc.V).max() < 1e-12 * np.abs(inc.V).max()
    # "true": v_0 is set to the whole system's after the impact (the truth after the capture)
    assert np.array_equal(np.asarray(b["theta_z_hat"])[i][:3], b["theta_z_captured"][:3])
    assert any("joined the parameter estimates" in e for e in b.summary()["events"])


def test_after_an_approach_the_reference_holds_the_hand_fixed_in_the_bus_frame():
    """capture-approach with exact sensors and a 4 s approach: from the grasp on the reference
    the controller had is the bus-fixed point p_b + R_b r(t) and its rate v_b + w_b x R_b r +
    R_b dr/dt, with p_b, R_b, v_b, w_b the bus's recorded state (not the hand kinematics the
    reference is built from) and r(t) the closed-form rest-to-rest curve from the hand's
    bus-frame position and velocity at the grasp (1e-12 m, 1e-12 m/s)."""
    from ffsm_pin.scenario.spec import SensorSpec
    from ffsm_pin.scenario.target_spec import ApproachSpec
    from ffsm_pin.sim.approach import HOLD_TIME

    sc = builtin_scenario("capture-approach")
    target = dataclasses.replace(sc.target, approach=ApproachSpec(4.0))
    sc = dataclasses.replace(sc, duration=5.0, target=target, sensors=SensorSpec())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(sc)
    res = simulate(setup)
    assert res.completed and res.capture.captured
    t, q, v = np.asarray(res["t"]), np.asarray(res["q"]), np.asarray(res["v"])
    z, dz = np.asarray(res["z_e"])[:, :3], np.asarray(res["z_e_dot"])[:, :3]
    z_d, dz_d = np.asarray(res["z_e_d"])[:, :3], np.asarray(res["z_e_d_dot"])[:, :3]
    c = int(np.flatnonzero(t >= res.capture.time)[0])
    assert t[-1] - t[c] > 3 * HOLD_TIME

    def bus(i):
        R = pin.Quaternion(q[i, 6], q[i, 3], q[i, 4], q[i, 5]).toRotationMatrix()
        return q[i, :3], R, R @ v[i, :3], R @ v[i, 3:6]

    p, R, v_b, w_b = bus(c)
    r_c = R.T @ (z[c] - p)  # the hand in the bus frame, and its velocity relative to the bus
    u_c = R.T @ (dz[c] - v_b - np.cross(w_b, z[c] - p))
    worst = np.zeros(2)
    for i in range(c, len(t)):
        p, R, v_b, w_b = bus(i)
        decay = np.exp(-(t[i] - t[c]) / HOLD_TIME)
        r = r_c + u_c * HOLD_TIME * (1.0 - decay)
        want = p + R @ r
        rate = v_b + np.cross(w_b, R @ r) + R @ (u_c * decay)
        worst = np.maximum(worst, (np.abs(z_d[i] - want).max(), np.abs(dz_d[i] - rate).max()))
    assert worst[0] < 1e-12 and worst[1] < 1e-12, worst
    assert res.summary()["funnel_ok_z"]


@pytest.mark.parametrize("case", ["planar5", "spatial"])
def test_the_increment_is_the_payloads_on_both_roots(case):
    """held_body_increment on a planar (general layout) and a spatial robot: theta_d + the
    increment gives Pinocchio's reduced M and C w of the robot whose end-effector link
    carries the body (as [robot.payload] attaches it), within 1e-10 relative at a random
    state. (A planar robot of the collinear layout cannot hold a body off its link's line:
    parameters_of refuses it, the layout has no Ds_kl.)"""
    import dataclasses as dc

    from ffsm_pin.control.held_body import robot_holding
    from ffsm_pin.robot.payload import Payload

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(dataclasses.replace(builtin_scenario(case), duration=0.01))
    robot, model = setup.robot, setup.model
    held = pin.Inertia(3.0, np.array([0.06, -0.03, 0.0]), np.diag([0.02, 0.03, 0.04]))
    I = held.inertia
    payload = Payload(3.0, (I[0, 0], I[1, 1], I[2, 2], 0.0, 0.0, 0.0), tuple(held.lever))
    holding = dc.replace(
        robot, model=payload.attach(robot.model, robot.ee_frame_id),
        geometry=robot_holding(robot, held),
    )  # fmt: skip
    rng = np.random.default_rng(7)
    q, v = setup.q0.copy(), setup.v0.copy()
    n = robot.n_joints
    q[-n:] += rng.uniform(-0.3, 0.3, n)
    v[-n:] += rng.normal(0.0, 0.3, n)
    meas = Sensor(holding, model, full_model=True).measure(0.0, q, v)
    theta_d = model.theta_d + held_body_increment(robot, model, held).theta_d
    M = model.mass_matrix(theta_d, meas.q_b, meas.q_m)
    h = model.velocity_product(theta_d, meas.q_b, meas.q_m, meas.w)
    assert np.abs(M - meas.M).max() < 1e-10 * np.abs(meas.M).max()
    assert np.abs(h - meas.h).max() < 1e-10 * np.abs(meas.h).max()
    M0 = model.mass_matrix(model.theta_d, meas.q_b, meas.q_m)
    assert np.abs(M0 - meas.M).max() > 1e-3 * np.abs(meas.M).max()  # (the body matters)
