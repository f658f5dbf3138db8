"""``[robot.payload]`` (issue 41): a rigid body held by the end effector. The plant's model is
Pinocchio's model of the URDF with that body written in by hand; momentum is still conserved;
the estimates leave an unknown payload out (the truth keeps it); bad input is one line."""

from __future__ import annotations

import dataclasses
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.errors import InertiaError, ParameterError, ScenarioError
from ffsm_pin.model import State, make_model
from ffsm_pin.robot import Payload, load_robot, resolve_urdf
from ffsm_pin.scenario.file import builtin_path, scenario_from_toml
from ffsm_pin.scenario.spec import Estimates
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.setup import prepare

PAYLOAD = Payload(
    mass=3.0, com=(0.05, -0.02, 0.04), inertia=(0.04, 0.05, 0.03, 0.002, -0.001, 0.003)
)
ROOTS = {"planar": pin.JointModelPlanar, "free-flyer": pin.JointModelFreeFlyer}


def _by_hand(urdf: str, payload: Payload) -> str:
    """The URDF with the payload as the inertial of the end-effector frame's child link (the
    ``ee`` fixed joint's child: its frame is the end-effector frame)."""
    root = ET.fromstring(resolve_urdf(urdf).read_text())
    joint = next(j for j in root.findall("joint") if j.get("name") == "ee")
    child = joint.find("child").get("link")
    link = next(x for x in root.findall("link") if x.get("name") == child)
    assert link.find("inertial") is None
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", xyz=" ".join(map(repr, payload.com)), rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=repr(payload.mass))
    keys = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
    ET.SubElement(
        inertial, "inertia", {k: repr(v) for k, v in zip(keys, payload.inertia, strict=True)}
    )
    return ET.tostring(root, encoding="unicode")


@pytest.mark.parametrize(
    ("urdf", "base"), [("ffsm_planar5.urdf", "planar"), ("spatial9.urdf", "free-flyer")]
)
def test_the_plant_is_pinocchios_model_with_the_body_written_in(urdf, base):
    robot = load_robot(urdf, "ee", base=base, payload=PAYLOAD)
    hand = pin.buildModelFromXML(_by_hand(urdf, PAYLOAD), ROOTS[base]())
    hand.gravity.setZero()  # free floating, as the loader's model
    data, hand_data = robot.model.createData(), hand.createData()
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = pin.randomConfiguration(hand, -np.ones(hand.nq), np.ones(hand.nq))
        v = rng.normal(size=hand.nv)
        M = pin.crba(robot.model, data, q)
        M_hand = pin.crba(hand, hand_data, q)
        np.testing.assert_allclose(np.triu(M), np.triu(M_hand), rtol=1e-12, atol=1e-12)
        h = pin.rnea(robot.model, data, q, v, np.zeros(hand.nv))
        np.testing.assert_allclose(
            h, pin.rnea(hand, hand_data, q, v, np.zeros(hand.nv)), atol=1e-10
        )
    assert robot.geometry.total_mass == pytest.approx(
        robot.unloaded.geometry.total_mass + PAYLOAD.mass
    )
    assert robot.unloaded.payload is None and robot.estimated is robot.unloaded
    known = load_robot(urdf, "ee", base=base, payload=dataclasses.replace(PAYLOAD, known=True))
    assert known.estimated is known


def _case1_with(payload_toml: str, initial: str = "true"):
    text = builtin_path("case1").read_text()
    text = text.replace("[initial]", f"[robot.payload]\n{payload_toml}\n\n[initial]", 1)
    sc = scenario_from_toml(text)
    est = Estimates(initial=initial, spread=0.3, seed=2)
    return dataclasses.replace(sc, controller=dataclasses.replace(sc.controller, estimates=est))


