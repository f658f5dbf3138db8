"""The true parameters after a capture (issue 40, ``ffsm_pin/sim/held_truth.py``): the merged
robot's theta_z, theta_d, theta_b, the summary's final estimate errors against them, and the
diagnostic e of Eq. (54) with the merged robot's M.

Capture exists for free-flyer robots only (docs/capture.md), so the checks are spatial."""

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

from ffsm_pin.control.lu_jia import LuJiaController
from ffsm_pin.model import make_model
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.held_truth import HELD_TRUTH_KEYS, momenta_holding
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.setup import prepare


@pytest.fixture(scope="module")
def grasp():
    """The capture case's robot grasping its box at t = 0.5 s (capture_grasp.py), its hook
    given the run (the truths after the grasp)."""
    return grasp_at_half_a_second(7, truths=True)


def test_the_truth_after_a_capture_is_the_merged_robots(grasp):
    """theta_d and the V_k of the truth after the grasp equal those of a reduced model built
    from the merged robot itself (the box a payload of the hand; 1e-12 relative); v_0 and
    A_0 are the whole system's CoM velocity and angular momentum about its CoM, equal to
    robot and free target's before the impact (Pinocchio's centroidal momentum of the two
    bodies, kept by the impact) to 1e-12 relative; both differ from the robot's own."""
    setup, motion, merged, _, _, before = grasp
    truth = motion.truth
    assert truth is not None
    direct = make_model(merged)
    m2, m3 = direct.m2, direct.m3
    scale = np.abs(direct.theta_d).max()
    assert np.abs(truth.theta_d - direct.theta_d).max() < 1e-12 * scale
    V = np.asarray(direct.true_theta_z(np.zeros(m2)))[m2:]
    assert np.abs(truth.theta_z[m2:] - V).max() < 1e-12 * np.abs(V).max()
    assert np.array_equal(truth.theta_b[m3:], truth.theta_d)
    mass = sum(inertia.mass for inertia in merged.model.inertias)  # (the universe's: 0)
    P, L = before[:3], before[3:]
    assert np.abs(truth.theta_z[:m2] - P / mass).max() < 1e-12 * np.abs(P / mass).max()
    assert np.abs(truth.theta_b[:m3] - L).max() < 1e-12 * np.abs(L).max()
    # the box moves theta_d by far more than rounding: the robot's truth is not the merged one
    assert np.abs(truth.theta_d - setup.theta_d).max() > 1e-3 * scale
    event = motion.event
    assert event is not None and np.array_equal(event.theta_d_true, truth.theta_d)


def test_eq54_e_after_the_hook_uses_the_merged_robot_on_both_backends(grasp):
    """After the hook lu-jia's e of Eq. (54) is taken with the merged robot's theta_d on the
    numpy reference and the compiled period alike (the kernel's copy updated): both agree,
    and differ from a controller told the body but not the new truth."""
    event = grasp.motion.event
    replies = replies_after_capture(grasp, LuJiaController, event)
    e = {backend: np.asarray(reply[1]["e"]) for backend, reply in replies.items()}
    stale = LuJiaController(grasp.setup.controller.context, backend="numba")
    stale.on_capture(dataclasses.replace(event, theta_d_true=None))
    e_stale = np.asarray(stale.step(merged_measurement(grasp))[1]["e"])
    scale = np.abs(e["numpy"]).max()
    np.testing.assert_allclose(e["numba"], e["numpy"], rtol=0, atol=1e-9 * scale)
    assert np.abs(e_stale - e["numpy"]).max() > 1e-3 * scale


