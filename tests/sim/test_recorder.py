"""The streaming recorder: a spilled recording equals an in-memory one bit for bit (issue 20)."""

from __future__ import annotations

import dataclasses
import gc
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ffsm_pin.control.interface import SignalLayout, SignalRow
from ffsm_pin.errors import ParameterError
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim import recorder
from ffsm_pin.sim.recorder import Recorder, Signals, write_npz
from ffsm_pin.sim.run import prepare, recording_size, simulate

WALL_CLOCK = {"wall_time_s", "steps_per_s"}


def _run(case: str, duration: float, chunk_bytes: int | None, monkeypatch, **kw):
    if chunk_bytes is not None:
        monkeypatch.setattr(recorder, "CHUNK_BYTES", chunk_bytes)
    sc = dataclasses.replace(builtin_scenario(case), duration=duration)
    return simulate(prepare(sc), **kw)  # a fresh controller: runs are not reentrant


@pytest.mark.parametrize("memory_bytes", [0, -5, 1.5, "1000", True])
def test_memory_bytes_must_be_a_positive_whole_number(memory_bytes):
    """A bad recorder chunk is refused before the run, naming the argument."""
    setup = prepare(dataclasses.replace(builtin_scenario("case1"), duration=0.01))
    with pytest.raises(ParameterError, match="memory_bytes = .*positive whole number"):
        simulate(setup, memory_bytes=memory_bytes)


@pytest.mark.parametrize("case, duration", [("case1", 0.6), ("spatial", 0.15)])
def test_spilled_recording_equals_in_memory(case, duration, monkeypatch, tmp_path):
    """Planar and spatial: every signal, the summary and trajectory.npz, chunk of 7 rows
    (``simulate``'s ``memory_bytes``)."""
    whole = _run(case, duration, None, monkeypatch)
    assert not whole.signals.spilled
    _, row_bytes = recording_size(prepare(builtin_scenario(case)))
    spilled = _run(
        case, duration, None, monkeypatch, spool_dir=tmp_path / "spool", memory_bytes=7 * row_bytes
    )
    assert spilled.signals.spilled
    assert list(spilled.signals) == list(whole.signals)
    for key in whole.signals:
        a, b = np.asarray(whole[key]), np.asarray(spilled[key])
        assert a.shape == b.shape and a.dtype == b.dtype, key
        assert np.array_equal(a, b, equal_nan=True), key
    s1, s2 = whole.summary(), spilled.summary()
    # sums over rows (effort, RMS) add the blocks of another size in another order: the last
    # bits may differ; every other value is a max, min, count or row and must be equal
    sums = {"control_effort", "rms_err_z_late"}
    for key in sums:
        assert s2[key] == pytest.approx(s1[key], rel=1e-12), key
    assert {k: v for k, v in s1.items() if k not in WALL_CLOCK | sums} == {
        k: v for k, v in s2.items() if k not in WALL_CLOCK | sums
    }
    whole.save(tmp_path / "a")
    spilled.save(tmp_path / "b")
    with np.load(tmp_path / "a/trajectory.npz") as A, np.load(tmp_path / "b/trajectory.npz") as B:
        assert A.files == B.files
        for key in A.files:
            assert A[key].shape == B[key].shape and np.array_equal(A[key], B[key], equal_nan=True)
    # the spool folder goes with the result
    spools = list((tmp_path / "spool").iterdir())
    assert len(spools) == 1
    del spilled
    gc.collect()
    assert not spools[0].exists()


def _recorder(chunk_rows: int, capacity: int = 100, **kw) -> Recorder:
    shapes = {"t": (), "x": (2, 3)}
    return Recorder(shapes, capacity, chunk_bytes=chunk_rows * 8 * 7, **kw)


def test_uncommitted_rows_are_dropped_and_a_cut_spill_is_redone(tmp_path):
    rec = _recorder(4, spool_dir=tmp_path)
    rows = []
    for k in range(11):
        rec.arrays["t"][rec.i] = k
        rec.arrays["x"][rec.i] = k * np.arange(6).reshape(2, 3)
        if k != 5:  # row 5 is written but never completed (a step that raised)
            rec.commit()
            rows.append(k)
    spool = next(tmp_path.iterdir())
    with open(spool / "x.bin", "ab") as f:  # a spill cut short by Ctrl-C left stray bytes
        f.write(b"\x00" * 20)
    sig = rec.finish()
    assert sig.spilled and len(sig["t"]) == len(rows) == 10
    assert np.array_equal(sig["t"], rows)
    assert np.array_equal(sig["x"], np.array(rows)[:, None, None] * np.arange(6).reshape(2, 3))


