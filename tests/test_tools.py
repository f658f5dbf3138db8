"""The developer tools under ``tools/`` run: ``rounding_sensitivity`` moves exactly one joint
angle of the plant's initial state by one unit in the last place, and reports the runs."""

from __future__ import annotations

import dataclasses
import importlib.util
import platform
from pathlib import Path

import numpy as np
import pytest

from ffsm_pin import prepare
from ffsm_pin.scenario.file import builtin_scenario

ROOT = Path(__file__).resolve().parents[1]


def _tool(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "tools" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_rounding_sensitivity_moves_one_joint_by_one_ulp(capsys):
    tool = _tool("rounding_sensitivity")
    scenario = dataclasses.replace(builtin_scenario("case1"), duration=0.02)
    ref, moved = tool._run(scenario), tool._run(scenario, joint=1)
    q_ref, q_moved = np.asarray(ref.signals["q"])[0], np.asarray(moved.signals["q"])[0]
    changed = np.flatnonzero(q_ref != q_moved)
    nq_root = prepare(scenario).robot.root.nq  # q = (root, q_m)
    assert changed.tolist() == [nq_root + 1]
    assert q_moved[changed[0]] == np.nextafter(q_ref[changed[0]], np.inf)
    assert tool.main(["1", "--duration", "0.02", "--joints", "0"]) == 0
    out = capsys.readouterr().out
    assert "as shipped: completed" in out and "joint 0 + 1 ulp" in out


@pytest.mark.skipif(
    platform.machine().lower() not in ("x86_64", "amd64"), reason="x86 OpenBLAS kernel names"
)
def test_rounding_sensitivity_reruns_the_case_on_another_openblas_kernel(capsys):
    """``--blas`` reruns the case unchanged in a new process with OpenBLAS forced to another
    kernel: the saved run is the case's (same rows), and over 0.05 s it stays within rounding
    of this process's run (what another CPU does to the shipped trajectory)."""
    tool = _tool("rounding_sensitivity")
    assert tool.main(["1", "--duration", "0.05", "--joints", "--blas", "Sandybridge"]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "OpenBLAS Sandybridge" in ln]
    assert len(line) == 1 and line[0].endswith("completed")
    parting = dict(zip(*[iter(line[0].split()[2:-1])] * 2, strict=True))
    assert set(parting) == set(tool.SIGNALS)
    assert all(float(v) < 1e-12 for v in parting.values())
