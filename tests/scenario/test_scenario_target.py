"""``[target]`` (issue 40, first slice): its keys, defaults, refusals and the round trip."""

from __future__ import annotations

import dataclasses
import math

import pytest

from ffsm_pin.errors import ScenarioError
from ffsm_pin.scenario import CaptureSpec, TargetSpec
from ffsm_pin.scenario.file import builtin_path, builtin_scenario, scenario_from_toml
from ffsm_pin.scenario.target_spec import ApproachSpec
from ffsm_pin.scenario.writer import scenario_to_toml

REALISTIC = builtin_path("spatial-realistic").read_text()
EVERY_KEY = """
[target]
shape = "box"
size = [0.4, 0.3, 0.25]
mass = 40.0
inertia = [0.5, 0.7, 0.9, 0.01, -0.02, 0.03]
origin = "world"
position = [2.0, 0.5, -0.3]
attitude_rpy = [0.1, -0.2, 0.3]
velocity = [-0.01, 0.002, 0.0]
angular_velocity = [0.02, 0.05, 0.03]
grasp_xyz = [-0.2, 0.0, 0.05]
grasp_rpy = [0.0, 1.5707963267948966, 0.0]
"""
MINIMAL = """
[target]
size = [0.4, 0.3, 0.3]
mass = 40.0
position = [1.5, 0.0, 0.0]
"""


def with_target(table: str, base: str = REALISTIC) -> str:
    return base + table


def test_every_key_is_read():
    sc = scenario_from_toml(with_target(EVERY_KEY))
    assert sc.target == TargetSpec(
        size=(0.4, 0.3, 0.25),
        mass=40.0,
        position=(2.0, 0.5, -0.3),
        inertia=(0.5, 0.7, 0.9, 0.01, -0.02, 0.03),
        attitude_rpy=(0.1, -0.2, 0.3),
        velocity=(-0.01, 0.002, 0.0),
        angular_velocity=(0.02, 0.05, 0.03),
        grasp_xyz=(-0.2, 0.0, 0.05),
        grasp_rpy=(0.0, 1.5707963267948966, 0.0),
    )


def test_defaults():
    t = scenario_from_toml(with_target(MINIMAL)).target
    assert t is not None
    assert (t.shape, t.origin, t.inertia) == ("box", "world", None)
    zero = (0.0, 0.0, 0.0)
    assert t.attitude_rpy == t.velocity == t.angular_velocity == zero
    assert t.grasp_xyz == t.grasp_rpy == zero
    assert scenario_from_toml(REALISTIC).target is None


@pytest.mark.parametrize("table", [EVERY_KEY, MINIMAL], ids=["every-key", "minimal"])
def test_round_trip(table):
    sc = scenario_from_toml(with_target(table))
    text = scenario_to_toml(sc)
    again = scenario_from_toml(text)
    assert again.target == sc.target
    assert scenario_to_toml(again) == text


def test_text_without_a_target_is_unchanged():
    """A scenario without [target] writes no [target]: its text (and a campaign's case_hash of
    it) is what it was; with one, the table is appended after the rest."""
    sc = scenario_from_toml(with_target(EVERY_KEY))
    plain = scenario_to_toml(dataclasses.replace(sc, target=None))
    assert "[target]" not in plain
    assert "[target]" not in scenario_to_toml(builtin_scenario("spatial-realistic"))
    full = scenario_to_toml(sc)
    assert full.startswith(plain) and full[len(plain) :].startswith("\n[target]\n")


def test_builtin_target_tumbling_is_spatial_realistic_with_a_target():
    tt, sr = builtin_scenario("target-tumbling"), builtin_scenario("spatial-realistic")
    assert tt.target == TargetSpec(
        size=(0.4, 0.3, 0.3),
        mass=40.0,
        position=(1.5, 0.0, 0.0),
        origin="end-effector",
        velocity=(-0.01, 0.0, 0.0),
        angular_velocity=(0.02, 0.05, 0.03),
        grasp_xyz=(-0.2, 0.0, 0.0),
    )
    assert tt.duration == 10.0
    for field in ("robot", "initial", "reference", "controller", "performance", "actuators"):
        assert getattr(tt, field) == getattr(sr, field), field
    assert (tt.sensors, tt.dt, tt.integrator) == (sr.sensors, sr.dt, sr.integrator)


