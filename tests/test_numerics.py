"""ffsm_pin._numerics: a run's summary says which BLAS kernels and library versions computed
it (docs/REPRODUCTION.md, "Reproducing the shipped numbers on another CPU")."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pinocchio as pin
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(platform.machine() != "x86_64", reason="OpenBLAS core types of x86-64")
def test_a_runs_summary_names_the_kernels_openblas_used(tmp_path):
    """OPENBLAS_CORETYPE forces other kernels than this CPU's: the summary follows them (so it
    reports what ran, not what the machine would pick), and names the libraries' versions."""
    env = {**os.environ, "OPENBLAS_CORETYPE": "Sandybridge"}  # AVX: runs on any x86-64 CI
    done = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", "--case", "case1", "--duration", "0.02",
         "--no-plots", "--no-html", "--quiet", "--out", str(tmp_path)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    entries = summary["blas"].split("; ")
    assert all(e.startswith("openblas ") for e in entries), summary["blas"]
    assert all(e.endswith(" Sandybridge") for e in entries), summary["blas"]
    for name, version in (("numpy", np.__version__), ("pinocchio", pin.__version__),
                          ("numba", numba.__version__)):  # fmt: skip
        assert f"{name} {version}" in summary["versions"]
