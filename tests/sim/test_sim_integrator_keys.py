"""The ``[sim]`` accuracy keys (``integrator``, ``substeps``): validation in Scenario and the
scenario file, the round trip through scenario_to_toml, and their effect in run.simulate."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ffsm_pin.errors import ScenarioError
from ffsm_pin.scenario.check import check_scenario
from ffsm_pin.scenario.file import builtin_path, builtin_scenario, scenario_from_toml
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.run import prepare, simulate


def with_sim(extra: str) -> str:
    """case1's file with ``extra`` lines appended to its [sim] table."""
    text = builtin_path("case1").read_text()
    assert text.rstrip().splitlines()[-1].startswith(("dt", "duration"))  # [sim] comes last
    return text.rstrip() + "\n" + extra + "\n"


def test_defaults_and_round_trip():
    sc = builtin_scenario("case1")
    assert (sc.integrator, sc.substeps) == ("semi-implicit", 1)
    sc = scenario_from_toml(with_sim('integrator = "rk4"\nsubsteps = 3'))
    assert (sc.integrator, sc.substeps) == ("rk4", 3)
    again = scenario_from_toml(scenario_to_toml(sc))
    assert (again.integrator, again.substeps) == ("rk4", 3)


@pytest.mark.parametrize(
    "extra, message",
    [
        ('integrator = "rk5"', r"sim.integrator = 'rk5' unknown \(did you mean 'rk4'\?\); valid "
         r"choices: 'semi-implicit', 'rk4'"),
        ("integrator = 4", "sim.integrator: expected a string"),
        ("substeps = 0", "sim.substeps = 0: must be >= 1"),
        ("substeps = 1.5", "sim.substeps: expected an integer"),
        ("substeps = true", "sim.substeps: expected an integer"),
        ("substep = 2", "did you mean 'substeps'"),
    ],
)  # fmt: skip
def test_bad_keys(extra, message):
    with pytest.raises(ScenarioError, match=message):
        scenario_from_toml(with_sim(extra))


def test_scenario_validates():
    """The schema checks a scenario built in Python (check_scenario, the first thing prepare
    does) with the file's messages."""
    sc = builtin_scenario("case1")
    with pytest.raises(ScenarioError, match="valid choices: 'semi-implicit', 'rk4'"):
        check_scenario(dataclasses.replace(sc, integrator="euler"))
    for bad in (0, -2, 2.0, True):
        with pytest.raises(ScenarioError, match="sim.substeps"):
            check_scenario(dataclasses.replace(sc, substeps=bad))


def test_closed_loop_uses_them():
    """Case 1 for 1 s: against rk4 with 4 substeps, the default run is off by O(dt) and 4
    substeps of the semi-implicit step cut that ~4x (first order); rk4 with 1 or 4 substeps
    agree to ~1e-13 (observed: 3e-4, 8e-5, 1.5e-13 over 2 s). Momentum stays exact in all."""
    sc = dataclasses.replace(builtin_scenario("case1"), duration=1.0)
    q = {}
    cases = (("semi-implicit", 1), ("semi-implicit", 4), ("rk4", 1), ("rk4", 4))
    for integrator, substeps in cases:
        run = simulate(prepare(dataclasses.replace(sc, integrator=integrator, substeps=substeps)))
        assert run.completed
        sig = run.signals
        for key in ("P", "L"):
            h = np.asarray(sig[key])
            assert np.abs(h - h[0]).max() <= 1e-9 * np.abs(h[0]).max()
        q[integrator, substeps] = np.asarray(sig["q"])
    ref = q["rk4", 4]
    err1 = np.abs(q["semi-implicit", 1] - ref).max()
    err4 = np.abs(q["semi-implicit", 4] - ref).max()
    assert err1 > 1e-6  # the keys changed the run
    assert 3.0 <= err1 / err4 <= 5.0, (err1, err4)
    assert np.abs(q["rk4", 1] - ref).max() <= 1e-3 * err4