def test_blocks_every_and_npz_of_a_spilled_recording(tmp_path):
    rec = _recorder(3)
    for k in range(17):
        rec.arrays["t"][rec.i] = 0.1 * k
        rec.arrays["x"][rec.i] = np.sin(k + np.arange(6)).reshape(2, 3)
        rec.commit()
    sig = rec.finish()
    t, x = np.array(sig["t"]), np.array(sig["x"])
    joined = np.concatenate([b["x"] for b in sig.blocks(["x"], rows=5)])
    assert np.array_equal(joined, x)
    for step in (1, 2, 4, 16, 40):
        idx = sorted(set(range(0, 17, step)) | {16})
        assert np.array_equal(sig.every("x", step), x[idx])
    consts = Signals({"t": t, "x": x, "c": np.arange(3.0)})
    write_npz(tmp_path / "a.npz", consts)
    spilled = recorder.extend(sig, lambda b: {"y": 2 * b["t"][:, None]}, {"c": np.arange(3.0)})
    write_npz(tmp_path / "b.npz", spilled)
    with np.load(tmp_path / "a.npz") as A, np.load(tmp_path / "b.npz") as B:
        assert set(B.files) == {"t", "x", "y", "c"}
        for key in A.files:
            assert np.array_equal(A[key], B[key])
        assert np.array_equal(B["y"], 2 * t[:, None])


@pytest.mark.parametrize("chunk_rows", [3, 100], ids=["spilled", "in-memory"])
def test_packed_columns_record_a_row_in_one_copy_as_column_by_column(tmp_path, chunk_rows):
    """Keys packed side by side (a controller's SignalRow) record, in memory and spilled, the
    same rows as the same keys written one by one (in memory, views of the block); packed
    columns are NaN until written, as every column."""
    shapes = {"t": (), "x": (2, 3), "s": (), "y": (4,)}
    width = 8 * (1 + 6 + 1 + 4)
    size = {"spool_dir": tmp_path, "chunk_bytes": chunk_rows * width}
    packed = Recorder(shapes, 20, **size, packed=["s", "x", "y"])  # not the recorder's order
    plain = Recorder(shapes, 20, **size)
    block = packed.block
    assert block.shape == (packed.chunk_rows, 11) and plain.block.shape[1] == 0
    assert list(packed.arrays) == list(shapes)  # the recorder's key order is kept
    assert all(np.isnan(packed.arrays[key]).all() for key in shapes)
    for k in range(17):
        x, s, y = np.sin(k + np.arange(6)).reshape(2, 3), 0.5 * k, np.cos(k + np.arange(4))
        for rec in (packed, plain):
            rec.arrays["t"][rec.i] = 0.1 * k
        block[packed.i] = np.concatenate(([s], x.ravel(), y))
        plain.arrays["x"][plain.i], plain.arrays["s"][plain.i], plain.arrays["y"][plain.i] = x, s, y
        packed.commit()
        plain.commit()
    a, b = packed.finish(), plain.finish()
    assert a.spilled is b.spilled is (chunk_rows == 3)
    if not a.spilled:  # views of the one block
        assert all(np.shares_memory(a[key], block) for key in ("s", "x", "y"))
    assert list(a) == list(b) == list(shapes)
    for key in shapes:
        x, y = np.asarray(a[key]), np.asarray(b[key])
        assert x.shape == y.shape == (17, *shapes[key]), key
        assert x.tobytes() == y.tobytes(), key


@pytest.mark.parametrize("spill", [False, True], ids=["in-memory", "spilled"])
def test_npz_is_stored_unless_compression_is_asked_for(tmp_path, spill):
    """trajectory.npz is stored (zip members uncompressed) by default and deflated with
    ``compress=True``; both give back the same arrays."""
    import zipfile

    rec = _recorder(3 if spill else 100)
    for k in range(17):
        rec.arrays["t"][rec.i] = 0.1 * k
        rec.arrays["x"][rec.i] = np.sin(k + np.arange(6)).reshape(2, 3)
        rec.commit()
    sig = rec.finish()
    assert sig.spilled == spill
    write_npz(tmp_path / "stored.npz", sig)
    write_npz(tmp_path / "deflated.npz", sig, compress=True)
    for name, method in (("stored", zipfile.ZIP_STORED), ("deflated", zipfile.ZIP_DEFLATED)):
        with zipfile.ZipFile(tmp_path / f"{name}.npz") as zf:
            assert {i.compress_type for i in zf.infolist()} == {method}, name
    with np.load(tmp_path / "stored.npz") as A, np.load(tmp_path / "deflated.npz") as B:
        assert A.files == B.files
        for key in A.files:
            assert np.array_equal(A[key], B[key]) and np.array_equal(A[key], np.array(sig[key]))


