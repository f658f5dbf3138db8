"""One numba cache per installation: the compile line appears once, not again from elsewhere."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ffsm_pin.sim.compile_note import MESSAGE

ROOT = Path(__file__).resolve().parents[2]


def _run(cwd: Path, cache: Path, out: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, XDG_CACHE_HOME=str(cache), PYTHONPATH=str(ROOT))
    env.pop("NUMBA_CACHE_DIR", None)
    cmd = [sys.executable, "-m", "ffsm_pin.sim", "--case", "1", "--duration", "0.01"]
    cmd += ["--no-plots", "--no-html", "--out", str(out)]
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


@pytest.mark.slow
def test_compile_line_once_per_installation(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    first = _run(tmp_path / "a", tmp_path / "cache", tmp_path / "o1")
    assert first.returncode == 0, first.stderr
    assert MESSAGE in first.stderr  # a fresh cache: compilation really happens
    second = _run(tmp_path / "b", tmp_path / "cache", tmp_path / "o2")
    assert second.returncode == 0, second.stderr
    assert MESSAGE not in second.stderr  # another folder, the same cache
    assert any((tmp_path / "cache" / "ffsm-pin" / "numba").glob("control_*/*.nbi"))
