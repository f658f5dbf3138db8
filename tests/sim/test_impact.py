"""Capture (ffsm_pin.sim.impact, issue 40): the perfectly plastic 6-D weld between the hand's
grasp frame and the target's.

* the impulse formula and Pinocchio's impulseDynamics (CONTACT_6D between the two frames)
  agree; after the impact the weld holds and momentum is unchanged; the energy lost is the
  closed form of a plastic impact; the recorded impulse is the target's change of momentum;
* the merged robot (the target as a payload of the end effector) has the combined model's
  momentum, the accelerations of the constrained combined model (Pinocchio's
  constraintDynamics), and the plant steps it;
* bad input is one line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin import load_robot
from ffsm_pin.errors import ParameterError
from ffsm_pin.robot import Payload
from ffsm_pin.sim.impact import (
    CaptureTolerances,
    capture_model,
    impact,
    impact_pinocchio,
    merge_after_capture,
)
from ffsm_pin.sim.plant import Plant
from ffsm_pin.sim.target import Target, TargetState

PANDA_JOINTS = [-0.83, 0.72, 0.45, -2.51, 0.27, 1.7, 1.75]  # the 'spatial' case's pose


@pytest.fixture(scope="module")
def panda():
    """The built-in 'spatial' case's robot (ffsm_pin/scenario/builtin/spatial.toml)."""
    return load_robot(
        "example-robot-data:panda",
        "panda_hand",
        base="free-flyer",
        locked_joints={"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0},
        satellite={
            "mass": 200.0,
            "inertia": [3.0, 3.24, 3.48, 0.0, 0.0, 0.0],
            "size": [0.5, 0.5, 0.5],
            "mount_xyz": [0.0, 0.0, 0.3],
        },
    )


@pytest.fixture(scope="module")
def chain(spatial_chain):
    return spatial_chain(5, 3)


TARGET = Target.box((0.3, 0.2, 0.4), 20.0, grasp_xyz=(0.0, 0.05, -0.2), grasp_rpy=(np.pi, 0, 0.3))


def _capture_state(robot, seed: int, hand_grasp=None, offset=True):
    """(capture model, q, v) at a capture: the target's grasp frame a few mm and a degree from
    the hand's, robot and target moving at random (target tumbling)."""
    cm = capture_model(robot, TARGET, hand_grasp)
    rng = np.random.default_rng(seed)
    q_r = robot.neutral()
    if robot.name == "panda":
        q_r[7:] = PANDA_JOINTS
    else:
        q_r[7:] = rng.uniform(-1.0, 1.0, robot.n_joints)
    q_r[:7] = pin.SE3ToXYZQUAT(pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3)))
    v_r = rng.normal(size=robot.model.nv) * 0.2
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q_r)
    oMh = data.oMf[robot.ee_frame_id] * cm.hand_grasp
    if offset:
        oMh = oMh * pin.SE3(pin.exp3(rng.normal(size=3) * 0.01), rng.normal(size=3) * 0.003)
    state = TargetState(oMh * TARGET.grasp.inverse(), rng.normal(size=3) * 0.1, rng.normal(size=3))
    return (cm, *cm.joint_state(q_r, v_r, state))


CASES = [("panda", 0), ("panda", 1), ("chain", 2), ("chain", 3)]


@pytest.fixture(params=CASES, ids=lambda c: f"{c[0]}-{c[1]}")
def captured(request, panda, chain):
    name, seed = request.param
    robot = panda if name == "panda" else chain
    hand = pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.0, -0.2), np.array([0.0, 0.01, 0.1]))
    return _capture_state(robot, seed, hand if seed % 2 else None)


