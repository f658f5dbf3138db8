"""The run loop's torque check (:func:`ffsm_pin.sim.loop.checked_torque`): its shortcut for
the usual reply (a float64 array of the right shape) passes the same torques and refuses the
same ones as its full checks."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.sim.loop import ControllerFault, checked_torque


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