BAD = {
    "shape": ('shape = "ball"', "target.shape = 'ball' unknown; valid choices: 'box'"),
    "mass": ("mass = 0.0", "target.mass = 0.0: must be > 0"),
    "size": ("size = [0.4, -0.3, 0.3]", "target.size[1] = -0.3: a box edge must be > 0"),
    "size-length": ("size = [0.4, 0.3]", "target.size"),
    "inertia": (
        "inertia = [1.0, 1.0, 5.0, 0.0, 0.0, 0.0]",
        "target.inertia = [1.0, 1.0, 5.0, 0.0, 0.0, 0.0]: has principal moments",
    ),
    "inertia-definite": ("inertia = [1.0, 1.0, 1.0, 2.0, 0.0, 0.0]", "target.inertia"),
    "grasp": ("grasp_xyz = [0.25, 0.0, 0.0]", "target.grasp_xyz = [0.25, 0.0, 0.0] m is outside"),
    "origin": ('origin = "hand"', "valid choices: 'world', 'end-effector'"),
    "unknown": ("spin = 1.0", "target.spin: unknown key in [target]"),
    "missing": (None, "target.position"),
}


@pytest.mark.parametrize("what", list(BAD))
def test_bad_input_is_one_line_naming_the_key(what):
    line, fragment = BAD[what]
    table = MINIMAL if line is not None else MINIMAL.replace("position = [1.5, 0.0, 0.0]\n", "")
    if line is not None:
        key = line.split(" = ")[0]
        kept = [x for x in table.splitlines() if not x.startswith(f"{key} = ")]
        table = "\n".join([*kept, line, ""])
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(with_target(table))
    msg = str(info.value)
    assert "\n" not in msg and fragment in msg, msg


def test_a_planar_scenario_with_a_target_is_refused():
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(with_target(MINIMAL, builtin_path("case1").read_text()))
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("target: applies only to robot.base = 'free-flyer'")


# ------------------------------------------------------------------------------ [capture]
CAPTURE = """
[capture]
tolerance_position = 0.01
tolerance_velocity = 0.05
"""


def test_capture_keys_are_read_and_written_back():
    sc = scenario_from_toml(with_target(MINIMAL + CAPTURE + 'estimates = "true"\n'))
    assert sc.target is not None
    assert sc.target.capture == CaptureSpec(0.01, 0.05, estimates="true")
    assert scenario_from_toml(scenario_to_toml(sc)) == sc
    default = scenario_from_toml(with_target(MINIMAL + CAPTURE)).target
    assert default is not None and default.capture is not None
    assert default.capture.estimates == "unknown"
    # the detumble tolerance: its default (0.1 deg/s) is not written; another one is, and read
    assert default.capture.detumble_rate == pytest.approx(math.radians(0.1), rel=1e-15)
    assert "detumble_rate" not in scenario_to_toml(
        scenario_from_toml(with_target(MINIMAL + CAPTURE))
    )
    given = scenario_from_toml(with_target(MINIMAL + CAPTURE + "detumble_rate = 0.01\n"))
    assert given.target is not None and given.target.capture is not None
    assert given.target.capture.detumble_rate == 0.01
    assert scenario_from_toml(scenario_to_toml(given)) == given


BAD_CAPTURE = {
    "position-zero": ("tolerance_position = 0.0", "capture.tolerance_position = 0.0: must be > 0"),
    "position-negative": (
        "tolerance_position = -0.01",
        "capture.tolerance_position = -0.01: must be > 0",
    ),
    "velocity-zero": ("tolerance_velocity = 0", "capture.tolerance_velocity = 0: must be > 0"),
    "velocity-inf": ("tolerance_velocity = inf", "capture.tolerance_velocity"),
    "estimates": (
        'estimates = "exact"',
        "capture.estimates = 'exact' unknown; valid choices: 'unknown', 'perturbed', 'true'",
    ),
    "unknown": ("tolerance = 0.01", "capture.tolerance: unknown key in [capture]"),
    "detumble-zero": ("detumble_rate = 0.0", "capture.detumble_rate = 0.0: must be > 0"),
}


@pytest.mark.parametrize("what", list(BAD_CAPTURE))
def test_bad_capture_input_is_one_line_naming_the_key(what):
    line, fragment = BAD_CAPTURE[what]
    key = line.split(" = ")[0]
    kept = [x for x in CAPTURE.splitlines() if not x.startswith(f"{key} = ")]
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(with_target(MINIMAL + "\n".join([*kept, line, ""])))
    msg = str(info.value)
    assert "\n" not in msg and fragment in msg, msg


