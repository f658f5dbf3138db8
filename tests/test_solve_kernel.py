"""``ffsm_pin._array_kernels.solve`` calls LAPACK's dgesv itself, without numba's
``np.linalg.solve`` wrapper (whose shape-message code costs a first run about 1.6 s of
compiling): it must give bitwise numba's ``np.linalg.solve`` (the same LAPACK call on the same
data) for every layout the kernels pass, and raise the same errors. Also, the first run of a
spatial case compiles the dynamic level's mass matrix and Y_M in this process before the
kinematic law (``fast_spatial.compile_beside_law``) with exactly the types the period then asks
for, so that the second process finds them in the cache."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from ffsm_pin import _array_kernels
from ffsm_pin._array_kernels import solve

REPO = Path(__file__).resolve().parents[1]


@njit(cache=False)
def numba_solve(A, b):
    """numba's own ``np.linalg.solve``, the reference."""
    return np.linalg.solve(A, b)


def test_the_lapack_declaration_is_found():
    """This numba has the private names: ``solve`` is the direct call, not the fallback."""
    gesv, pivot = _array_kernels._lapack_gesv()
    assert gesv is not None
    from numba.np.linalg import F_INT_nptype

    assert pivot is F_INT_nptype


@pytest.mark.parametrize("n", [1, 2, 3, 5, 7, 10, 23])
def test_bitwise_numbas_solve(n, rng):
    """Random systems (some ill-conditioned), C-ordered, Fortran-ordered and strided
    matrices: the same bits as numba's np.linalg.solve, and the solution of A x = b."""
    for k in range(40):
        A = rng.standard_normal((n, n))
        if k % 4 == 3:  # ill-conditioned: nearly dependent rows
            A[-1] = A[0] + 1e-9 * rng.standard_normal(n)
        b = rng.standard_normal(n)
        for A_in in (A, np.asfortranarray(A), np.repeat(A, 2, axis=1)[:, ::2]):
            x = solve(A_in, b)
            ref = numba_solve(np.ascontiguousarray(A_in), b)
            assert x.dtype == ref.dtype and x.shape == (n,)
            assert np.array_equal(x.view(np.int64), ref.view(np.int64))
        if k % 4 != 3:
            np.testing.assert_allclose(A @ x, b, rtol=0, atol=1e-9 * (1 + abs(x).max()))


def test_the_same_errors_as_numbas_solve():
    """A singular matrix and entries not finite: numba's LinAlgError and message."""
    cases = [
        (np.zeros((3, 3)), np.ones(3)),
        (np.array([[1.0, 2.0], [2.0, 4.0]]), np.ones(2)),
        (np.diag([1.0, np.nan, 1.0]), np.ones(3)),
        (np.eye(3), np.array([1.0, np.inf, 0.0])),
    ]
    for A, b in cases:
        with pytest.raises(np.linalg.LinAlgError) as ref:
            numba_solve(A, b)
        with pytest.raises(np.linalg.LinAlgError) as got:
            solve(A, b)
        assert str(got.value) == str(ref.value)


def test_inputs_are_not_modified(rng):
    A, b = rng.standard_normal((4, 4)), rng.standard_normal(4)
    A0, b0 = A.copy(), b.copy()
    solve(A, b)
    assert np.array_equal(A, A0) and np.array_equal(b, b0)


BESIDE_LAW = """
import sys
from ffsm_pin.control import _first_compile, fast_spatial as F
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.run import prepare
import dataclasses

def one_process(module, child_args, dispatchers, compile_here):
    compile_here()  # no second process: the period compiles its real kernels here

_first_compile.compile_in_parallel = one_process
seen = {}
original = F.compile_beside_law

def real(name):
    return {s for s in getattr(F, name).signatures if str(s[0].dtype) == "float64"}

def beside(meas, state):
    before = {name: real(name) for name in ("add_ym", "mass_matrix_by_sums")}
    original(meas, state)
    for name in before:
        seen[name] = real(name)
        assert seen[name] - before[name], (name, "nothing compiled beside the law")

F.compile_beside_law = beside
prepare(dataclasses.replace(builtin_scenario("spatial"), duration=0.01))
assert seen, "compile_beside_law was not called"
for name, beside_law in seen.items():  # the period adds no real signature (complex ones: the law)
    assert real(name) == beside_law, (name, beside_law, real(name))
print("ok")
"""


@pytest.mark.slow
def test_the_spatial_first_run_compiles_what_the_period_asks_for(tmp_path):
    """30-90 s (one spatial compilation in one process, from an empty cache): after
    ``compile_beside_law``, compiling the period (its dynamic level here) adds no real
    signature to ``mass_matrix_by_sums`` (M-hat) or ``add_ym`` (Y_M of Eq. 49): those
    compiled beside the law are the ones the period calls (a literal ``False`` for
    ``add_ym``'s ``base_only``); a mismatch would compile them twice."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "NUMBA_CACHE_DIR": str(tmp_path)}
    proc = subprocess.run([sys.executable, "-c", BESIDE_LAW], capture_output=True, text=True,
                          env=env, timeout=900)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip().endswith("ok")
