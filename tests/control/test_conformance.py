"""One conformance suite over every registered controller (as qpsolvers runs one test body over
every solver): each built-in of ``registry.BUILTIN`` and each controller registered here for
the test (the kit's joint-space PD, tests/control/kit_pd.py) gets, planar (case 1's robot) and
spatial (the Panda on a satellite):

* its compiled step equal to its numpy step, period after period, at random states;
* whole short runs, on each backend, that complete and agree;
* nothing compiled while the run's clock runs (torque limits, a lag, sensor delay and noise);
* a bad ``[controller.params]`` refused before the run with an error naming the key;
* every signal it declares recorded, with its shape.

A new controller gets all of it by being registered (one line of ``registry.BUILTIN``; here a
test-only entry). The kit PD is also run with torque limits and sensor noise, and in a
campaign on Dask workers (docs/controllers.md, "Adding a built-in controller")."""

from __future__ import annotations

import dataclasses
import functools
import os
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from kit_pd import KitPD
from numba.core import event

from ffsm_pin.control import registry
from ffsm_pin.control.interface import recorded_name, split_reply
from ffsm_pin.errors import FfsmError, SimulationError
from ffsm_pin.scenario import builtin_scenario
from ffsm_pin.scenario.devices import ActuatorSpec, SensorSpec
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.measurement import Sensor
from ffsm_pin.sim.setup import prepare

#: controllers registered for these tests only, beside the built-ins
TEST_CONTROLLERS = {"kit-pd": KitPD}
KINDS = [*registry.BUILTIN, *TEST_CONTROLLERS]
GEOMETRIES = {"planar": "case1", "spatial": "spatial"}
DEVICES = {  # torque limits and a lag; sensor delay and noise
    "actuators": ActuatorSpec(torque_limit="urdf", time_constant=0.005),
    "sensors": SensorSpec(seed=3, delay=2, noise=(("joints", 1e-4),)),
}
STEPS = 25  # control periods of a short run


@pytest.fixture(autouse=True)
def registered(monkeypatch):
    """The test controllers are registered as a built-in is: by a line of the registry."""
    monkeypatch.setattr(registry, "BUILTIN", {**registry.BUILTIN, **TEST_CONTROLLERS})


def _scenario(kind: str, geometry: str, steps: int = STEPS, params=None, devices=False):
    sc = builtin_scenario(GEOMETRIES[geometry])
    controller = dataclasses.replace(sc.controller, type=kind, params=dict(params or {}))
    sc = dataclasses.replace(sc, duration=steps * sc.dt, controller=controller)
    return dataclasses.replace(sc, **DEVICES) if devices else sc


def _prepare(scenario):
    with warnings.catch_warnings():  # (reach horizon, gains: not what is tested here)
        warnings.simplefilter("ignore")
        return prepare(scenario)


def _on_backend(setup, backend: str):
    """The setup's controller built anew on ``backend`` from the same context."""
    controller = type(setup.controller)(setup.controller.context, backend=backend)
    assert controller.backend == backend
    return controller


def _copy(meas):
    """A measurement of its own for each controller (a controller may not write into it, but
    the comparison must not depend on that)."""
    q_b = meas.q_b.copy() if isinstance(meas.q_b, np.ndarray) else meas.q_b
    return meas._replace(q_b=q_b, q_m=meas.q_m.copy(), w=meas.w.copy(), z_e=meas.z_e.copy(),
                         z_e_dot=meas.z_e_dot.copy())  # fmt: skip


def _period(controller, meas):
    """(u_m, signals as arrays) of one step, or ("stop", cause) when the law stops."""
    try:
        u, signals = split_reply(controller.step(meas))
    except SimulationError as exc:
        return "stop", exc.cause
    return np.array(u, dtype=float), {k: np.array(v, dtype=float) for k, v in signals.items()}


