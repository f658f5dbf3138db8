"""The compiled torque-free step (``ffsm_pin/sim/_target_kernels.py``) against the numpy
reference of :func:`ffsm_pin.sim.target.torque_free_step` (the closed-form and independent
integration checks of tests/sim/test_target.py run the default, compiled, path)."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.sim.target import Target, TargetState, torque_free_step


def _body(seed: int) -> tuple[Target, TargetState]:
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    moments = np.sort(rng.uniform(1.0, 3.0, 3))
    moments[2] = min(moments[2], 0.99 * (moments[0] + moments[1]))  # (triangle inequality)
    target = Target(
        float(rng.uniform(5, 50)), Q @ np.diag(moments) @ Q.T, com=tuple(0.1 * rng.normal(size=3))
    )
    state = TargetState.from_rpy(
        rng.normal(size=3), rng.normal(size=3), 0.1 * rng.normal(size=3), rng.normal(size=3)
    )
    return target, state


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_compiled_step_is_the_reference_to_rounding(seed):
    """2000 steps of 2 ms (4 s) from the same state: attitude, position and body rates of the
    two versions within 1e-12 (relative to the rates' size) at every step, with and without
    a momentum to keep; the world angular momentum of each within 1e-12 of the start."""
    target, state = _body(seed)
    for momentum in (None, state.angular_momentum(target)):
        a = b = state
        for _ in range(2000):
            a = torque_free_step(target, a, 0.002, momentum, compiled=True)
            b = torque_free_step(target, b, 0.002, momentum, compiled=False)
            scale = np.abs(b.angular_velocity).max()
            assert np.abs(a.pose.rotation - b.pose.rotation).max() < 1e-12
            assert np.abs(a.pose.translation - b.pose.translation).max() < 1e-12
            assert np.abs(a.angular_velocity - b.angular_velocity).max() < 1e-12 * scale
        L0 = state.angular_momentum(target)
        for end in (a, b):
            assert np.abs(end.angular_momentum(target) - L0).max() < 1e-12 * np.abs(L0).max()