def test_formula_and_pinocchio_agree(captured):
    cm, q, v = captured
    a, b = impact(cm, q, v), impact_pinocchio(cm, q, v)
    scale = np.abs(v).max()
    assert np.abs(a.v - b.v).max() < 1e-10 * scale  # measured ~1e-15 relative
    assert np.abs(a.impulse - b.impulse).max() < 1e-10 * np.abs(a.impulse).max()
    assert a.energy_loss == pytest.approx(b.energy_loss, rel=1e-10)
    assert np.abs(a.v - v).max() > 1e-3 * scale  # a real impact, not a no-op


def test_weld_holds_momentum_kept_energy_lost(captured):
    cm, q, v = captured
    J_v = cm.relative_twist(q, v)
    result = impact(cm, q, v)
    assert np.abs(cm.relative_twist(q, result.v)).max() < 1e-12 * np.abs(J_v).max()
    h0, h1 = cm.momentum(q, v), cm.momentum(q, result.v)
    assert np.abs(h1 - h0).max() < 1e-12 * np.abs(h0).max()
    # a plastic impact loses (J v-)^T (J M^-1 J^T)^-1 (J v-) / 2 (Kelvin), > 0 unless J v- = 0
    M, J = cm.mass_matrix(q), cm.weld_jacobian(q)
    loss = 0.5 * J_v @ np.linalg.solve(J @ np.linalg.solve(M, J.T), J_v)
    assert result.energy_loss == pytest.approx(loss, rel=1e-9)
    assert cm.kinetic_energy(q, result.v) == pytest.approx(
        cm.kinetic_energy(q, v) - loss, rel=1e-12
    )
    assert result.energy_loss > 0


def test_impulse_is_the_targets_change_of_momentum(captured):
    """The target alone receives -impulse at the hand's grasp point: its linear momentum
    changes by -R_h lambda_lin and its angular momentum about that point by -R_h lambda_ang
    (TargetState's own momenta, no Pinocchio centroidal call)."""
    cm, q, v = captured
    result = impact(cm, q, v)
    data = cm.model.createData()
    pin.framesForwardKinematics(cm.model, data, q)
    oMh = data.oMf[cm.hand_frame]
    before, after = cm.target_state(q, v), cm.target_state(q, result.v)
    dP = after.linear_momentum(TARGET) - before.linear_momentum(TARGET)
    point = oMh.translation
    dL = after.angular_momentum(TARGET, point) - before.angular_momentum(TARGET, point)
    np.testing.assert_allclose(dP, -oMh.rotation @ result.impulse[:3], rtol=0, atol=1e-12)
    np.testing.assert_allclose(dL, -oMh.rotation @ result.impulse[3:], rtol=0, atol=1e-12)


def test_a_welded_velocity_is_left_alone(panda):
    """If the hand and the target already move as one (J v = 0), no impulse, v unchanged."""
    cm, q, v = _capture_state(panda, 5)
    J = cm.weld_jacobian(q)
    # remove the relative motion by moving the target's twist only (J's last six columns)
    v = v.copy()
    v[cm.nv_robot :] += np.linalg.solve(J[:, cm.nv_robot :], -J @ v)
    assert np.abs(J @ v).max() < 1e-13
    result = impact(cm, q, v)
    assert np.abs(result.impulse).max() < 1e-12
    assert np.abs(result.v - v).max() < 1e-13


def test_tolerances_and_ready(panda):
    cm, q, v = _capture_state(panda, 6)
    distance, speed = cm.relative_motion(q, v)
    np.testing.assert_allclose(distance, np.linalg.norm(cm.relative_pose(q).translation))
    assert 0 < distance < 0.02 and speed > 0
    assert cm.ready(q, v, CaptureTolerances(1.01 * distance, 1.01 * speed))
    assert not cm.ready(q, v, CaptureTolerances(0.99 * distance, 1.01 * speed))
    assert not cm.ready(q, v, CaptureTolerances(1.01 * distance, 0.99 * speed))
    # exactly coincident frames: distance zero
    cm0, q0, v0 = _capture_state(panda, 6, offset=False)
    assert cm0.relative_motion(q0, v0)[0] < 1e-14


# ---- after capture: one robot ---------------------------------------------------------------


