"""The first compilation of the spatial period on two processes (control/fast_spatial.py,
``compile_in_parallel``): the argument types survive the trip to the second process, a warm
cache starts no process, and a run from an empty numba cache (kernels compiled in two
processes) gives bitwise the trajectory of a run from a warm cache."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import typeof

from ffsm_pin.control import fast_spatial

REPO = Path(__file__).resolve().parents[2]


def test_array_types_survive_the_trip_to_the_second_process():
    """numba types a read-only array differently from a writeable one, and pickling drops
    the flag: the second process must see the types this one passes."""
    ro = np.arange(6.0)
    ro.setflags(write=False)
    view = np.zeros((4, 5))[:, 2:]  # non-contiguous: layout 'A'
    args = (ro, np.ones(3), (7, True, ro), view)
    back = fast_spatial._restore_flags(pickle.loads(pickle.dumps(fast_spatial._with_flags(args))))
    assert typeof(back[0]) == typeof(ro) and not back[0].flags.writeable
    assert typeof(back[1]) == typeof(args[1]) and back[1].flags.writeable
    assert back[2][:2] == (7, True) and typeof(back[2][2]) == typeof(ro)
    np.testing.assert_array_equal(back[3], view)  # values kept (layout becomes 'C')


def test_a_warm_cache_starts_no_second_process(monkeypatch):
    started = []
    monkeypatch.setattr(fast_spatial, "_cold", lambda dispatcher: False)
    monkeypatch.setattr(subprocess, "Popen", lambda *a, **k: started.append(a))
    fast_spatial.compile_in_parallel(*([None] * 9))
    assert started == []


@pytest.mark.slow
def test_a_run_from_an_empty_cache_equals_a_run_from_a_warm_one(tmp_path):
    """About 40 s: everything compiled anew, the complex kinematic law here and the real
    kernels in the second process."""

    def run(cache: Path, out: str) -> dict:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(REPO)}
        proc = subprocess.run(
            [sys.executable, "-m", "ffsm_pin.sim", "--case", "spatial", "--duration", "0.2",
             "--no-plots", "--no-html", "--quiet", "--out", out],
            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        return dict(np.load(tmp_path / out / "trajectory.npz"))

    cache = tmp_path / "numba-cache"
    first = run(cache, "cold")
    assert any(cache.rglob("*velocity_terms*.nbi"))  # the second process's kernels are cached
    second = run(cache, "warm")
    assert first.keys() == second.keys()
    for key in first:
        np.testing.assert_array_equal(first[key], second[key], err_msg=key)
