"""``detumble_time`` (issue 40): from when on the held target's rate relative to the bus stays
below the tolerance (ffsm_pin/sim/detumble.py)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.sim.detumble import DETUMBLE_RATE, detumble_outcome, relative_rate

# relative rates per row [rad/s]: fast, slow, fast again at 0.5 s, slow from 0.6 s on
T = np.arange(10) * 0.1
SPEEDS = np.array([5, 5, 0.5, 0.5, 3, 2, 0.9, 0.5, 0.1, 0.0]) * DETUMBLE_RATE


def _rows(speeds, seed=0) -> dict[str, np.ndarray]:
    """Rows whose relative rate is ``speeds``: a random target attitude R_t, a random bus
    rate w_b, a direction d; body rates w_t = R_t^T (w_b + speed d)."""
    rng = np.random.default_rng(seed)
    n = len(speeds)
    pose, twist, w = np.zeros((n, 7)), np.zeros((n, 6)), np.zeros((n, 9))
    for i, s in enumerate(speeds):
        R = pin.exp3(rng.normal(size=3))
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        w[i, :3] = rng.normal(size=3) * 0.1
        pose[i, 3:] = pin.Quaternion(R).coeffs()  # x, y, z, w
        twist[i, 3:] = R.T @ (w[i, :3] + s * d)
    return {"w": w, "target_pose": pose, "target_twist": twist}


def test_relative_rate_is_the_rate_built_in():
    rows = _rows(SPEEDS)
    np.testing.assert_allclose(relative_rate(rows), SPEEDS, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("size", [1, 3, 4, 10])
def test_detumble_time_is_the_row_after_the_last_fast_one(size):
    """The same answer whatever the blocks (a spilled recording is read a block at a time);
    rows before the capture do not count."""
    rows = {"t": T, **_rows(SPEEDS)}

    def blocks(keys):
        for i in range(0, len(T), size):
            yield {k: rows[k][i : i + size] for k in keys}

    assert detumble_outcome(blocks, capture_time=0.0).time == pytest.approx(0.6)
    assert detumble_outcome(blocks, capture_time=None).time is None
    # from 0.65 s on every row is slow: detumbled at the first held row
    assert detumble_outcome(blocks, capture_time=0.65).time == pytest.approx(0.7)
    # a run whose last row is fast is not detumbled
    fast_end = {"t": T, **_rows(np.r_[SPEEDS[:-1], 2 * DETUMBLE_RATE])}

    def fast_blocks(keys):
        for i in range(0, len(T), size):
            yield {k: fast_end[k][i : i + size] for k in keys}

    assert detumble_outcome(fast_blocks, capture_time=0.0).time is None
    assert detumble_outcome(blocks, capture_time=0.0, rate=6 * DETUMBLE_RATE).time == 0.0