# ---------------------------------------------------------------------- compiled = numpy
@pytest.mark.parametrize("geometry", list(GEOMETRIES))
@pytest.mark.parametrize("kind", KINDS)
def test_compiled_step_equals_numpy_step_at_random_states(kind, geometry):
    """Two controllers from one context, compiled and numpy, stepped on the same random
    measurements near the initial state (joint angles within 5 mrad, rates within 0.05 rad/s,
    so that the paper's controller stays inside its funnels), period after period: the same
    torque and signals, and the same stops.

    Tolerance: both evaluate the same formulas in another order (loops against BLAS, numba's
    LAPACK calls against numpy's, the spatial models' complex-step momentum rows through the
    real model against complex arithmetic), so one period differs by rounding of its
    operations: about 1e-13 relative on case 1, up to about 1e-11 on the spatial adaptive laws
    (3x3 and 10x10 solves with condition numbers up to about 1e4), carried over the periods
    through the controllers' states. 1e-9 of each output's largest entry leaves two orders of
    magnitude for that, and is far below any change of the law (a gain or a sign is off by
    order one)."""
    setup = _prepare(_scenario(kind, geometry))
    compiled, reference = _on_backend(setup, "numba"), _on_backend(setup, "numpy")
    needs_dynamics = bool(getattr(compiled, "needs_dynamics", False))
    sensor = Sensor(setup.robot, setup.model, full_model=needs_dynamics)
    rng = np.random.default_rng(7)
    n, dt = setup.robot.n_joints, setup.scenario.dt
    compared = 0
    for k in range(6):
        q, v = setup.q0.copy(), setup.v0.copy()
        q[-n:] += rng.uniform(-0.005, 0.005, n)
        v[-n:] += rng.uniform(-0.05, 0.05, n)
        meas = sensor.measure(k * dt, q, v)
        got, want = _period(compiled, _copy(meas)), _period(reference, _copy(meas))
        stopped = isinstance(want[0], str)
        assert isinstance(got[0], str) == stopped, (k, got, want)
        if stopped:
            assert got == want
            break
        (u, signals), (u_ref, signals_ref) = got, want
        np.testing.assert_allclose(u, u_ref, rtol=0, atol=1e-9 * np.abs(u_ref).max(),
                                   err_msg=f"u_m, period {k}")  # fmt: skip
        assert signals.keys() == signals_ref.keys()
        for key, value in signals_ref.items():
            scale = max(float(np.abs(value).max(initial=0.0)), 1e-12)
            np.testing.assert_allclose(signals[key], value, rtol=0, atol=1e-9 * scale,
                                       err_msg=f"{key}, period {k}")  # fmt: skip
        compared += 1
    assert compared >= 3  # (the states are near the start: no law stops there)


# ---------------------------------------------------------------------- whole short runs
@functools.cache
def _short_run(kind: str, geometry: str, backend: str):
    """(setup, result) of a short run on ``backend`` (cached: several tests read one run; called
    from the tests, with the test controllers registered)."""
    setup = _prepare(_scenario(kind, geometry))
    setup.controller = _on_backend(setup, backend)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return setup, simulate(setup)


@pytest.mark.parametrize("geometry", list(GEOMETRIES))
@pytest.mark.parametrize("kind", KINDS)
def test_short_runs_complete_and_the_backends_agree(kind, geometry):
    """25 periods through the run loop on each backend: both complete, and the trajectories
    agree to the rounding of the step test above, grown through 25 periods of the closed loop
    (1e-8 of each signal's largest entry)."""
    (_, compiled), (_, reference) = (_short_run(kind, geometry, b) for b in ("numba", "numpy"))
    assert compiled.completed and reference.completed, (compiled.stop_reason,
                                                        reference.stop_reason)  # fmt: skip
    assert compiled.steps == reference.steps == STEPS
    for key in ("q", "v", "u_m"):
        a, b = np.asarray(compiled.signals[key]), np.asarray(reference.signals[key])
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-8 * np.abs(b).max(), err_msg=key)


@pytest.mark.parametrize("geometry", list(GEOMETRIES))
@pytest.mark.parametrize("kind", KINDS)
def test_declared_signals_are_recorded(kind, geometry):
    """Every signal a controller declares (``signal_layout``, ``signal_shapes``) is in the
    recording under its recorded name, one row per recorded step, with its shape."""
    setup, result = _short_run(kind, geometry, "numba")
    layout = getattr(setup.controller, "signal_layout", None)
    declared = {**(layout.shapes if layout else {}),
                **(getattr(setup.controller, "signal_shapes", None) or {})}  # fmt: skip
    assert declared, "a controller of the suite declares its signals"
    rows = len(result.signals["t"])
    for key, shape in declared.items():
        recorded = np.asarray(result.signals[recorded_name(key)])
        assert recorded.shape == (rows, *shape), key
        assert np.all(np.isfinite(recorded)), key


# ---------------------------------------------------------------------- the run's clock
class _Compilations(event.Listener):
    """The functions numba compiles (or loads from its cache), with the time it starts."""

    def __init__(self):
        self.started: list[tuple[float, str]] = []

    def on_start(self, ev):
        data = ev.data or {}
        name = data["dispatcher"].py_func.__qualname__ if "dispatcher" in data else str(data)
        self.started.append((time.perf_counter(), name))

    def on_end(self, ev):
        pass


@pytest.mark.parametrize("geometry", list(GEOMETRIES))
@pytest.mark.parametrize("kind", KINDS)
def test_nothing_is_compiled_while_the_runs_clock_runs(kind, geometry):
    """With torque limits, a lag, sensor delay and noise (the measurement's types of a run with
    devices): every kernel was compiled or loaded while the controller was built."""
    setup = _prepare(_scenario(kind, geometry, steps=10, devices=True))
    listener = _Compilations()
    clock: list[float] = []  # when the loop's first step starts (the first progress call)
    with event.install_listener("numba:compile", listener), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = simulate(setup, progress=lambda t: clock.append(time.perf_counter()))
    assert result.completed and clock, result.stop_reason
    assert [name for at, name in listener.started if at >= clock[0]] == []