def test_momentum_is_conserved_with_a_payload_and_the_truth_keeps_it():
    # on the end effector's line (the collinear layout of case 1 stays)
    sc = dataclasses.replace(
        _case1_with("mass = 5.0\ncom = [0.1, 0.0, 0.0]\ninertia = [0.02, 0.02, 0.02, 0, 0, 0]"),
        duration=1.0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(sc)
        result = simulate(setup)
    assert result.completed
    assert result.summary()["drift_P"] < 1e-11 and result.summary()["drift_L"] < 1e-11
    unloaded = make_model(setup.robot.unloaded)
    truth_without = unloaded.theta_d
    assert not np.allclose(setup.theta_d, truth_without)  # the plant's truth has the payload
    est = setup.controller.context.estimates
    # an unknown payload: the "true" estimates are the robot's without it
    np.testing.assert_allclose(est[1], truth_without, rtol=1e-12)
    st = State(setup.robot.unloaded).update(setup.q0, setup.v0)
    np.testing.assert_allclose(est[0][:2], st.com_velocity, rtol=1e-12, atol=1e-15)


def test_a_known_payload_is_in_the_estimates():
    sc = _case1_with("mass = 5.0\ninertia = [0.02, 0.02, 0.02, 0, 0, 0]\nknown = true")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(sc)
    est = setup.controller.context.estimates
    np.testing.assert_array_equal(est[1], setup.theta_d)
    perturbed = _case1_with(
        "mass = 5.0\ninertia = [0.02, 0.02, 0.02, 0, 0, 0]", initial="perturbed"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        drawn = prepare(perturbed)
    masses = [b["mass"] for b in drawn.drawn_estimates["bodies"]]
    true_without = [float(drawn.robot.unloaded.model.inertias[j].mass) for j in range(1, 6)]
    assert all(abs(m / t - 1) <= 0.3 for m, t in zip(masses, true_without, strict=True))


def test_the_payload_round_trips_through_the_scenario_file():
    sc = _case1_with("mass = 5.0\ncom = [0.1, 0.0, 0.0]\ninertia = [0.02, 0.02, 0.02, 0, 0, 0]")
    again = scenario_from_toml(scenario_to_toml(sc))
    assert (
        again.robot.payload
        == sc.robot.payload
        == Payload(5.0, (0.02, 0.02, 0.02, 0, 0, 0), (0.1, 0, 0))
    )


@pytest.mark.parametrize(
    ("table", "expected"),
    [
        (
            "mass = 5.0\ninertia = [0.01, 0.01, 0.05, 0, 0, 0]",
            "robot.payload.inertia = [0.01, 0.01, 0.05, 0.0, 0.0, 0.0]: has principal moments",
        ),
        ("mass = 5.0\ninertia = [0.01, 0.01, -0.01, 0, 0, 0]", "robot.payload.inertia"),
        (
            "mass = 0.0\ninertia = [0.01, 0.01, 0.01, 0, 0, 0]",
            "robot.payload.mass = 0.0: must be > 0",
        ),
        ("mass = 5.0", "robot.payload.inertia: missing"),
        ("mass = 5.0\ninertia = [0.01, 0.01, 0.01, 0, 0, 0]\nknwn = true", "did you mean 'known'"),
        (
            "mass = 5.0\ninertia = [0.01, 0.01, 0.01, 0, 0, 0]\ncom = [0.1, 0.2]",
            "robot.payload.com: 2 values, expected 3",
        ),
    ],
)
def test_bad_payloads_are_one_line(table, expected):
    with pytest.raises(ScenarioError) as err:
        _case1_with(table)
    assert expected in str(err.value) and "\n" not in str(err.value)


def test_the_payload_class_refuses_what_is_not_a_body():
    with pytest.raises(InertiaError, match="triangle inequality"):
        Payload(1.0, (1.0, 1.0, 3.0, 0.0, 0.0, 0.0))
    with pytest.raises(ParameterError, match="unknown key 'size'"):
        Payload.from_mapping({"mass": 1.0, "inertia": (1.0,) * 3 + (0.0,) * 3, "size": 1})
