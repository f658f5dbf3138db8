"""The developer tools under ``tools/`` run: ``rounding_sensitivity`` moves exactly one joint
angle of the plant's initial state by one unit in the last place, and reports the runs."""

from __future__ import annotations

import dataclasses
import importlib.util
import os
import platform
import subprocess
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


def test_rounding_sensitivity_reruns_the_case_with_another_source(capsys, tmp_path):
    """``--source DIR`` reruns the case in a new process with DIR's package (checked: the run
    says which package it imported): this checkout's own package gives the same trajectory
    bit for bit (every parting 0), and a folder without a package is refused."""
    tool = _tool("rounding_sensitivity")
    assert tool.main(["1", "--duration", "0.05", "--joints", "--source", str(ROOT)]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "source " in ln]
    assert len(line) == 1 and line[0].endswith("completed")
    parting = dict(zip(*[iter(line[0].split()[2:-1])] * 2, strict=True))
    assert parting == dict.fromkeys(tool.SIGNALS, "0")
    with pytest.raises(SystemExit, match="no ffsm_pin package"):
        tool.main(["1", "--duration", "0.05", "--joints", "--source", str(tmp_path)])


def _fake_package(folder: Path, marker: str) -> Path:
    """A folder holding an ``ffsm_pin`` package that is only ``marker``."""
    (folder / "ffsm_pin").mkdir(parents=True)
    (folder / "ffsm_pin" / "__init__.py").write_text(f"MARKER = {marker!r}\n")
    return folder


def test_compare_runs_records_the_package_it_was_asked_for(tmp_path):
    """``python -m`` puts the current folder first: run from a checkout's root, a PYTHONPATH
    naming another checkout is shadowed, and a "before" recording would silently be the
    "after" one. ``record`` finds the package its runs import, refuses the shadowed
    PYTHONPATH with what to use instead, and ``--source`` runs the folder asked for."""
    tool = _tool("compare_runs")
    other = _fake_package(tmp_path / "other", "other").resolve()
    env = {**os.environ, "PYTHONPATH": str(other)}
    here = _fake_package(tmp_path / "here", "here").resolve()  # the folder the command runs in
    shadowed = tool.imported_package(here, env)
    assert shadowed == here / "ffsm_pin"
    with pytest.raises(tool.SourceError, match=r"--source .*other") as info:
        tool.check_asked_for(shadowed, None, env["PYTHONPATH"])
    assert str(other / "ffsm_pin") in str(info.value) and str(shadowed) in str(info.value)
    cwd, env = tool.run_environment(other)
    assert tool.imported_package(cwd, env) == other / "ffsm_pin"
    tool.check_asked_for(other / "ffsm_pin", other, env["PYTHONPATH"])  # asked for: no error


def test_compare_runs_exports_a_revision_and_refuses_an_unknown_one(tmp_path, capsys):
    """``--rev`` runs ``git archive`` of the revision: its files as committed; an unknown
    revision is one ``error:`` line and exit 2, nothing recorded."""
    tool = _tool("compare_runs")
    head = subprocess.run(["git", "-C", str(ROOT), "show", "HEAD:ffsm_pin/__init__.py"],
                          capture_output=True, check=False)  # fmt: skip
    if head.returncode != 0:
        pytest.skip("not a git checkout")
    source = tool.export_revision("HEAD", tmp_path / "head")
    assert (source / "ffsm_pin" / "__init__.py").read_bytes() == head.stdout
    assert len(tool.resolve_revision("HEAD")) == 40
    out = tmp_path / "rec"
    assert tool.main(["record", str(out), "--rev", "no-such-revision", "--cases", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: git rev-parse no-such-revision")
    assert not out.exists()


def test_compare_runs_record_runs_the_source_it_names(tmp_path, monkeypatch):
    """``record --source DIR`` runs DIR's package (a stand-in whose ``python -m
    ffsm_pin.sim`` notes which package ran it and exits as told), names it in
    ``source.txt``, keeps a run that stopped early (exit 3) and fails on any other exit,
    passes ``extra_env`` to the runs unless this process sets the variable; a folder
    without a package is refused before anything runs."""
    tool = _tool("compare_runs")
    fake = _fake_package(tmp_path / "fake", "fake")
    (fake / "ffsm_pin" / "sim").mkdir()
    (fake / "ffsm_pin" / "sim" / "__init__.py").write_text("")
    (fake / "ffsm_pin" / "sim" / "__main__.py").write_text(
        "import os, pathlib, sys, ffsm_pin\n"
        "out = pathlib.Path(sys.argv[sys.argv.index('--out') + 1])\n"
        "out.mkdir(parents=True)\n"
        "(out / 'ran.txt').write_text(ffsm_pin.MARKER)\n"
        "sys.exit(int(os.environ.get('FAKE_EXIT', '0')))\n"
    )
    out = tmp_path / "rec"
    assert tool.record(out, ["1", "spatial"], 1, 0.1, source=fake) == 0
    assert (out / "source.txt").read_text().strip() == str((fake / "ffsm_pin").resolve())
    assert [(out / c / "ran.txt").read_text() for c in ("1", "spatial")] == ["fake", "fake"]
    # extra_env reaches the runs (exit 1: a failure) without touching this process
    assert (
        tool.record(tmp_path / "x", ["1"], 1, 0.1, source=fake, extra_env={"FAKE_EXIT": "1"}) == 1
    )
    assert "FAKE_EXIT" not in os.environ
    monkeypatch.setenv("FAKE_EXIT", "3")  # a run that stops early is a result
    assert tool.record(tmp_path / "stopped", ["1"], 1, 0.1, source=fake) == 0
    # a variable this process has wins over extra_env (a NUMBA_CACHE_DIR you set)
    assert (
        tool.record(tmp_path / "y", ["1"], 1, 0.1, source=fake, extra_env={"FAKE_EXIT": "1"}) == 0
    )
    monkeypatch.setenv("FAKE_EXIT", "1")
    assert tool.record(tmp_path / "failed", ["1"], 1, 0.1, source=fake) == 1
    (tmp_path / "empty").mkdir()
    with pytest.raises(tool.SourceError, match="ffsm_pin"):
        tool.record(tmp_path / "none", ["1"], 1, 0.1, source=tmp_path / "empty")
    assert not (tmp_path / "none").exists()
