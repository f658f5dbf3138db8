"""A run compiles nothing while its clock runs: every compiled kernel its loop calls (the
controller's period, the sensor's and the plant's kernels, the actuators', the after-run
signals') is compiled or loaded from numba's cache before the loop starts, so that a run's
``steps_per_s`` and wall time measure the run, and controllers compare fairly.

What this guards against: numba compiles one version of a kernel per argument types, a
read-only array typed apart from a writeable one. The known model's M and C w come read-only
from the sensor's model while the controller warmed its period up on writeable stand-ins, so
the run's first period loaded (on a first run: compiled) a second period; the baselines and
the actuators compiled their kernels at their first call, inside the loop."""

from __future__ import annotations

import dataclasses
import time

import pytest
from numba.core import event

from ffsm_pin.scenario import builtin_scenario
from ffsm_pin.scenario.devices import ActuatorSpec, SensorSpec
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.setup import prepare

LIMITS = ActuatorSpec(torque_limit="urdf", time_constant=0.005)
SENSORS = SensorSpec(seed=3, delay=2, noise=(("joints", 1e-4),))

RUNS = {  # id: (built-in case, controller type, [controller.params], devices on)
    "planar": ("case1", "lu-jia", {}, False),
    "spatial": ("spatial", "lu-jia", {}, False),
    "planar-known-model-numba": ("known-model", "lu-jia", {"backend": "numba"}, False),
    "spatial-known-model": ("spatial-known-model", "lu-jia", {}, False),
    "planar-devices": ("case1", "lu-jia", {}, True),
    "spatial-known-model-devices": ("spatial-known-model", "lu-jia", {}, True),
    "planar-gjm-ct": ("case1", "gjm-ct", {}, True),
    "spatial-gjm-ct": ("spatial", "gjm-ct", {}, True),
    "planar-adaptive-ct": ("case1", "adaptive-ct", {}, True),
    "spatial-adaptive-ct": ("spatial", "adaptive-ct", {}, True),
}


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


@pytest.mark.parametrize("run", list(RUNS))
def test_a_run_compiles_nothing_while_its_clock_runs(run):
    case, kind, params, devices = RUNS[run]
    sc = builtin_scenario(case)
    controller = dataclasses.replace(sc.controller, type=kind, params=params)
    sc = dataclasses.replace(sc, duration=10 * sc.dt, controller=controller)
    if devices:  # torque limits and a lag; sensor delay and noise
        sc = dataclasses.replace(sc, actuators=LIMITS, sensors=SENSORS)
    setup = prepare(sc)
    listener = _Compilations()
    clock: list[float] = []  # when the loop's first step starts (the run's first progress call)
    with event.install_listener("numba:compile", listener):
        result = simulate(setup, progress=lambda t: clock.append(time.perf_counter()))
    assert result.completed and clock, result.stop_reason
    in_loop = [name for at, name in listener.started if at >= clock[0]]
    assert in_loop == [], in_loop