# ---------------------------------------------------------------------- parameters
@pytest.mark.parametrize("kind", KINDS)
def test_bad_params_are_refused_with_the_key_named(kind):
    """A ``[controller.params]`` key the controller cannot take (here a backend that does not
    exist: a bad value for the paper's controller, an unknown key for the others) is bad input
    before the run, an FfsmError naming the key."""
    with pytest.raises(FfsmError) as info:
        _prepare(_scenario(kind, "planar", params={"backend": "no-such-backend"}))
    assert "controller.params.backend" in str(info.value), str(info.value)


# ---------------------------------------------------------------------- the kit's rules
PACKAGE = Path(__file__).resolve().parents[2] / "ffsm_pin"


def test_compiled_functions_take_named_bundles_and_control_imports_no_private_name():
    """The kit's rules, read from the source: no compiled function of the package takes more
    than 12 arguments (what a period needs travels as named bundles), and no module of the
    control layer imports another module's private name (shared helpers are public in their
    one home)."""
    import ast

    long, private = [], []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and any(
                "jit" in ast.unparse(d) for d in node.decorator_list
            ):
                if len(node.args.args) > 12:
                    long.append(f"{path.name}:{node.name} ({len(node.args.args)})")
            if path.parent.name == "control" and isinstance(node, ast.ImportFrom):
                base = path.parent  # (a private module is a layer's own: not a name)
                for _ in range(node.level - 1):
                    base = base.parent
                folder = base.joinpath(*(node.module or "").split(".")) if node.level else None
                private += [f"{path.name}: {a.name}" for a in node.names
                            if a.name.startswith("_")
                            and not (folder and (folder / f"{a.name}.py").exists())]  # fmt: skip
    assert long == [] and private == [], (long, private)


# ---------------------------------------------------------------------- the kit's PD
@pytest.mark.parametrize("geometry", list(GEOMETRIES))
def test_the_kit_pd_runs_with_torque_limits_and_sensor_noise(geometry):
    """By registration alone: a target 0.1 rad off, a torque limit below k_p 0.1, noisy and
    delayed joint angles; the run completes, the limit bites, the controller saw the noise."""
    q_m0 = _prepare(_scenario("kit-pd", geometry)).controller.context.initial.q_m
    sc = _scenario("kit-pd", geometry, steps=40, params={"kp": 5.0, "target": list(q_m0 + 0.1)})
    sc = dataclasses.replace(
        sc, actuators=ActuatorSpec(torque_limit=0.1),
        sensors=SensorSpec(seed=5, delay=1, noise=(("joints", 1e-3),)),
    )  # fmt: skip
    setup = _prepare(sc)
    assert setup.controller.backend == "numba"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = simulate(setup)
    assert result.completed, result.stop_reason
    assert result.saturation_fraction > 0.5
    u_m = np.asarray(result.signals["u_m"])
    assert np.abs(u_m).max() <= 0.1 + 1e-15
    n = setup.robot.n_joints
    seen, true = np.asarray(result.signals["meas_q_m"]), np.asarray(result.signals["q"])[:, -n:]
    assert 1e-4 < np.abs(seen[5:] - true[4:-1]).max() < 1e-2  # noise on the delayed angles
    error = np.asarray(result.signals["ctrl_position_error"])
    np.testing.assert_allclose(error, (q_m0 + 0.1) - seen, rtol=0, atol=1e-15)


@pytest.mark.slow
def test_the_kit_pd_runs_in_a_campaign_on_dask_workers(tmp_path, monkeypatch):
    """A tiny campaign (two cases of 0.1 s, one worker process) of the kit PD, named as an
    importable module's class (the worker processes import it; a test's registry entry lives
    in this process only): each case completes on the worker."""
    from ffsm_pin.sweep import cli

    here = str(Path(__file__).resolve().parent)  # kit_pd.py, for the worker processes
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([here, os.environ.get("PYTHONPATH", "")]))
    path = tmp_path / "campaign.toml"
    path.write_text(
        '[campaign]\nname = "kit-pd"\nscenario = "case1"\nduration = 0.1\ndt = 0.002\n\n'
        '[campaign.set]\n"controller.type" = "kit_pd:KitPD"\n\n'
        '[[vary]]\nkey = "sensors.noise.joints"\nvalues = [0.0, 1e-3]\n'
    )
    out = tmp_path / "out"
    assert cli.main([str(path), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    import pyarrow.parquet as pq

    rows = pq.read_table(out / "results.parquet").to_pylist()
    assert {r["status"] for r in rows} == {"completed"}, rows
    cases = [r for r in rows if not r["nominal"]]  # (the nominal case is the scenario as is)
    assert len(cases) == 2 and {r["controller"] for r in cases} == {"kit_pd:KitPD"}
    assert sorted(r["sensors.noise.joints"] for r in cases) == [0.0, 1e-3]
