"""The approach (issue 40, third slice): the end-effector reference follows the target's grasp
frame predicted from a target sensor, a hand grasp offset, and the built-in case
'capture-approach'.

Checked: the grasp point's motion against Pinocchio's frame kinematics of the combined model
and finite differences of the torque-free integrator; the hand offset against Pinocchio's hand
frame; with an exact, undelayed sensor the reference the controller got (the recorded
z_e_d, and the table its compiled kernels read) is the true grasp point; with a delay the
prediction recovers it; with noise the plant is unchanged (the target's motion bit for bit,
the system's momentum); the case captures the box that starts 25 cm from the hand."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude import mrp
from ffsm_pin.control.reference_kernels import reference_arrays, reference_at
from ffsm_pin.scenario.devices import SensorSpec
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.scenario.target_spec import ApproachSpec
from ffsm_pin.sim.approach import ApproachController, blend, grasp_motion, hand_offset
from ffsm_pin.sim.capture_run import CaptureMotion, hand_grasp
from ffsm_pin.sim.figures import write_figures
from ffsm_pin.sim.impact import capture_model
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.measurement import Sensor
from ffsm_pin.sim.plant import Plant
from ffsm_pin.sim.setup import prepare
from ffsm_pin.sim.target import Target, TargetState, torque_free_step

CASE = "capture-approach"


def _scenario(
    duration: float, approach: ApproachSpec | None = None, hand=None, sensors=None, grasp=True
):
    """The case for ``duration`` seconds, with another [approach], hand offset or [sensors];
    ``grasp`` False: a capture tolerance of 1 nm (the hand follows the box without grasping
    it)."""
    sc = builtin_scenario(CASE)
    target = sc.target
    assert target is not None and target.capture is not None
    capture = target.capture
    if hand is not None:
        capture = dataclasses.replace(capture, hand_xyz=hand)
    if not grasp:
        capture = dataclasses.replace(capture, tolerance_position=1e-9)
    target = dataclasses.replace(target, approach=approach or target.approach, capture=capture)
    sc = dataclasses.replace(sc, duration=duration, target=target)
    return sc if sensors is None else dataclasses.replace(sc, sensors=sensors)


def _run(scenario):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(scenario)
    return setup, simulate(setup)


def _grasp_rows(target: Target, result, rows):
    """The true grasp point's position and velocity on recorded rows."""
    pose, twist = result["target_pose"], result["target_twist"]
    out = [
        grasp_motion(target, TargetState(pin.XYZQUATToSE3(pose[i]), twist[i, :3], twist[i, 3:]))
        for i in rows
    ]
    return np.array([o[0] for o in out]), np.array([o[1] for o in out])


def _tumbling_target() -> tuple[Target, TargetState]:
    inertia = np.array([[0.9, 0.05, -0.02], [0.05, 1.3, 0.03], [-0.02, 0.03, 1.7]])
    grasp = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([-0.2, 0.05, 0.1]))
    target = Target(30.0, inertia, grasp=grasp, com=np.array([0.02, -0.01, 0.03]))
    pose = pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.4, 1.1), np.array([1.0, 0.2, -0.3]))
    state = TargetState(pose, np.array([0.01, -0.02, 0.005]), np.array([0.3, -0.5, 0.4]))
    return target, state


def test_grasp_motion_is_the_grasp_frames_and_the_integrators():
    """Position and velocity: Pinocchio's grasp frame of the combined model (the target a
    free-flyer body; LOCAL_WORLD_ALIGNED velocity). Acceleration: the central difference of
    the velocity along torque_free_step's trajectory, O(h^2)."""
    target, state = _tumbling_target()
    robot = prepare(_scenario(0.1)).robot
    cap = capture_model(robot, target)
    q, v = cap.joint_state(pin.neutral(robot.model), np.zeros(robot.model.nv), state)
    data = cap.model.createData()
    pin.forwardKinematics(cap.model, data, q, v)
    frame = pin.updateFramePlacement(cap.model, data, cap.grasp_frame)
    vel = pin.getFrameVelocity(cap.model, data, cap.grasp_frame, pin.LOCAL_WORLD_ALIGNED)
    p, dp, ddp = grasp_motion(target, state)
    assert np.abs(p - frame.translation).max() < 1e-14
    assert np.abs(dp - vel.linear).max() < 1e-14
    errors = []
    for h in (1e-3, 5e-4):
        mid = torque_free_step(target, state, h)
        fwd = torque_free_step(target, mid, h)
        ddp_h = (grasp_motion(target, fwd)[1] - grasp_motion(target, state)[1]) / (2 * h)
        errors.append(np.abs(ddp_h - grasp_motion(target, mid)[2]).max())
    assert np.abs(ddp).max() > 0.05  # (a tumbling body: a real acceleration to check)
    assert errors[0] < 1e-5 * np.abs(ddp).max()
    assert 3.5 < errors[0] / errors[1] < 4.5  # second order


