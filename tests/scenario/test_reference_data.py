"""References from data: ``ee_file`` / ``ee_samples`` (C2 spline) and ``ee_waypoints``
(rest-to-rest quintics), docs/cli.md "References from data" (issue 21)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from ffsm_pin.control.reference_kernels import piecewise, reference_arrays, reference_at
from ffsm_pin.errors import ParameterError, ScenarioError
from ffsm_pin.scenario.file import builtin_path, builtin_scenario, load_scenario, scenario_from_toml
from ffsm_pin.scenario.spec import Reference
from ffsm_pin.scenario.trajectory import ReferenceData
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.run import Sensor, prepare, simulate

H = 1e-20  # complex step


def _spline_data(seed: int = 0) -> ReferenceData:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.2, 1.0, 12))
    z = rng.normal(size=(12, 3))
    return ReferenceData(tuple(t), tuple(map(tuple, z)))


def _waypoints() -> ReferenceData:
    t = (0.0, 2.0, 5.0, 5.5)
    z = ((0.0, 0.0, 0.0), (1.0, -2.0, 0.3), (0.5, 1.0, -0.2), (0.4, 1.1, -0.1))
    return ReferenceData(t, z, "waypoints")


# ----------------------------------------------------------------- the interpolants
def test_spline_is_scipys_cubic_spline_and_holds_its_ends():
    data = _spline_data()
    pp = data.polynomial()
    t, z = np.array(data.times), np.array(data.values)
    ref = CubicSpline(t, z, axis=0)  # not-a-knot, as documented
    ts = np.linspace(t[0], t[-1], 301)[:-1]
    for order in (0, 1, 2):
        np.testing.assert_allclose(pp.sample(ts, order), ref(ts, order), rtol=1e-10, atol=1e-10)
    # outside the data: the end values held, at rest
    np.testing.assert_allclose(pp.sample(np.array([t[0] - 3.0]), 0)[0], z[0], atol=1e-12)
    np.testing.assert_allclose(pp.sample(np.array([t[-1], t[-1] + 9.0]), 0), [z[-1]] * 2, atol=1e-9)
    np.testing.assert_array_equal(pp.sample(np.array([t[0] - 1.0, t[-1] + 1.0]), 1), 0.0)


def test_waypoints_are_rest_to_rest_and_twice_continuous():
    data = _waypoints()
    pp = data.polynomial()
    t, z = np.array(data.times), np.array(data.values)
    np.testing.assert_allclose(pp.sample(t, 0), z, atol=1e-12)
    for order in (1, 2):  # velocity and acceleration vanish at every waypoint
        np.testing.assert_allclose(pp.sample(t, order), 0.0, atol=1e-9)
    # continuity of value, rate and acceleration across every waypoint (both sides)
    eps = 1e-7
    for order in (0, 1, 2):
        left, right = pp.sample(t - eps, order), pp.sample(t + eps, order)
        np.testing.assert_allclose(left, right, atol=1e-5)
    # the closed form of a rest-to-rest quintic: peak rate 15 d / (8 T) at the middle
    mid = pp.sample(np.array([1.0]), 1)[0]
    np.testing.assert_allclose(mid, 15.0 / 8.0 * (z[1] - z[0]) / 2.0, rtol=1e-12)


@pytest.mark.parametrize("make", [_spline_data, _waypoints], ids=["spline", "waypoints"])
def test_compiled_piecewise_equals_numpy_reference(make):
    pp = make().polynomial()
    t0, t1 = pp.table[0, 1], pp.table[0, -1]
    for t in np.concatenate(([t0 - 1.0, t0, t1, t1 + 2.0], np.linspace(t0, t1, 37))):
        for order in (0, 1):
            np.testing.assert_array_equal(piecewise(pp.table, t, order), pp.derivative(t, order))
            # complex products may round differently in compiled code (LLVM's complex
            # multiply): the value equal to an ulp, the derivative (imag / H, a sum of O(1)
            # terms that can cancel) to 1e-13 absolute, not bitwise
            tc = t + 1j * H
            got, want = piecewise(pp.table, tc, order), pp.derivative(tc, order)
            np.testing.assert_allclose(got.real, want.real, rtol=1e-15, atol=0)
            np.testing.assert_allclose(got.imag / H, want.imag / H, rtol=0, atol=1e-13)


@pytest.mark.parametrize("make", [_spline_data, _waypoints], ids=["spline", "waypoints"])
def test_reference_derivatives_are_exact(make):
    """ee_rate and ee_accel are the derivatives of ee_pose (complex step, to rounding)."""
    ref = Reference(ee=(), data=make())
    for t in np.linspace(0.3, 5.2, 11):
        np.testing.assert_allclose(ref.ee_pose(t + 1j * H).imag / H, ref.ee_rate(t), atol=1e-12)
        np.testing.assert_allclose(ref.ee_rate(t + 1j * H).imag / H, ref.ee_accel(t), atol=1e-12)
    pose, rate = ref.sample(np.array([0.3, 1.7]))
    np.testing.assert_allclose(pose[1], ref.ee_pose(1.7), atol=1e-14)
    np.testing.assert_allclose(rate[1], ref.ee_rate(1.7), atol=1e-14)


def test_compiled_reference_adds_the_polynomial_only_when_there_is_one():
    """``reference_arrays`` gives ``pp`` None for a harmonic reference (the kernels compile no
    piecewise code: numba prunes the branch on a None argument) and the table for one from
    data; ``reference_at`` is then the harmonic terms alone, bitwise what an empty table
    gives, or the harmonic terms plus :func:`piecewise`, bitwise, real and complex t."""
    harmonic = reference_arrays(builtin_scenario("case1").reference)
    assert harmonic.pp is None
    empty = harmonic._replace(pp=np.zeros((harmonic.A.shape[0] * 6 + 1, 0)))
    data = Reference(ee=(), data=_waypoints())
    with_data = reference_arrays(data)
    assert with_data.pp is not None and with_data.pp.shape[1] > 0
    no_data = with_data._replace(pp=None)
    for t in (0.0, 0.7, 3.1 + 1j * H, 6.0):
        for rate in (False, True):
            a, b = reference_at(harmonic, t, rate), reference_at(empty, t, rate)
            assert np.array_equal(a, b)
            got = reference_at(with_data, t, rate)
            want = reference_at(no_data, t, rate) + piecewise(with_data.pp, t, int(rate))
            assert np.array_equal(got, want)


# ----------------------------------------------------------------- runs
def _sampled(sc, h: float):
    """The scenario with its harmonic reference replaced by samples h [s] apart."""
    ts = np.arange(-0.5, sc.duration + 1.0, h)
    z = np.array([sc.reference.ee_pose(t) for t in ts])
    data = ReferenceData(tuple(ts), tuple(map(tuple, z)))
    return dataclasses.replace(sc, reference=dataclasses.replace(sc.reference, ee=(), data=data))


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_sampled_analytic_reference_reproduces_the_analytic_run(case, tmp_path):
    """A CSV that samples the Fourier reference at 10 ms gives the same run: the spline's
    error, about (w h)^4 / 384 of an amplitude (w <= 0.5 rad/s: ~2e-11 relative), is all
    that differs; 1e-7 leaves room for its growth through the closed loop over 2 s."""
    sc = dataclasses.replace(builtin_scenario(case), duration=2.0)
    data = _sampled(sc, 0.01).reference.data
    names = ", ".join(["t", *(f"z{i}" for i in range(data.n_components))])
    samples = zip(data.times, data.values, strict=True)
    rows = [", ".join(repr(float(x)) for x in (t, *z)) for t, z in samples]
    (tmp_path / "ref.csv").write_text("\n".join([names, *rows]) + "\n")
    text = builtin_path(case).read_text()
    text = text.replace("\nee = [", '\nee_file = "ref.csv"\nold_ee = [', 1)
    for long in ("duration = 40.0", "duration = 30.0"):
        text = text.replace(long, "duration = 2.0")
    src = tmp_path / "s.toml"
    src.write_text(_drop_table_key(text, "old_ee"))
    from_file = load_scenario(src)
    assert from_file.reference.data is not None and from_file.duration == 2.0
    a, b = simulate(prepare(sc)), simulate(prepare(from_file))
    assert a.stop_cause == b.stop_cause
    scale = np.abs(a["q"]).max()
    for key in ("q", "z_e", "z_e_d", "err_z"):
        np.testing.assert_allclose(b[key], a[key], rtol=0, atol=1e-7 * scale, err_msg=key)
    np.testing.assert_allclose(b["u_m"], a["u_m"], rtol=0, atol=1e-7 * np.abs(a["u_m"]).max())


def _drop_table_key(text: str, key: str) -> str:
    """Remove a multi-line ``key = [ ... ]`` array from TOML text."""
    start = text.index(f"\n{key} = [")
    end = text.index("\n]", start) + 2
    return text[:start] + text[end:]


def test_waypoints_relative_to_the_start_fly_rest_to_rest(tmp_path):
    """origin = "initial": waypoint 0 at zero starts on the end effector; the end effector
    reaches the next waypoint and the reference is at rest there."""
    sc = builtin_scenario("case1")
    setup = prepare(sc)
    z0 = Sensor(setup.robot, setup.model, full_model=False).measure(0.0, setup.q0, setup.v0).z_e
    step = np.array([0.1, -0.05, 0.02])
    data = ReferenceData((0.0, 4.0), ((0.0, 0.0, 0.0), tuple(step)), "waypoints")
    ref = dataclasses.replace(sc.reference, ee=(), data=data, origin="initial")
    flown = prepare(dataclasses.replace(sc, reference=ref, duration=6.0))
    run = simulate(flown)
    assert run.stop_cause is None
    t = np.asarray(run["t"])
    np.testing.assert_allclose(run["z_e_d"][0], z0, atol=1e-12)
    np.testing.assert_allclose(run["z_e_d"][-1], z0 + step, atol=1e-12)
    at4 = np.searchsorted(t, 4.0)
    np.testing.assert_allclose(run["z_e_d_dot"][at4], 0.0, atol=1e-9)
    # the saved scenario holds the resolved waypoints and loads back into the same reference
    back = scenario_from_toml(scenario_to_toml(flown.scenario))
    assert back.reference.origin == "absolute"
    np.testing.assert_allclose(back.reference.data.values, [z0, z0 + step], atol=1e-12)


def test_saved_scenario_writes_samples_inline(tmp_path):
    sc = _sampled(dataclasses.replace(builtin_scenario("case1"), duration=1.0), 0.25)
    text = scenario_to_toml(sc)
    assert "ee_samples.t = [" in text
    back = scenario_from_toml(text)
    assert back.reference == sc.reference


# ----------------------------------------------------------------- bad input
_BASE = """
[initial]
base_pose = [0.0, 0.0, 0.0]
joints = [0.5, 0.5, 0.5, 0.5]
base_twist = [0.0, 0.0, 0.0]
"""


def _scenario(reference: str, tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(_BASE + "\n[reference]\n" + reference)
    return path


@pytest.mark.parametrize(
    ("reference", "csv", "expected"),
    [
        ('ee_file = "missing.csv"', None, "missing.csv'.*not found"),
        ('ee_file = "r.csv"', "time, x, y, a\n0, 1, 2, 3\n1, 1, 2, 3\n", "header.*expected 't'"),
        ('ee_file = "r.csv"', "t, x, y\n0, 1, 2\n1, 1, 2\n", "header.*3 column names"),
        ('ee_file = "r.csv"', "t, x, y, a\n0, 1, 2, 3\n1, 1, 2\n", "line 3: 3 values, expected 4"),
        ('ee_file = "r.csv"', "t, x, y, a\n0, 1, 2, 3\n1, 1, b, 3\n", "line 3: not numbers"),
        ('ee_file = "r.csv"', "t, x, y, a\n0, 1, 2, 3\n0, 1, 2, 3\n", "sample 1 .*not come after"),
        ('ee_file = "r.csv"', "t, x, y, a\n0, 1, 2, 3\n", "at least 2 samples"),
        (
            'ee_file = "r.csv"\nee = [{ c = 1.0 }, { c = 1.0 }, { c = 1.0 }]',
            "t, x, y, a\n0, 1, 2, 3\n1, 1, 2, 3\n",
            "reference: give exactly one of .*reference.ee and reference.ee_file",
        ),
        ("task = 'pose'", None, "reference.ee: missing; give one of 'ee', 'ee_file'"),
        (
            "ee_waypoints = [{ t = 0.0, z = [1, 2, 3] }, { t = 1.0, z = [1, 2] }]",
            None,
            r"reference.ee_waypoints\[1\].z: 2 values, expected 3",
        ),
        ("ee_waypoints = [{ t = 0.0, z = [1, 2, 3] }]", None, "1 waypoint.*at least 2"),
        (
            "ee_waypoints = [{ t = 1.0, z = [1, 2, 3] }, { t = 1.0, z = [1, 2, 3] }]",
            None,
            "reference.ee_waypoints: times must increase",
        ),
        (
            "ee_samples = { t = [0.0, 1.0, 2.0], z = [[1, 2, 3], [1, 2, 3]] }",
            None,
            "reference.ee_samples.z: 2 rows, expected 3",
        ),
    ],
)
def test_bad_reference_data_is_named(reference, csv, expected, tmp_path):
    if csv is not None:
        (tmp_path / "r.csv").write_text(csv)
    with pytest.raises(ScenarioError, match=expected):
        load_scenario(_scenario(reference, tmp_path))


def test_reference_data_refuses_harmonics_too():
    ref = builtin_scenario("case1").reference
    with pytest.raises(ParameterError, match="not both"):
        dataclasses.replace(ref, data=_waypoints())


def test_cli_runs_a_waypoint_scenario_and_saves_it(tmp_path):
    """The command line end to end: exit 0, and the run folder's scenario holds the
    waypoints, so ``--scenario <run>/scenario.toml`` repeats the run."""
    src = tmp_path / "p2p.toml"
    src.write_text(
        _BASE
        + "\n[reference]\norigin = 'initial'\nee_waypoints = [\n"
        + "  { t = 0.0, z = [0.0, 0.0, 0.0] },\n  { t = 1.0, z = [0.05, 0.0, 0.0] },\n]\n"
        + "\n[sim]\nduration = 1.5\n"
    )
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "ffsm_pin.sim", "--scenario", str(src), "--out", str(out)]
    done = subprocess.run([*cmd, "--no-plots", "--no-html"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    saved = (out / "scenario.toml").read_text()
    assert "ee_waypoints = [" in saved and "\norigin =" not in saved.split("[controller]")[0]
