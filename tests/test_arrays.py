"""Small array helpers (``ffsm_pin/_arrays.py``)."""

from __future__ import annotations

import numpy as np

from ffsm_pin._arrays import cross3


def test_cross3_is_numpys_cross_bit_for_bit():
    """On 10^4 random pairs over ten decades each component: the same bits as np.cross."""
    rng = np.random.default_rng(0)
    for _ in range(10_000):
        a = rng.normal(size=3) * 10.0 ** rng.uniform(-5, 5, 3)
        b = rng.normal(size=3) * 10.0 ** rng.uniform(-5, 5, 3)
        assert np.cross(a, b).tobytes() == cross3(a, b).tobytes()