def test_blend_is_a_rest_to_rest_quintic():
    T = 2.5
    for t in (0.0, 0.3, 1.25, 2.0, 2.5, 3.0):
        s, ds, dds = blend(t, T)
        h = 1e-6
        if 0 < t < T:
            assert ds == pytest.approx(
                (blend(t + h, T)[0] - blend(t - h, T)[0]) / (2 * h), abs=1e-8
            )
            assert dds == pytest.approx(
                (blend(t + h, T)[1] - blend(t - h, T)[1]) / (2 * h), abs=1e-6
            )
    assert blend(0.0, T) == (0.0, 0.0, 0.0) and blend(T, T) == (1.0, 0.0, 0.0)
    assert blend(T / 2, T)[0] == pytest.approx(0.5, abs=1e-15)


def test_hand_offset_is_pinocchios_hand_frame():
    """p_e + R_e r_e and v_e + W x r from the measured pose and MRP rate equal the position
    and velocity of capture_model's hand frame."""
    setup = prepare(_scenario(0.1))
    robot, target = setup.robot, setup.target
    rng = np.random.default_rng(3)
    q, v = setup.q0.copy(), setup.v0.copy()
    v[:6] = 0.05 * rng.standard_normal(6)
    v[6:] = 0.2 * rng.standard_normal(robot.model.nv - 6)
    offset = pin.SE3(pin.rpy.rpyToMatrix(0.2, 0.1, -0.3), np.array([0.01, -0.02, 0.1]))
    cap = capture_model(robot, target, offset)
    meas = Sensor(robot, setup.model, full_model=False).measure(0.0, q, v)
    r, dr, _ = hand_offset(offset.translation, meas.z_e, meas.z_e_dot)
    state = setup.target_state
    qc, vc = cap.joint_state(q, v, state)
    data = cap.model.createData()
    pin.forwardKinematics(cap.model, data, qc, vc)
    hand = pin.updateFramePlacement(cap.model, data, cap.hand_frame)
    vel = pin.getFrameVelocity(cap.model, data, cap.hand_frame, pin.LOCAL_WORLD_ALIGNED)
    assert np.abs(meas.z_e[:3] + r - hand.translation).max() < 1e-14
    assert np.abs(meas.z_e_dot[:3] + dr - vel.linear).max() < 1e-13
    assert np.abs(mrp.to_rotation(meas.z_e[3:]) @ offset.translation - r).max() < 1e-15


@pytest.fixture(scope="module")
def exact():
    """1.2 s, an approach of 1 s, exact robot sensors and target sensor, a hand offset."""
    sc = _scenario(1.2, ApproachSpec(1.0), hand=(0.0, 0.0, 0.02), sensors=SensorSpec(), grasp=False)
    return _run(sc)


