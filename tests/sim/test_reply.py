"""What the run loop accepts of a controller's reply (:mod:`ffsm_pin.sim.reply`): the torque
check's shortcut for the usual reply (a float64 array of the right shape) passes the same
torques and refuses the same ones as its full checks, and the reply's one-pass check hands
back what the split and the check one after the other do."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.control.interface import SignalLayout, SignalRow, split_reply
from ffsm_pin.sim.reply import ControllerFault, checked_reply, checked_torque


def test_a_float_array_of_the_right_shape_passes_as_it_is():
    u = np.array([1.0, -2.0, 3.5])
    assert checked_torque(u, 3) is u


@pytest.mark.parametrize(
    "u",
    [
        np.array([1, 2, 3]),  # integers: converted
        np.array([1.0, 2.0, 3.0], dtype=">f8"),  # float64 of the other byte order
        np.array([1.0, 2.0, 3.0], dtype=np.float32),
        [1.0, 2.0, 3.0],
    ],
)
def test_other_real_torques_are_converted_to_float64(u):
    out = checked_torque(u, 3)
    assert out.dtype == np.float64 and out.shape == (3,)
    np.testing.assert_array_equal(out, np.asarray(u, dtype=float))


@pytest.mark.parametrize(
    ("u", "says"),
    [
        (np.array([1.0, np.nan, 3.0]), "non-finite"),
        (np.array([1.0, np.inf, 3.0]), "non-finite"),
        (np.array([1.0, 2.0]), "shape (2,)"),
        (np.zeros((3, 1)), "shape (3, 1)"),
        (np.array([1.0, 2.0, 3.0]) + 0j, "dtype complex128"),
        (np.array([True, False, True]), "dtype bool"),
    ],
)
def test_a_bad_torque_is_a_controller_fault_that_says_why(u, says):
    with pytest.raises(ControllerFault, match=says.replace("(", r"\(").replace(")", r"\)")):
        checked_torque(u, 3)


_ROW = SignalRow(np.zeros(2), SignalLayout({"sigma_min": (), "damping": ()}))
_BAD_TORQUES = [
    np.array([1.0, np.nan, 3.0]),
    np.array([1.0, -np.inf, 3.0]),
    np.array([1.0, 2.0]),
    np.zeros((3, 1)),
    np.array([1.0, 2.0, 3.0]) + 0j,
    np.array([True, False, True]),
]


def test_the_packages_usual_reply_is_handed_back_as_it_is():
    reply = (np.array([1.0, -2.0, 3.5]), _ROW)
    assert checked_reply(reply, 3) is reply


@pytest.mark.parametrize(
    "reply",
    [
        np.array([1.0, -2.0, 3.5]),  # the torque alone
        [1.0, -2.0, 3.5],
        (np.array([1.0, -2.0, 3.5]), {"x": 1.0}),  # the signals as a dict
        (np.array([1, 2, 3]), _ROW),  # integers beside a row: converted
        (np.array([1.0, 2.0, 3.0], dtype=np.float32), {}),
        (np.array([1.0, 2.0, 3.0], dtype=">f8"), _ROW),
    ],
)
def test_every_other_reply_is_split_and_checked_as_before(reply):
    u, signals = checked_reply(reply, 3)
    expected = split_reply(reply)
    assert signals is expected.signals
    np.testing.assert_array_equal(u, checked_torque(expected.u_m, 3))
    assert u.dtype == np.float64


@pytest.mark.parametrize("u", _BAD_TORQUES)
@pytest.mark.parametrize("signals", [_ROW, {"x": 1.0}, None])
def test_a_bad_torque_in_any_reply_is_the_same_controller_fault(u, signals):
    reply = u if signals is None else (u, signals)
    with pytest.raises(ControllerFault) as direct:
        checked_torque(u, 3)
    with pytest.raises(ControllerFault) as via_reply:
        checked_reply(reply, 3)
    assert str(via_reply.value) == str(direct.value)
