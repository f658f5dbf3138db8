"""A grasp of the ``capture`` case's box set up by hand, shared by the tests of the controller
after capture (test_capture_controller.py) and of the truths after it (test_held_truth.py)."""

from __future__ import annotations

import dataclasses
import warnings
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.scenario.spec import Estimates
from ffsm_pin.scenario.target_spec import CaptureSpec
from ffsm_pin.sim.capture_run import CaptureMotion, held_body_estimate
from ffsm_pin.sim.measurement import Sensor
from ffsm_pin.sim.plant import Plant
from ffsm_pin.sim.setup import prepare
from ffsm_pin.sim.target import TargetState


def capture_scenario(estimates: str = "true", initial: str = "true", duration: float = 0.1):
    """The ``capture`` case with ``[capture] estimates``, ``[controller.estimates] initial``
    and the duration given."""
    sc = builtin_scenario("capture")
    capture = dataclasses.replace(sc.target.capture, estimates=estimates)
    controller = dataclasses.replace(sc.controller, estimates=Estimates(initial=initial))
    return dataclasses.replace(
        sc, duration=duration, controller=controller,
        target=dataclasses.replace(sc.target, capture=capture),
    )  # fmt: skip


class Grasp(NamedTuple):
    """The setup, the capture hook after the grasp, the merged robot, the robot's q and its v
    after the impact, and robot and box's (P, L) before it."""

    setup: object
    motion: CaptureMotion
    merged: object
    q: np.ndarray
    v: np.ndarray
    before: np.ndarray


def grasp_at_half_a_second(seed: int, *, truths: bool, estimates: str = "true") -> Grasp:
    """The capture case's robot (exact estimates) grasping its box at t = 0.5 s, the arm's
    joints turning at random rates (``seed``), the grasp frames 4 mm and 1.5 degrees apart,
    the box moving; ``truths``: the hook is given the run (the truths after the grasp);
    ``estimates``: the hook's ``[capture] estimates``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(capture_scenario())
    robot, target = setup.robot, setup.target
    rng = np.random.default_rng(seed)
    q, v = setup.q0.copy(), setup.v0.copy()
    v[6:] = 0.05 * rng.standard_normal(robot.model.nv - 6)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    offset = pin.SE3(pin.exp3(np.array([0.01, -0.02, 0.015])), np.array([0.002, -0.001, 0.003]))
    pose = data.oMf[robot.ee_frame_id] * offset * target.grasp.inverse()
    state = TargetState(pose, np.array([0.004, -0.003, 0.002]), np.array([0.03, 0.01, -0.02]))
    motion = CaptureMotion(
        target, state, robot, CaptureSpec(0.01, 0.1, estimates=estimates),
        perturb=lambda held: held_body_estimate(held, setup), setup=setup if truths else None,
    )  # fmt: skip
    cap = motion.capture
    before = cap.momentum(*cap.joint_state(q, v, state))
    plant = Plant(robot, integrator="rk4")
    plant.reset(q, v)
    sensor = Sensor(robot, setup.model, full_model=False)
    new_plant, _, v_new = motion.at_period(0.5, q, v, plant, sensor)
    return Grasp(setup, motion, new_plant.robot, q, v_new, before)


def merged_measurement(grasp: Grasp):
    """What a sensor on the merged robot measures just after the grasp (t = 0.5 s): the state
    after the impact, with the merged robot's true M and C w."""
    ctx = grasp.setup.controller.context
    return Sensor(grasp.merged, ctx.model, full_model=True).measure(0.5, grasp.q, grasp.v)


def replies_after_capture(grasp: Grasp, make, event) -> dict:
    """backend -> the reply of ``step`` (torques, signals) of a controller made by
    ``make(ctx, backend=...)`` and told ``event``, at :func:`merged_measurement`; on the
    compiled period and on the numpy reference."""
    ctx, meas = grasp.setup.controller.context, merged_measurement(grasp)
    replies = {}
    for backend in ("numba", "numpy"):
        ctrl = make(ctx, backend=backend)
        ctrl.on_capture(event)
        replies[backend] = ctrl.step(meas)
    return replies
