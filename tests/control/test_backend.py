"""The backend choice (ffsm_pin/control/backend.py): numba is a dependency, loaded by
``import ffsm_pin``, so the compiled period is always there; ``"numpy"`` is the readable
reference a user asks for, and an unknown name is refused naming the choices."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from ffsm_pin.control.backend import BACKENDS, choose_backend, numba_available
from ffsm_pin.errors import ParameterError

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]


def test_numba_is_a_dependency_that_import_ffsm_pin_loads():
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    assert any(re.match(r"numba\b", d) for d in deps)
    code = "import sys, ffsm_pin; print('numba' in sys.modules)"
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    )
    assert proc.stdout.strip() == "True"
    assert numba_available() is True


@pytest.mark.parametrize(
    ("asked", "runs"), [("auto", "numba"), ("numba", "numba"), ("numpy", "numpy")]
)
def test_choose_backend(asked, runs):
    assert asked in BACKENDS
    assert choose_backend(asked) == runs


def test_an_unknown_backend_is_refused_naming_the_choices():
    with pytest.raises(ParameterError, match="valid choices: 'auto', 'numba', 'numpy'"):
        choose_backend("cuda")