def test_merged_robot_keeps_the_momentum_and_moves_as_the_welded_pair(captured):
    cm, q, v = captured
    v_plus = impact(cm, q, v).v
    merged, q_m, v_m = merge_after_capture(cm, q, v_plus)
    assert merged.payload is not None and merged.payload.mass == pytest.approx(TARGET.mass)
    assert merged.unloaded is cm.robot
    plant = Plant(merged)
    h = cm.momentum(q, v_plus)
    assert np.abs(plant.momentum(q_m, v_m) - h).max() < 1e-12 * np.abs(h).max()
    # with the same joint torques, the merged robot's ABA accelerations are those of the
    # combined model under the weld (Pinocchio's constraintDynamics, CONTACT_6D)
    model, data = cm.model, cm.model.createData()
    hand, grasp = model.frames[cm.hand_frame], model.frames[cm.grasp_frame]
    weld = pin.RigidConstraintModel(
        pin.ContactType.CONTACT_6D,
        model,
        hand.parentJoint,
        hand.placement,
        grasp.parentJoint,
        grasp.placement,
        pin.ReferenceFrame.LOCAL,
    )
    models, datas = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    models.append(weld)
    datas.append(weld.createData())
    pin.initConstraintDynamics(model, data, models, datas)
    tau = np.zeros(model.nv)
    tau[6 : cm.nv_robot] = np.random.default_rng(0).normal(size=cm.nv_robot - 6)
    settings = pin.ProximalSettings(1e-14, 0.0, 1)
    a_weld = pin.constraintDynamics(model, data, q, v_plus, tau, models, datas, settings)
    a_merged = pin.aba(merged.model, merged.model.createData(), q_m, v_m, tau[: cm.nv_robot])
    assert np.abs(a_weld[: cm.nv_robot] - a_merged).max() < 1e-10 * np.abs(a_merged).max()
    # the plant steps the merged robot with its momentum kept
    plant.reset(q_m, v_m)
    q_k, v_k = q_m, v_m
    for _ in range(20):
        q_k, v_k, _ = plant.advance(q_k, v_k, tau[6 : cm.nv_robot], 2e-3)
    assert np.abs(plant.momentum(q_k, v_k) - h).max() < 1e-12 * np.abs(h).max()
    assert np.abs(v_k - v_m).max() > 1e-4  # it did move


def test_merge_adds_to_a_payload_already_held(panda):
    held = Payload(mass=2.0, com=(0.0, 0.0, 0.05), inertia=(0.01, 0.02, 0.015, 0.0, 0.0, 0.0))
    model = held.attach(panda.model, panda.ee_frame_id)
    robot = dataclasses.replace(panda, model=model, payload=held, unloaded=panda)
    cm, q, v = _capture_state(robot, 7)
    v_plus = impact(cm, q, v).v
    merged, q_m, v_m = merge_after_capture(cm, q, v_plus)
    assert merged.payload.mass == pytest.approx(22.0)
    assert merged.unloaded is panda
    h = cm.momentum(q, v_plus)
    assert np.abs(Plant(merged).momentum(q_m, v_m) - h).max() < 1e-12 * np.abs(h).max()


# ---- bad input: one line --------------------------------------------------------------------


def test_refusals_are_one_line(panda, paper_robot):
    cm, q, v = _capture_state(panda, 8)
    cases = [
        (lambda: capture_model(paper_robot, TARGET), "free-flyer"),
        (lambda: CaptureTolerances(0.0, 0.1), "tolerance_position: must be > 0"),
        (lambda: CaptureTolerances(0.01, -1.0), "tolerance_velocity: must be > 0"),
        (lambda: CaptureTolerances(float("nan"), 0.1), "tolerance_position"),
        (lambda: merge_after_capture(cm, q, v), "after the impact"),
    ]
    for build, words in cases:
        with pytest.raises(ParameterError, match=words) as err:
            build()
        assert "\n" not in str(err.value)