def test_the_reference_is_the_true_grasp_point_with_an_exact_sensor(exact):
    """From the end of the blend on, the reference the controller had (recorded z_e_d) plus
    the hand offset turned by the end effector's attitude is the true grasp point, and its
    rate the grasp point's velocity less the offset's (to rounding); before, the blend."""
    setup, result = exact
    assert isinstance(setup.controller, ApproachController)
    t, q, v = result["t"], result["q"], result["v"]
    robot = setup.robot
    model, data = robot.model, robot.model.createData()
    offset = np.array([0.0, 0.0, 0.02])
    rows = np.flatnonzero(t >= 1.0)
    g, dg = _grasp_rows(setup.target, result, rows)
    for j, i in enumerate(rows):
        pin.forwardKinematics(model, data, q[i], v[i])
        ee = pin.updateFramePlacement(model, data, robot.ee_frame_id)
        w = pin.getFrameVelocity(model, data, robot.ee_frame_id, pin.LOCAL_WORLD_ALIGNED).angular
        r = ee.rotation @ offset
        assert np.abs(result["z_e_d"][i] + r - g[j]).max() < 1e-12
        assert np.abs(result["z_e_d_dot"][i] + np.cross(w, r) - dg[j]).max() < 1e-12
    # before: r + s (g - r), r the [reference]'s (the hand holding its place)
    i = int(np.flatnonzero(t >= 0.4)[0])
    (gi,), _ = _grasp_rows(setup.target, result, [i])
    pin.framesForwardKinematics(model, data, q[i])
    gi = gi - data.oMf[robot.ee_frame_id].rotation @ offset
    s = blend(t[i], 1.0)[0]
    r0 = result["z_e"][0]
    assert np.abs(result["z_e_d"][i] - (r0 + s * (gi - r0))).max() < 1e-12
    # the table the compiled kernels read holds the last period's expansion
    arrays = reference_arrays(setup.approach.reference)
    last = result["z_e_d"][-1]
    assert np.abs(reference_at(arrays, t[-1], False) - last).max() == 0.0
    assert np.abs(reference_at(arrays, t[-1], True) - result["z_e_d_dot"][-1]).max() == 0.0


def test_a_delay_is_compensated_by_the_prediction(exact):
    """With a delay of 5 periods and no noise, the reference after the blend is the true
    grasp point within the integrators' difference (the plant's substeps against the
    prediction's control periods), far below the 5 periods' motion."""
    setup0, result0 = exact
    sc = _scenario(
        1.2, ApproachSpec(1.0, delay=5), hand=(0.0, 0.0, 0.02), sensors=SensorSpec(), grasp=False
    )
    setup, result = _run(sc)
    t = result["t"]
    rows = np.flatnonzero(t >= 1.0)
    gap = np.abs(result["z_e_d"][rows] - result0["z_e_d"][rows]).max()
    g, dg = _grasp_rows(setup.target, result, rows)
    moved = np.abs(g[5:] - g[:-5]).max()  # the grasp point's motion over 5 periods
    assert moved > 1e-5 and gap < 1e-3 * moved
    # unpredicted (the measurement of 5 periods ago taken as now): the gap would be `moved`


def test_noise_acts_on_the_controller_only(exact):
    """With the target sensor's noise the controller does otherwise, but the target moves
    exactly as without it and the system's momentum is the same."""
    _, exact_result = exact
    noise = ApproachSpec(1.0, seed=2, delay=2, noise=(2e-3, 5e-3, 2e-3, 2e-3))
    sc = _scenario(1.2, noise, hand=(0.0, 0.0, 0.02), sensors=SensorSpec(), grasp=False)
    setup, result = _run(sc)
    assert np.abs(result["u_m"] - exact_result["u_m"]).max() > 1e-6  # (it saw other data)
    assert not result.capture.captured and not exact_result.capture.captured
    assert np.array_equal(result["target_pose"], exact_result["target_pose"])
    assert np.array_equal(result["target_twist"], exact_result["target_twist"])
    # the system's linear momentum; the robot's own momentum (the plant's projection keeps
    # it; the system's L also moves with the plant's CoM position error: test_capture_run)
    assert np.abs(result["P"] - exact_result["P"][0]).max() < 1e-14
    plant = Plant(setup.robot, integrator=setup.scenario.integrator)
    for res in (result, exact_result):
        h = np.hstack(plant.momentum_rows(res["q"], res["v"]))
        assert np.abs(h - h[0]).max() < 1e-13 * max(1.0, np.abs(h[0]).max())


@pytest.fixture(scope="module")
def case():
    """The case for 5.5 s (it captures at about 4.9 s)."""
    return _run(_scenario(5.5))


