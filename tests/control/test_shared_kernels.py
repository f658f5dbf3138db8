"""The compiled funnel transformation shared by the planar and spatial periods equals the numpy
reference (control/funnel.py): psi, Phi inside, and the same exit index outside."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.control._shared_kernels import funnel_terms, pack_funnel
from ffsm_pin.control.funnel import Funnel, FunnelExit, FunnelParams

PARAMS = FunnelParams((2.0, 0.5, 0.3), (0.1, 0.2, 0.01), (1.5, 0.05, 0.7), (1.0, 0.3, 0.55))


@pytest.mark.parametrize("dtype", [float, complex])
def test_inside_equals_the_numpy_funnel(dtype, rng):
    funnel = Funnel(PARAMS, np.array([0.1, -0.05, 0.02]))
    table = pack_funnel(funnel)
    for t in (0.0, 0.7, 3.0):
        lo, hi = funnel.bounds(t)
        e = (lo + (hi - lo) * rng.uniform(0.05, 0.95, 3)).astype(dtype)
        if dtype is complex:
            e = e + 1e-20j * rng.normal(size=3)  # a complex step
        ref = funnel.evaluate(t, e)
        psi, Phi, idx = funnel_terms(table, t, e, False)
        assert idx == -1
        np.testing.assert_allclose(psi, ref.psi, rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(Phi, ref.Phi, rtol=1e-14, atol=1e-15)
        if dtype is complex:  # the imaginary parts carry the derivative: they must agree too
            np.testing.assert_allclose(psi.imag, ref.psi.imag, rtol=1e-12, atol=1e-40)


def test_exit_index_is_the_reference_one():
    """Two components beyond their bounds: the one farther beyond is reported (before this
    kernel was shared, the planar period reported the first of the two)."""
    funnel = Funnel(PARAMS, np.array([0.1, 0.1, 0.1]))
    lo, hi = funnel.bounds(0.0)
    e = np.array([1.01 * hi[0], 0.0, 3.0 * hi[2]])  # component 2 is farther out
    with pytest.raises(FunnelExit) as exc:
        funnel.evaluate(0.0, e)
    _, _, idx = funnel_terms(pack_funnel(funnel), 0.0, e, False)
    assert idx == exc.value.index == 2


def test_identity_passes_the_error_through():
    funnel = Funnel(PARAMS, np.ones(3))
    e = np.array([5.0, -7.0, 0.3])  # far outside: no refusal without prescribed performance
    psi, Phi, idx = funnel_terms(pack_funnel(funnel), 1.0, e, True)
    assert idx == -1
    np.testing.assert_array_equal(psi, e)
    np.testing.assert_array_equal(Phi, np.ones(3))
