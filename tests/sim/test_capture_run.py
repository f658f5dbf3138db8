"""Capture in the loop (issue 40, second slice): the built-in 'capture' case and the hook
:class:`~ffsm_pin.sim.capture_run.CaptureMotion` on its own.

The capture happens at the first control period at which the recorded true state meets the
tolerances, and not before; at the impact the whole system's momentum is kept to rounding
and the post-impact velocities are Pinocchio's impulse dynamics'; after it the weld holds in
the recorded rows; the system's momentum is kept to rounding over the whole run (the plant
keeps the robot's CoM on its line, as the target's); a campaign over the case writes the
capture columns."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pinocchio as pin
import pyarrow.parquet as pq
import pytest

from ffsm_pin.scenario.file import builtin_scenario, scenario_from_toml
from ffsm_pin.scenario.target_spec import CaptureSpec
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.capture_run import CAPTURE_KEYS, CaptureMotion
from ffsm_pin.sim.impact import capture_model, impact_pinocchio
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.measurement import Sensor
from ffsm_pin.sim.plant import Plant
from ffsm_pin.sim.setup import prepare
from ffsm_pin.sim.target import TargetState

DURATION = 3.6  # [s]: the case captures at about 3.06 s


@pytest.fixture(scope="module")
def run():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(dataclasses.replace(builtin_scenario("capture"), duration=DURATION))
    return setup, simulate(setup)


def _states(result, rows):
    pose, twist = result["target_pose"], result["target_twist"]
    return [TargetState(pin.XYZQUATToSE3(pose[i]), twist[i, :3], twist[i, 3:]) for i in rows]


def _combined(cap, result, i, state):
    return cap.joint_state(result["q"][i], result["v"][i], state)


def test_capture_happens_when_the_tolerances_are_met_and_not_before(run):
    setup, result = run
    out, tol = result.capture, setup.scenario.target.capture
    summary = result.summary()
    assert out.captured and 1.0 < out.time < DURATION and result.completed
    assert summary["funnel_ok_b"] and summary["funnel_ok_z"]
    assert {k: summary[k] for k in CAPTURE_KEYS} == out.summary()
    assert len(summary["impact_impulse"]) == 6 and summary["impact_energy_lost"] > 0
    t = result["t"]
    i_c = int(np.flatnonzero(t == out.time)[0])  # every period is recorded
    cap = capture_model(setup.robot, setup.target)
    for i, state in zip(range(i_c), _states(result, range(i_c)), strict=True):
        distance, speed = cap.relative_motion(*_combined(cap, result, i, state))
        assert not (distance <= tol.tolerance_position and speed <= tol.tolerance_velocity), i
    # the row at capture: q and the target's pose are those the condition was checked on
    # (the impact changes velocities only)
    (state,) = _states(result, [i_c])
    distance, _ = cap.relative_motion(*_combined(cap, result, i_c, state))
    assert distance == pytest.approx(out.distance, abs=1e-12)
    assert distance <= tol.tolerance_position and out.relative_speed <= tol.tolerance_velocity
    # the period before missed by the distance: the box closes at 1 cm/s, 20 um a period
    (before,) = _states(result, [i_c - 1])
    distance_before, _ = cap.relative_motion(*_combined(cap, result, i_c - 1, before))
    assert tol.tolerance_position < distance_before < tol.tolerance_position + 1e-4


def test_the_weld_holds_after_the_impact(run):
    """The recorded rows after capture: the two grasp frames' relative twist zero to rounding
    and their relative pose the one at capture (the held target's recorded state is computed
    from the merged robot's; the weld is checked on the combined model)."""
    setup, result = run
    i_c = int(np.flatnonzero(result["t"] == result.capture.time)[0])
    cap = capture_model(setup.robot, setup.target)
    rows = range(i_c, len(result["t"]), 25)
    pose0 = None
    for i, state in zip(rows, _states(result, rows), strict=True):
        q, v = _combined(cap, result, i, state)
        scale = np.abs(v).max()
        assert np.abs(cap.relative_twist(q, v)).max() < 1e-12 * scale, i
        pose = cap.relative_pose(q)
        pose0 = pose if pose0 is None else pose0
        assert np.abs((pose0.actInv(pose)).homogeneous - np.eye(4)).max() < 1e-12, i


def test_the_whole_systems_momentum_over_the_run(run):
    """P and L of robot and target (before the capture), of the merged robot (after): kept to
    rounding over the whole run, the impact included. Before the capture L depends on where
    the two CoMs are (L = L_r + L_t + mu (c_r - c_t) x (v_r - v_t), mu the reduced mass): both
    are on their straight lines to rounding, the robot's by the plant's position projection
    (Pinocchio's CoM of the recorded q), the target's by its own (its recorded pose)."""
    setup, result = run
    t, P, L = result["t"], result["P"], result["L"]
    i_c = int(np.flatnonzero(t == result.capture.time)[0])
    assert np.abs(P - P[0]).max() < 1e-14 * max(1.0, np.abs(P[0]).max())  # P0 = 0.4 kg m/s
    assert np.abs(L - L[0]).max() < 1e-12 * np.linalg.norm(L[0])  # (measured 2e-14)
    model = setup.robot.model
    data = model.createData()
    m_r, m_t = pin.computeTotalMass(model), setup.target.mass
    rows = np.r_[np.arange(0, i_c, 10), i_c]  # (the row at capture: after the impact)
    c_r = np.array([pin.centerOfMass(model, data, result["q"][i]).copy() for i in rows])
    v_t = result["target_twist"][0, :3]  # both CoM velocities are constant until capture
    assert np.abs(result["target_twist"][:i_c, :3] - v_t).max() == 0.0
    v_r = (P[0] - m_t * v_t) / m_r
    scale = 1.0 + np.abs(c_r[0]).max()  # [m]
    assert np.abs(c_r - c_r[0] - np.outer(t[rows] - t[0], v_r)).max() < 1e-14 * scale
    c_t = np.array([s.com_position(setup.target) for s in _states(result, rows)])
    assert np.abs(c_t - c_t[0] - np.outer(t[rows] - t[0], v_t)).max() < 1e-14 * scale


def test_the_targets_drift_is_that_of_the_free_target(run):
    """``target_drift_*`` cover the free target's rows only (before the capture): its own P
    and L are kept to rounding there, while over the held rows the hand changes them (the
    same rows with the held ones: many orders larger)."""
    from ffsm_pin.sim.target_run import target_momenta, target_summary

    setup, result = run
    summary = result.summary()
    tg = setup.target
    P, L = target_momenta(
        tg.mass, np.array(tg.inertia), np.array(tg.com),
        result["target_pose"][:1], result["target_twist"][:1],
    )  # fmt: skip
    assert summary["target_drift_P"] < 1e-12 * np.linalg.norm(P[0])
    assert summary["target_drift_L"] < 1e-12 * np.linalg.norm(L[0])
    every = target_summary(setup.target, result.signals_blocks)  # no capture given: every row
    assert every["target_drift_P"] > 1e6 * max(summary["target_drift_P"], 1e-16)


@pytest.mark.parametrize("estimates", ["unknown", "true"])
def test_the_hook_at_capture(run, estimates):
    """CaptureMotion.at_period on a state within the tolerances: the robot's velocity after
    it and the held target's are those of Pinocchio's impulse dynamics, the new plant holds
    the combined model's momentum before the impact (to rounding), the recorded impulse is
    Pinocchio's; one plant step later the weld holds. With "true" the sensor is the merged
    robot's (a controller measuring M and h sees the box), with "unknown" it is unchanged."""
    setup, _ = run
    robot, target = setup.robot, setup.target
    rng = np.random.default_rng(4)
    q = setup.q0.copy()
    v = setup.v0.copy()
    v[6:] = 0.05 * rng.standard_normal(robot.model.nv - 6)  # the arm moving
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    hand = data.oMf[robot.ee_frame_id]
    offset = pin.SE3(pin.exp3(np.array([0.01, -0.02, 0.015])), np.array([0.002, -0.001, 0.003]))
    pose = hand * offset * target.grasp.inverse()  # the grasp frame 4 mm and 1.5 deg away
    state = TargetState(pose, np.array([0.004, -0.003, 0.002]), np.array([0.03, 0.01, -0.02]))
    spec = CaptureSpec(0.01, 0.1, estimates=estimates)
    motion = CaptureMotion(target, state, robot, spec)
    plant = Plant(robot, integrator="rk4")
    plant.reset(q, v)
    sensor = Sensor(robot, setup.model, full_model=True)
    cap = motion.capture
    qc, vc = cap.joint_state(q, v, state)
    reference = impact_pinocchio(cap, qc, vc)
    new_plant, new_sensor, v_new = motion.at_period(0.5, q, v, plant, sensor)
    assert new_plant is not plant and motion.outcome.captured and motion.outcome.time == 0.5
    nv = robot.model.nv
    assert np.abs(v_new - reference.v[:nv]).max() < 1e-10 * np.abs(reference.v).max()
    held = cap.target_state(qc, reference.v)
    assert np.allclose(motion.state.velocity, held.velocity, rtol=0, atol=1e-12)
    assert np.allclose(motion.state.angular_velocity, held.angular_velocity, rtol=0, atol=1e-12)
    assert np.abs(np.array(motion.outcome.impulse) - reference.impulse).max() < 1e-10 * max(
        1.0, np.abs(reference.impulse).max()
    )
    h_before = cap.momentum(qc, vc)
    h_after = new_plant.momentum(q, v_new)
    assert np.abs(h_after - h_before).max() < 1e-12 * np.abs(h_before).max()
    assert (new_sensor is sensor) == (estimates == "unknown")
    if estimates == "true":
        assert new_sensor.robot is new_plant.robot
    # one plant step on: the held target moves with the hand
    q1, v1, _ = new_plant.advance(q, v_new, np.zeros(robot.n_joints), 0.002, 1)
    new_plant.project(q1, v1)
    motion.at_period(0.502, q1, v1, new_plant, new_sensor)
    q1c, v1c = cap.joint_state(q1, v1, motion.state)
    assert np.abs(cap.relative_twist(q1c, v1c)).max() < 1e-12 * np.abs(v1c).max()
    assert np.abs(cap.momentum(q1c, v1c) - h_before).max() < 1e-12 * np.abs(h_before).max()


def test_a_campaign_over_the_capture_case_writes_the_capture_columns(tmp_path):
    """The 'capture' case (nominal: 1 cm) and a 2 cm position tolerance run through the
    campaign's case runner and results table: results.parquet has the capture columns, typed;
    the nominal row's equal to its scenario run on its own; the wider tolerance captures
    earlier."""
    from ffsm_pin.sweep.campaign import load_campaign
    from ffsm_pin.sweep.cases import expand
    from ffsm_pin.sweep.engine import run_case
    from ffsm_pin.sweep.table import ResultsTable

    path = tmp_path / "campaign.toml"
    path.write_text(
        '[campaign]\nname = "capture-tolerance"\nscenario = "capture"\nseed = 1\n'
        f"duration = {DURATION}\n\n"
        '[[vary]]\nkey = "capture.tolerance_position"\nvalues = [0.02]\n',
        encoding="utf-8",
    )
    campaign = load_campaign(path)
    cases = expand(campaign)
    assert len(cases) == 2
    table = ResultsTable(tmp_path / "results.parquet", campaign.columns)
    for case in cases:
        table.add(case, run_case(case.scenario_toml))
    got = pq.read_table(tmp_path / "results.parquet")
    assert got.schema.field("captured").type == "bool"
    assert got.schema.field("impact_impulse").type.value_type == "double"
    rows = sorted(got.to_pylist(), key=lambda r: r["case"])
    assert [r["nominal"] for r in rows] == [True, False]
    assert all(r["captured"] is True for r in rows)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        own = simulate(prepare(scenario_from_toml(cases[0].scenario_toml))).summary()
    for key in CAPTURE_KEYS:
        assert rows[0][key] == own[key], key
    assert rows[1]["capture_time"] < rows[0]["capture_time"]


def test_the_saved_scenario_keeps_the_capture(run):
    """The run folder's scenario.toml holds [capture]."""
    setup, _ = run
    again = scenario_from_toml(scenario_to_toml(setup.scenario))
    assert again.target == setup.scenario.target and again.target.capture is not None


def test_the_replay_marks_the_capture_instant(run, tmp_path):
    """An orange sphere at the hand's recorded position at capture, hidden in the still
    picture and at the first frame, shown from the capture's frame on."""
    import base64
    import re

    from ffsm_pin.sim.replay import write_replay_html

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import umsgpack

    setup, result = run
    fps = 2
    html = write_replay_html(setup.robot, result, tmp_path / "r.html", fps=fps).read_text()
    found = re.findall(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html)
    cmds = [umsgpack.unpackb(base64.b64decode(b)) for b in found]
    path = "/meshcat/ffsm/capture_point"
    objects = {c["path"]: c["object"] for c in cmds if c["type"] == "set_object"}
    assert objects[path]["geometries"][0]["type"] == "SphereGeometry"
    i_c = int(np.flatnonzero(result["t"] == result.capture.time)[0])
    (place,) = [c["matrix"] for c in cmds if c["type"] == "set_transform" and c["path"] == path]
    assert np.allclose(np.reshape(place, (4, 4)).T[:3, 3], result["z_e"][i_c, :3], atol=1e-6)
    hidden = [c for c in cmds if c["type"] == "set_property" and c["path"] == path]
    assert [(c["property"], c["value"]) for c in hidden] == [("visible", False)]
    anim = next(c for c in cmds if c["type"] == "set_animation")
    clip = next(a["clip"] for a in anim["animations"] if a["path"] == path)
    (track,) = clip["tracks"]
    assert track["name"] == ".visible"
    times = [k["time"] for k in track["keys"]]
    assert [k["value"] for k in track["keys"]] == [False, True]
    assert times == [0, round(result.capture.time * fps)]