def test_thinned_result_keeps_first_last_and_evenly_spaced_rows(monkeypatch):
    res = _run("case1", 0.5, 3000, monkeypatch)  # 501 rows, spilled
    thin = res.thinned(50)
    n = len(res["t"])
    step = -(-(n - 1) // 49)
    idx = sorted(set(range(0, n, step)) | {n - 1})
    assert len(thin["t"]) <= 51
    for key in ("t", "q", "err_z", "rho_z", "z_e_d"):
        assert np.array_equal(thin[key], np.asarray(res[key])[idx]), key
    assert thin["theta_d"] is res["theta_d"]  # constants pass through
    assert res.thinned(10_000) is res


@pytest.mark.slow
def test_ctrl_c_writes_what_was_recorded(tmp_path):
    """SIGINT mid-run: exit 130, a readable trajectory.npz and a summary that says why.

    The known-model case on its numpy reference (about 10 s of wall time for 30 s simulated;
    a scenario file with ``[controller.params] backend = "numpy"``): the progress bar redraws
    every 2 s when stderr is not a terminal, and case 1 (about 2 s on an idle machine) could
    finish before the first redraw."""
    from ffsm_pin.scenario.writer import scenario_to_toml

    out = tmp_path / "run"
    sc = builtin_scenario("known-model")
    ctrl = dataclasses.replace(sc.controller, params={"backend": "numpy"})
    (tmp_path / "slow.toml").write_text(scenario_to_toml(dataclasses.replace(sc, controller=ctrl)))
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    cmd = [sys.executable, "-m", "ffsm_pin.sim", "--scenario", str(tmp_path / "slow.toml"),
           "--duration", "30", "--no-plots", "--no-html"]  # fmt: skip
    proc = subprocess.Popen(
        [*cmd, "--out", str(out)],
        stderr=subprocess.PIPE,
        stdout=subprocess.PIPE,
        env=env,
        # a shell that started pytest in the background ignores SIGINT, and so would the child
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert proc.stderr is not None
    seen = b""
    deadline = time.monotonic() + 240
    simulated = 0.0  # the progress bar's simulated time: the loop is running (compiled)
    while simulated < 1.0:
        chunk = os.read(proc.stderr.fileno(), 4096)
        assert chunk and time.monotonic() < deadline, seen
        seen += chunk
        bars = re.findall(rb"\]\s+([0-9.]+)/30 s", seen)
        simulated = float(bars[-1]) if bars else 0.0
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err.decode()[-3000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["completed"] is False and summary["stop_cause"] == "interrupted"
    with np.load(out / "trajectory.npz") as z:
        t = z["t"]
        assert 0 < len(t) < 30001 and np.all(np.isfinite(z["q"]))
        assert summary["simulated_time"] == float(t[-1])
    assert "interrupted (Ctrl-C)" in err.decode()
    assert not any(p.name.startswith("ffsm-pin-rec-") for p in out.iterdir())
    assert Path(out / "scenario.toml").is_file()


@pytest.mark.parametrize("case", ["case1", "spatial-pose"])
def test_errors_computed_after_the_run_are_the_per_step_errors(case):
    """err_b, err_z are computed after the run from the recorded t, q_b, z_e (a block of rows
    at a time); they equal task_errors row by row, the function the loop used to call."""
    import dataclasses

    from ffsm_pin.control.kinematic import task_errors
    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.run import prepare, simulate

    sc = dataclasses.replace(builtin_scenario(case), duration=0.5)
    run = simulate(prepare(sc), record_every=7)
    ref, m3 = sc.reference, np.asarray(run["q_b"]).shape[1]
    for i in range(len(run["t"])):
        err_b, err_z = task_errors(
            ref, ref.base_attitude, run["t"][i], run["q_b"][i], run["z_e"][i], m3
        )
        np.testing.assert_allclose(run["err_b"][i], err_b, rtol=0, atol=1e-14)
        np.testing.assert_allclose(run["err_z"][i], err_z, rtol=0, atol=1e-14)


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_reaction_torque_after_the_run_is_the_models_on_every_row(case):
    """F_r, computed after the run from the recorded q_b, q, w and dw_b, equals the model's
    reaction torque of Eq. (7) (itself checked against Pinocchio in tests/model) on every
    recorded row; and dw_b is the base's angular acceleration: the forward difference of the
    recorded w_b, to O(dt) (the semi-implicit step is w_b(t + dt) = w_b(t) + dt dw_b/dt, then
    the momentum projection changes the base twist by O(dt^2): measured 1e-3 of max |dw_b|
    planar, 9e-5 spatial; the tolerance is 1e-2, which a wrong sign, index or scale fails)."""
    import dataclasses

    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.run import prepare, simulate

    sc = dataclasses.replace(builtin_scenario(case), duration=0.2)
    setup = prepare(sc)
    run = simulate(setup, record_every=1)
    model, m3, nq = setup.model, setup.model.m3, setup.robot.root.nq
    q, w, q_b, dw_b, F_r = (np.asarray(run[k]) for k in ("q", "w", "q_b", "dw_b", "F_r"))
    scale = np.max(np.abs(F_r))
    for i in range(0, len(q), 9):
        w_dot = np.zeros(w.shape[1])
        w_dot[:m3] = dw_b[i]
        qb = q_b[i, 0] if m3 == 1 else q_b[i]
        expected = model.reaction_torque(setup.theta_d, qb, q[i, nq:], w[i], w_dot)
        np.testing.assert_allclose(F_r[i], expected, rtol=1e-9, atol=1e-12 * scale)
    dt = sc.dt
    fd = (w[1:, :m3] - w[:-1, :m3]) / dt
    acc = dw_b.reshape(len(q), -1)[:-1]
    np.testing.assert_allclose(fd, acc, rtol=0, atol=1e-2 * np.max(np.abs(acc)))


class _Wrapped:
    """The paper's controller with its signals handed back another way (``how``)."""

    def __init__(self, inner, how: str):
        self.inner, self.how = inner, how
        self.signal_layout = inner.signal_layout  # its columns packed, as for the paper's

    def step(self, meas):
        u_m, signals = self.inner.step(meas)
        assert isinstance(signals, SignalRow)
        if self.how == "dict":
            return u_m, {key: np.copy(value) for key, value in signals.items()}
        layout, late = signals.layout, meas.t > 0.05
        if self.how == "new-layout":  # equal, but not the first period's layout object
            return u_m, SignalRow(signals.row, SignalLayout(layout.shapes))
        if self.how == "short":  # from t = 0.05 s a row one entry short of its layout
            return u_m, SignalRow(signals.row[:-1] if late else signals.row, layout)
        if self.how == "short-new-layout":  # the same, and another layout object
            row = signals.row[:-1] if late else signals.row
            return u_m, SignalRow(row, SignalLayout(layout.shapes) if late else layout)
        # "one-entry": a row that numpy would broadcast over the whole layout
        return u_m, SignalRow(signals.row[:1] if late else signals.row, layout)


def test_a_signal_row_records_as_the_same_signals_in_a_dict():
    """The run records a SignalRow of the controller's declared layout in one copy: every
    recorded signal equals, bit for bit, the run in which the same controller hands the same
    values back as a dict (each signal written on its own into the packed columns), and the
    run in which each period's row has a layout of its own (written signal by signal). A row
    that stops fitting its layout stops the run, with the declared layout object or another,
    one entry short or a single entry (which numpy would broadcast)."""
    sc = dataclasses.replace(builtin_scenario("case1"), duration=0.2)
    runs = {"row": simulate(prepare(sc))}
    for how in ("dict", "new-layout"):
        setup = prepare(sc)
        setup.controller = _Wrapped(setup.controller, how)
        runs[how] = simulate(setup)
    ref = runs["row"]
    assert ref.completed and "theta_d_hat" in ref.signals
    for how in ("dict", "new-layout"):
        assert runs[how].completed and list(runs[how].signals) == list(ref.signals), how
        for key in ref.signals:
            assert np.asarray(runs[how][key]).tobytes() == np.asarray(ref[key]).tobytes(), key
    for how in ("short", "short-new-layout", "one-entry"):
        setup = prepare(sc)
        setup.controller = _Wrapped(setup.controller, how)
        bad = simulate(setup)
        assert not bad.completed and bad.stop_cause == "controller", how
        assert "signals changed" in bad.stop_reason, how
        assert bad.stop_time == pytest.approx(0.051, abs=1e-9), how
        assert len(bad["t"]) == 51  # the periods before the stop