@pytest.mark.parametrize("key", ["tolerance_position", "tolerance_velocity"])
def test_a_capture_without_a_tolerance_is_refused(key):
    kept = [x for x in CAPTURE.splitlines() if not x.startswith(f"{key} = ")]
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(with_target(MINIMAL + "\n".join(kept)))
    msg = str(info.value)
    assert "\n" not in msg and f"capture.{key}: missing" in msg, msg


def test_a_capture_without_a_target_is_refused():
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(REALISTIC + CAPTURE)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("capture: needs a [target] table"), msg


# ------------------------------------------------ [capture] hand offset and [approach]
APPROACH = """
[approach]
time = 6.0
seed = 5
delay = 2

[approach.noise]
position = 1e-3
attitude = 2e-3
velocity = 1e-3
angular_velocity = 5e-4
"""


def test_hand_offset_and_approach_are_read_and_written_back():
    hand = "hand_xyz = [0.0, 0.0, 0.1]\nhand_rpy = [0.0, 0.0, 0.5]\n"
    sc = scenario_from_toml(with_target(MINIMAL + CAPTURE + hand + APPROACH))
    assert sc.target is not None and sc.target.capture is not None
    assert sc.target.capture.hand_xyz == (0.0, 0.0, 0.1)
    assert sc.target.capture.hand_rpy == (0.0, 0.0, 0.5)
    assert sc.target.approach == ApproachSpec(6.0, 5, 2, (1e-3, 2e-3, 1e-3, 5e-4))
    assert scenario_from_toml(scenario_to_toml(sc)) == sc
    # defaults: no offset (and the saved text has no hand keys), an exact sensor
    plain = scenario_from_toml(with_target(MINIMAL + CAPTURE + "[approach]\ntime = 2.0\n"))
    assert plain.target is not None and plain.target.capture is not None
    assert plain.target.capture.hand_xyz == plain.target.capture.hand_rpy == (0.0, 0.0, 0.0)
    assert plain.target.approach == ApproachSpec(2.0)
    assert "hand_xyz" not in scenario_to_toml(plain)


BAD_APPROACH = {
    "hand-count": (CAPTURE + "hand_xyz = [0.0, 0.1]\n", "capture.hand_xyz"),
    "hand-text": (CAPTURE + 'hand_rpy = [0.0, 0.0, "x"]\n', "capture.hand_rpy: expected a list of"),
    "hand-nan": (CAPTURE + "hand_xyz = [0.0, nan, 0.0]\n", "capture.hand_xyz[1]"),
    "time-zero": ("[approach]\ntime = 0.0\n", "approach.time = 0.0: must be > 0"),
    "time-missing": ("[approach]\nseed = 1\n", "approach.time: missing"),
    "delay": ("[approach]\ntime = 1.0\ndelay = -1\n", "approach.delay = -1"),
    "noise": (
        "[approach]\ntime = 1.0\n[approach.noise]\nposition = -1e-3\n",
        "approach.noise.position = -0.001",
    ),
    "noise-key": (
        "[approach]\ntime = 1.0\n[approach.noise]\nrate = 1e-3\n",
        "approach.noise.rate: unknown key in [approach.noise]",
    ),
    "unknown": ("[approach]\ntime = 1.0\nhorizon = 2\n", "approach.horizon: unknown key"),
}


@pytest.mark.parametrize("what", list(BAD_APPROACH))
def test_bad_hand_or_approach_input_is_one_line_naming_the_key(what):
    table, fragment = BAD_APPROACH[what]
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(with_target(MINIMAL + table))
    msg = str(info.value)
    assert "\n" not in msg and fragment in msg, msg


def test_an_approach_needs_a_target_and_the_position_task():
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(REALISTIC + "[approach]\ntime = 1.0\n")
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("approach: needs a [target] table"), msg
    pose = builtin_path("spatial-pose").read_text()
    with pytest.raises(ScenarioError) as info:
        scenario_from_toml(with_target(MINIMAL + "[approach]\ntime = 1.0\n", pose))
    msg = str(info.value)
    assert "\n" not in msg and "reference.task = 'pose'" in msg and "'position'" in msg, msg


def test_builtin_capture_approach_is_capture_with_the_box_farther():
    approach, capture = builtin_scenario("capture-approach"), builtin_scenario("capture")
    assert approach.target is not None and capture.target is not None
    assert approach.target.approach is not None and capture.target.approach is None
    assert approach.target.capture == capture.target.capture
    assert dataclasses.replace(approach.target, position=capture.target.position,
                               approach=None) == capture.target  # fmt: skip
    for key in ("robot", "initial", "reference", "controller", "sensors", "actuators", "dt"):
        assert getattr(approach, key) == getattr(capture, key), key