def test_a_run_records_the_truth_after_the_capture_and_judges_its_estimates_by_it():
    """The capture case with "true" and exact initial estimates, cut after its grasp: the run's
    signals carry theta_*_captured (the capture hook's), the summary's final errors are the
    last estimates against them, and at the grasp the estimates jump by what the truth jumps
    (the body's increment, within the adaptation's one-period step)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = simulate(prepare(capture_scenario(duration=3.3)))
    summary, s = result.summary(), result.signals
    assert summary["captured"]
    for key in HELD_TRUTH_KEYS:
        assert key in s
    for name in ("theta_z", "theta_d"):
        err = np.linalg.norm(s[f"{name}_hat"][-1] - s[f"{name}_captured"])
        assert summary[f"final_{name}_error"] == pytest.approx(err, rel=1e-12)
        assert err != pytest.approx(np.linalg.norm(s[f"{name}_hat"][-1] - s[name]), rel=1e-3)
    i = int(np.searchsorted(s["t"], summary["capture_time"]))
    jump = s["theta_d_hat"][i] - s["theta_d_hat"][i - 1]
    truth_jump = s["theta_d_captured"] - s["theta_d"]
    drift = np.abs(s["theta_d_hat"][i - 1] - s["theta_d_hat"][i - 2]).max()
    assert np.abs(jump - truth_jump).max() < 10 * drift + 1e-9 * np.abs(truth_jump).max()


def test_true_estimates_get_the_systems_momenta_after_the_impact(grasp):
    """With "true" the event carries v_0 and A_0 of the whole system just after the impact
    (robot and box's before it, by Pinocchio), and the hook puts them in the heads of
    theta_z-hat and theta_b-hat (1e-12 relative); the tails are the body's increment."""
    setup, motion, merged, _, _, before = grasp
    ctx = setup.controller.context
    ctrl = LuJiaController(ctx, backend="numpy")
    event = motion.event
    assert event.momenta is not None
    ctrl.on_capture(event)
    m2, m3 = ctx.m2, ctx.m3
    mass = sum(inertia.mass for inertia in merged.model.inertias)
    P, L = before[:3], before[3:]
    assert np.abs(ctrl.law.theta_z[:m2] - P / mass).max() < 1e-12 * np.abs(P / mass).max()
    assert np.abs(ctrl.law.theta_b[:m3] - L).max() < 1e-12 * np.abs(L).max()
    unknown = dataclasses.replace(event, estimates="unknown", held=None, momenta=None)
    ctrl2 = LuJiaController(ctx, backend="numpy")
    heads = ctrl2.law.theta_z[:m2].copy(), ctrl2.law.theta_b[:m3].copy()
    ctrl2.on_capture(unknown)
    assert np.array_equal(ctrl2.law.theta_z[:m2], heads[0])
    assert np.array_equal(ctrl2.law.theta_b[:m3], heads[1])


def test_perturbed_estimates_get_the_momenta_of_the_drawn_body_in_the_hand(grasp):
    """With "perturbed" the event's v_0 and A_0 are the whole system's with the drawn body in
    the hand instead of the true one: from the truth's (P, L about the CoM) by taking the true
    body's momentum out and the drawn body's in (each I_b times the hand's twist, moved to the
    world origin; the CoM moved by the masses), 1e-12 relative; with the true body the same
    function gives the truth's momenta."""
    setup, motion, merged, q, v, _ = grasp
    truth = motion.truth
    robot = setup.robot
    v0, A0 = momenta_holding(robot, motion.held, q, v)
    assert np.abs(v0 - truth.momenta[0]).max() < 1e-12 * np.abs(v0).max()
    assert np.abs(A0 - truth.momenta[1]).max() < 1e-12 * np.abs(A0).max()

    drawn = grasp_at_half_a_second(7, truths=True, estimates="perturbed")
    event = drawn.motion.event
    assert event is not None and event.momenta is not None and event.held is not None
    assert abs(event.held.mass - motion.held.mass) > 1e-3 * motion.held.mass  # (drawn)
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, drawn.q, drawn.v)
    fid = robot.ee_frame_id
    pin.updateFramePlacements(robot.model, data)
    oMf = data.oMf[fid]
    twist = pin.getFrameVelocity(robot.model, data, fid, pin.LOCAL)
    mass = sum(inertia.mass for inertia in drawn.merged.model.inertias)
    P_true = mass * drawn.motion.truth.momenta[0]
    c_true = pin.centerOfMass(drawn.merged.model, drawn.merged.model.createData(), drawn.q)
    L_origin = drawn.motion.truth.momenta[1] + np.cross(c_true, P_true)
    P, L, m, mc = P_true.copy(), L_origin.copy(), mass, mass * c_true
    for body, sign in ((drawn.motion.held, -1.0), (event.held, 1.0)):
        h = oMf.act(body * twist)  # the body's momentum at the world origin, world axes
        P, L = P + sign * h.linear, L + sign * h.angular
        m, mc = m + sign * body.mass, mc + sign * body.mass * (oMf * body.lever)
    v0_want, A0_want = P / m, L - np.cross(mc / m, P)
    assert np.abs(event.momenta[0] - v0_want).max() < 1e-12 * np.abs(v0_want).max()
    assert np.abs(event.momenta[1] - A0_want).max() < 1e-12 * np.abs(A0_want).max()
    assert np.abs(A0_want - drawn.motion.truth.momenta[1]).max() > 1e-6 * np.abs(A0_want).max()


def test_the_estimation_figure_measures_against_the_truth_of_each_row():
    """The figure's truth per row: the robot's before the grasp, the merged robot's from it on;
    a run without a capture the robot's on every row."""
    from ffsm_pin.sim.figures import truth_rows

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = simulate(prepare(capture_scenario(duration=3.2)))
    t, t_c = np.asarray(result["t"]), result.capture.time
    rows = truth_rows(result, "theta_d")
    assert np.array_equal(rows[t < t_c], np.broadcast_to(result["theta_d"], rows[t < t_c].shape))
    after = rows[t >= t_c]
    assert len(after) and np.array_equal(
        after, np.broadcast_to(result["theta_d_captured"], after.shape)
    )
    plain = simulate(prepare(dataclasses.replace(builtin_scenario("spatial"), duration=0.05)))
    rows = truth_rows(plain, "theta_z")
    assert np.array_equal(rows, np.broadcast_to(plain["theta_z"], rows.shape))