def test_the_case_goes_to_the_box_and_captures_it(case):
    """The box's grasp face starts 25 cm from the hand; the hand goes to it within its
    funnels and grasps it (the relative speed within the tolerance)."""
    setup, result = case
    summary = result.summary()
    tol = setup.scenario.target.capture
    assert result.completed and summary["funnel_ok_b"] and summary["funnel_ok_z"]
    (g0,), _ = _grasp_rows(setup.target, result, [0])
    assert np.linalg.norm(g0 - result["z_e"][0]) > 0.2
    out = result.capture
    assert out.captured and 3.0 < out.time < 5.5
    assert out.distance <= tol.tolerance_position
    assert out.relative_speed <= tol.tolerance_velocity


def test_the_recorded_grasp_distance_and_speed(case):
    """grasp_distance and grasp_speed: the relative motion of the two grasp frames of an
    independent capture model on the recorded q, v and target state (before, at and after
    the capture); at the capture row the distance is the outcome's and the speed zero (the
    row's state is after the impact)."""
    setup, result = case
    cap = capture_model(setup.robot, setup.target)
    t = result["t"]
    i_c = int(np.flatnonzero(t == result.capture.time)[0])
    pose, twist = result["target_pose"], result["target_twist"]
    for i in (0, i_c // 2, i_c - 1, i_c, i_c + 1, len(t) - 1):
        state = TargetState(pin.XYZQUATToSE3(pose[i]), twist[i, :3], twist[i, 3:])
        qc, vc = cap.joint_state(result["q"][i], result["v"][i], state)
        distance, speed = cap.relative_motion(qc, vc)
        assert result["grasp_distance"][i] == pytest.approx(distance, rel=1e-12, abs=1e-15)
        assert result["grasp_speed"][i] == pytest.approx(speed, rel=1e-9, abs=1e-12)
    assert result["grasp_distance"][i_c] == result.capture.distance
    assert result["grasp_speed"][i_c] < 1e-12 and result["grasp_speed"][i_c - 1] > 1e-3


def test_the_capture_figures(case, tmp_path):
    """A run with [capture] gets fig_approach.png and fig_impulse.png beside the others; a
    run without the capture's signals does not."""
    _, result = case
    paths = write_figures(result, tmp_path / "with")
    names = {p.name for p in paths}
    assert {"fig_approach.png", "fig_impulse.png", "fig_errors.png"} <= names
    assert all(p.stat().st_size > 1000 for p in paths)
    signals = {k: v for k, v in result.signals.items() if not k.startswith("grasp_")}
    plain = dataclasses.replace(result, signals=signals, capture=None)
    names = {p.name for p in write_figures(plain, tmp_path / "without")}
    assert not names & {"fig_approach.png", "fig_impulse.png"}


def test_the_capture_welds_the_hand_frame_of_hand_xyz_and_hand_rpy():
    sc = _scenario(0.1, hand=(0.01, 0.0, 0.03))
    assert sc.target is not None and sc.target.capture is not None
    spec = dataclasses.replace(sc.target.capture, hand_rpy=(0.1, 0.2, 0.3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(sc)
    motion = CaptureMotion(setup.target, setup.target_state, setup.robot, spec)
    offset = motion.capture.hand_grasp
    assert offset.isApprox(hand_grasp(spec), 0.0)
    assert np.array_equal(offset.translation, [0.01, 0.0, 0.03])
    assert np.abs(offset.rotation - pin.rpy.rpyToMatrix(0.1, 0.2, 0.3)).max() == 0.0
    # the weld's hand frame is the end-effector frame moved by it
    data = motion.capture.model.createData()
    q = motion.capture.joint_state(setup.q0, np.zeros(setup.robot.model.nv), setup.target_state)[0]
    pin.framesForwardKinematics(motion.capture.model, data, q)
    hand = data.oMf[motion.capture.hand_frame]
    ee = data.oMf[
        motion.capture.model.getFrameId(setup.robot.model.frames[setup.robot.ee_frame_id].name)
    ]
    assert (ee * offset).isApprox(hand, 1e-14)
