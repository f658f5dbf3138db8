"""The built-in 'spatial-realistic' case: what its file claims holds (a realistic bus, the
arm's torque limits, the feasibility numbers of its attitude error), the paper's controller
keeps both funnels for the whole run, and a free base (gjm-ct) leaves the attitude funnel."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ffsm_pin.model import State
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.run import prepare, simulate

SC = builtin_scenario("spatial-realistic")


def test_the_satellite_and_the_world_are_realistic():
    sat = SC.robot.satellite
    density = sat.mass / np.prod(sat.size) / 1000.0  # [t/m^3]
    assert 0.3 <= density <= 1.5 and sat.mass >= 200.0
    cube = sat.mass * sat.size[0] ** 2 / 6  # uniform cube
    assert np.allclose(sat.inertia[:3], cube, rtol=0.1) and not any(sat.inertia[3:])
    assert SC.actuators.torque_limit == "urdf"
    assert {k for k, v in SC.sensors.noise if np.any(v)} == {
        "joints", "joint_rates", "base_attitude", "base_rate", "ee_pose", "ee_velocity"
    }  # fmt: skip
    assert SC.controller.estimates.initial == "perturbed" and SC.controller.estimates.spread > 0


def test_the_feasibility_argument_of_the_file():
    """Singular values of H_bb^-1 H_bm at the start (0.076, 0.043, 0.0094 rad/rad), and the
    initial error: 0.5 degree about the strongest direction u_1."""
    setup = prepare(SC)
    st = State(setup.robot).update(setup.q0, setup.v0)
    U, S, _ = np.linalg.svd(np.linalg.solve(st.H_bb, st.H_bm))
    np.testing.assert_allclose(S, (0.076, 0.043, 0.0094), rtol=0.02)
    s0 = np.asarray(SC.initial.base_pose[3:])
    angle = 4 * np.arctan(np.linalg.norm(s0))
    assert np.degrees(angle) == pytest.approx(0.5, rel=1e-4)
    assert abs(s0 @ U[:, 0]) / np.linalg.norm(s0) == pytest.approx(1.0, abs=1e-6)
    # the joint motion it costs along u_1, and along the weakest direction
    assert angle / S[0] == pytest.approx(0.11, abs=0.01)
    assert angle / S[2] == pytest.approx(0.9, abs=0.05)


@pytest.mark.parametrize("kind, kept_b", [("lu-jia", True), ("gjm-ct", False)])
def test_who_keeps_which_funnel(kind, kept_b):
    sc = dataclasses.replace(SC, controller=dataclasses.replace(SC.controller, type=kind))
    res = simulate(prepare(sc))
    s = res.summary()
    assert res.completed, res.stop_reason
    assert s["funnel_ok_z"] and s["funnel_ok_b"] == kept_b
    assert s["saturation_fraction"] == 0.0  # within the Panda's own limits
    assert s["drift_P"] < 1e-9 and s["drift_L"] < 1e-9
    if not kept_b:  # the base, left free, turns by about half a degree under the circle
        assert np.degrees(s["max_base_excursion"]) == pytest.approx(0.46, abs=0.03)
