"""Physically consistent adaptation, ``adaptation = "physical"`` (control/physical.py,
docs/robust.md): the projection's properties (the margin reached, the distance to every point
of the physical set C never increased, numpy and compiled equal), the Lyapunov parameter term
at every projection of a run, long runs with large parameter errors where the gradient law
loses a physical (positive definite) M-hat and the projected law keeps P-hat >= eps I at every
step (lu-jia and adaptive-ct), the default law untouched where no estimate nears the boundary,
and the refusals of bad input."""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest
import tomllib

import ffsm_pin
from ffsm_pin.control import adaptive_ct, controller
from ffsm_pin.control.adaptive_ct import AdaptiveComputedTorque
from ffsm_pin.control.lu_jia import LuJiaController
from ffsm_pin.control.physical import (
    MARGIN_FRACTION,
    increment,
    margin_kernel,
    margin_of,
    physical_increment,
    physical_term,
    project,
    project_kernel,
)
from ffsm_pin.errors import ParameterError, ScenarioError
from ffsm_pin.model._pseudo_inertia import pseudo_inertia
from ffsm_pin.scenario.file import builtin_scenario, scenario_from_dict
from ffsm_pin.sim.run import prepare, simulate

CASES = {"planar": "case1", "spatial": "spatial"}


def lam_min(model, theta_d) -> float:
    return float(np.linalg.eigvalsh(model.pseudo_inertia(theta_d))[0])


def _outside(m, rng):
    """An estimate outside C (30-80 % entrywise error), and points of C: the truth and the
    truth with random point masses added (P grows by a PSD matrix)."""
    while True:
        theta = m.theta_d * (1 + rng.uniform(-0.8, 0.8, m.n_d))
        if lam_min(m, theta) < 0:
            break
    t = m.pseudo_inertia_table()
    basis = np.array([pseudo_inertia(t, e).ravel() for e in np.eye(m.n_d)]).T
    inside = [np.array(m.theta_d)]
    for _ in range(5):
        G = rng.normal(size=(t.size, 3)) * np.sqrt(lam_min(m, m.theta_d))
        X = G @ G.T
        extra = np.linalg.lstsq(basis, X.ravel(), rcond=None)[0]
        if lam_min(m, extra) >= -1e-12:  # (the image's projection of a PSD X stays PSD)
            inside.append(m.theta_d + extra)
    return theta, inside


@pytest.mark.parametrize("geometry", ["planar", "spatial"])
def test_projection_reaches_the_margin_and_never_moves_away_from_C(geometry, reduced_model_of):
    m = reduced_model_of(geometry)
    term = physical_term(m, m.theta_d, None)
    assert term.margin == pytest.approx(MARGIN_FRACTION * lam_min(m, m.theta_d), rel=1e-12)
    rng = np.random.default_rng(4)
    for _ in range(3):
        theta, inside = _outside(m, rng)
        got, count, lam = project(term, theta)
        assert count >= 1
        assert lam == pytest.approx(lam_min(m, got), abs=1e-12 * np.abs(got).max())
        assert lam >= term.margin * (1 - term.tol)
        for c in inside:  # C's points, the truth among them: never farther
            assert np.linalg.norm(got - c) <= np.linalg.norm(theta - c) * (1 + 1e-12)
        fast, fast_count, fast_lam = project_kernel(term, theta)
        assert fast_count == count
        np.testing.assert_allclose(fast, got, rtol=0, atol=1e-10 * np.abs(got).max())
        assert fast_lam == pytest.approx(lam, rel=1e-6)
        # the cap: one half-space is not enough from this far out
        assert project(term._replace(max_iter=0), theta)[1] == 1
    # an estimate in C is not touched, the increment neither (the same object)
    same, count, _ = project(term, m.theta_d)
    assert same is m.theta_d and count == 0
    d = 1e-6 * rng.normal(size=m.n_d)
    assert increment(term, m.theta_d, d)[0] is d
    assert physical_increment(term, np.array(m.theta_d), d)[0] is d
    assert physical_increment(None, np.array(m.theta_d), d)[0] is d


@pytest.mark.parametrize("geometry", ["planar", "spatial"])
def test_recorded_margin_numpy_equals_compiled(geometry, reduced_model_of):
    """The recorded distance to the boundary, lambda_min(P): the numpy reference, the compiled
    kernel and the model's P agree, inside the set and outside it (negative there)."""
    m = reduced_model_of(geometry)
    term = physical_term(m, m.theta_d, None)
    theta, inside = _outside(m, np.random.default_rng(9))
    for x in (theta, *inside):
        x = np.asarray(x, dtype=float)
        lam = margin_of(term, x)
        assert lam == pytest.approx(lam_min(m, x), rel=1e-12, abs=1e-15)
        assert margin_kernel(term, x) == pytest.approx(lam, rel=1e-9, abs=1e-14)
    assert margin_of(term, theta) < 0 <= margin_of(term, m.theta_d)


def test_margin_refusals(reduced_model_of):
    m = reduced_model_of("planar")
    bad = -np.array(m.theta_d)
    with pytest.raises(ParameterError, match="physical_margin") as exc:
        physical_term(m, bad, None)
    assert "\n" not in str(exc.value)
    with pytest.raises(ParameterError, match=">= 0"):
        physical_term(m, m.theta_d, -1.0)


@pytest.mark.parametrize(
    "key, value, words",
    [("adaptation", "foo", ("controller.adaptation", "'gradient', 'physical'")),
     ("physical_margin", -0.5, ("controller.physical_margin", ">= 0"))],
)  # fmt: skip
def test_scenario_refusals_are_one_line(key, value, words):
    doc = _case1_doc()
    doc["controller"][key] = value
    with pytest.raises(ScenarioError) as exc:
        scenario_from_dict(doc)
    msg = str(exc.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def _case1_doc() -> dict:
    path = Path(ffsm_pin.__file__).parent / "scenario" / "builtin" / "case1.toml"
    return tomllib.loads(path.read_text())


def _campaign_case1(ctype: str, adaptation: str, seed: int, spread: float = 0.3):
    """Case 1 as the compare-controllers campaign runs it: 100 N m limits, sensor noise,
    physical draws of the estimates within ``spread``."""
    doc = copy.deepcopy(_case1_doc())
    c = doc["controller"]
    c.update(type=ctype, adaptation=adaptation)
    c["estimates"] = {"initial": "perturbed", "spread": spread, "seed": seed}
    doc["actuators"] = {"torque_limit": 100.0}
    noise = dict(joints=1e-4, joint_rates=1e-3, base_attitude=1e-4, base_rate=1e-3,
                 ee_pose=1e-3, ee_velocity=1e-3)  # fmt: skip
    doc["sensors"] = {"seed": 7, "noise": noise}
    return scenario_from_dict(doc)


def _with(sc, **lu_jia):
    ctrl = dataclasses.replace(sc.controller, lu_jia=dataclasses.replace(sc.controller.lu_jia,
                                                                         **lu_jia))  # fmt: skip
    return dataclasses.replace(sc, controller=ctrl)


@pytest.mark.parametrize(
    "ctype, seed, loses",
    [("lu-jia", 6, "not positive definite"), ("adaptive-ct", 3, None)],
)
def test_long_run_with_large_errors_stays_physical(ctype, seed, loses):
    """30 % parameter error, 30 s: the gradient law's estimate leaves the physical set (lu-jia:
    M-hat loses positive definiteness and the run stops; adaptive-ct: P-hat far from PSD),
    the projected law keeps lambda_min(P-hat) >= eps (1 - tol) at every recorded step."""
    runs = {}
    for adaptation in ("gradient", "physical"):
        setup = prepare(_campaign_case1(ctype, adaptation, seed))
        runs[adaptation] = (setup, simulate(setup))
    setup, res = runs["gradient"]
    m = setup.model
    theta = np.asarray(res["theta_d_hat"])
    eps = MARGIN_FRACTION * lam_min(m, theta[0])
    assert eps <= lam_min(m, res["theta_d"])  # the truth is in C
    if loses:
        assert not res.completed and loses in res.stop_reason
    else:
        assert min(lam_min(m, x) for x in theta[::100]) < -1.0
    setup, res = runs["physical"]
    assert res.completed, res.stop_reason
    lam = np.array([lam_min(m, x) for x in np.asarray(res["theta_d_hat"])])
    assert lam.min() >= eps * (1 - 1e-3), lam.min()
    assert lam.min() < 1.01 * eps  # the projection acted


@pytest.mark.parametrize(
    "source, ctype, fraction, duration",
    [("case1", "lu-jia", 0.95, 5.0), ("spatial", "lu-jia", 0.5, 0.3),
     ("campaign", "adaptive-ct", 0.1, 1.0), ("spatial", "adaptive-ct", 0.5, 0.3)],
)  # fmt: skip
def test_lyapunov_parameter_term_never_increases_at_a_projection(
    source, ctype, fraction, duration, monkeypatch
):
    """The numpy reference run, every increment recorded: at each projection, |theta_d-hat -
    theta_d|^2 (the parameter term of Theorem 1's Lyapunov function, times gamma_3) after it
    never exceeds its value before, and the estimate has lambda_min(P) >= eps (1 - tol).
    ``campaign``: case 1 of the compare-controllers campaign, 30 % error (seed 3)."""
    if source == "campaign":
        sc = _campaign_case1(ctype, "gradient", seed=3)
    else:
        sc = builtin_scenario(source)
    m = prepare(dataclasses.replace(sc, duration=0.01)).model
    eps = fraction * lam_min(m, m.theta_d)  # the truth in C
    sc = _with(sc, adaptation="physical", physical_margin=eps)
    if ctype == "adaptive-ct":
        ctrl = dataclasses.replace(sc.controller, type="adaptive-ct")
        sc = dataclasses.replace(sc, controller=ctrl)
    setup = prepare(dataclasses.replace(sc, duration=duration))
    cls = LuJiaController if ctype == "lu-jia" else AdaptiveComputedTorque
    setup.controller = cls(setup.controller.context, backend="numpy")
    calls = []

    def recording(term, theta_d, d):
        got, count = increment(term, theta_d, d)
        calls.append((theta_d + d, theta_d + got, count, term.margin))
        return got, count

    monkeypatch.setattr(controller if ctype == "lu-jia" else adaptive_ct, "increment", recording)
    res = simulate(setup)
    assert res.completed, res.stop_reason
    m, truth = setup.model, setup.model.theta_d
    acted = [c for c in calls if c[2] > 0]
    assert len(acted) > 10, len(acted)
    for before, after, _, margin in acted:
        assert margin == eps
        assert np.sum((after - truth) ** 2) <= np.sum((before - truth) ** 2) * (1 + 1e-12)
        assert lam_min(m, after) >= eps * (1 - 1e-3)


def test_default_margin_leaves_case1_bitwise_unchanged():
    """Case 1 (the paper's estimates stay far from the boundary): the option on gives the
    default's trajectory bit for bit (the projection acts only where needed)."""
    sc = builtin_scenario("case1")
    a, b = (simulate(prepare(s)) for s in (sc, _with(sc, adaptation="physical")))
    assert a.completed and b.completed
    for key in a.signals:
        assert np.array_equal(np.asarray(a[key]), np.asarray(b[key]), equal_nan=True), key
    # the option records the distance to the boundary; the paper's law does not
    assert "ctrl_lambda_min_P" not in a.signals and set(b.signals) - set(a.signals) == {
        "ctrl_lambda_min_P"
    }
    lam0 = lam_min(prepare(sc).model, np.asarray(b["theta_d_hat"])[0])
    assert np.ravel(b["ctrl_lambda_min_P"])[0] == pytest.approx(lam0, rel=1e-12)


@pytest.mark.parametrize("geometry", ["planar", "spatial"])
@pytest.mark.parametrize("ctype", ["lu-jia", "adaptive-ct"])
def test_compiled_projected_run_follows_the_numpy_run(geometry, ctype):
    """A margin above the initial estimate's lambda_min(P): the initial estimate is projected
    (an event says so) and the periods project where the law pushes it back below; the
    compiled and the numpy runs (0.3 s) agree to rounding growth, every estimate at the margin
    or above."""
    sc = builtin_scenario(CASES[geometry])
    start = prepare(dataclasses.replace(sc, duration=0.01))
    margin = 1.01 * lam_min(start.model, start.controller.law.theta_d)  # the initial estimate's
    sc = _with(sc, adaptation="physical", physical_margin=margin)
    if ctype == "adaptive-ct":
        sc = dataclasses.replace(
            sc, controller=dataclasses.replace(sc.controller, type="adaptive-ct")
        )
    cls = LuJiaController if ctype == "lu-jia" else AdaptiveComputedTorque
    runs = []
    for backend in ("numba", "numpy"):
        setup = prepare(dataclasses.replace(sc, duration=0.3))
        setup.controller = cls(setup.controller.context, backend=backend)
        assert setup.controller.backend == backend
        assert any("projected" in e for e in setup.controller.events)
        runs.append(simulate(setup))
    fast, ref = runs
    assert fast.completed and ref.completed
    theta = np.asarray(ref["theta_d_hat"])
    np.testing.assert_allclose(fast["theta_d_hat"], theta, rtol=0, atol=1e-8 * np.abs(theta).max())
    np.testing.assert_allclose(fast["q"], ref["q"], rtol=0, atol=1e-9)
    lam = np.array([lam_min(start.model, x) for x in theta])
    assert lam.min() >= margin * (1 - 1e-3)
    assert lam[0] < 1.001 * margin  # the initial estimate projected to the margin
    # the recorded distance to the boundary: lambda_min(P) of the row's estimate (both at t,
    # before the period's update), both backends, both controllers
    for run in runs:
        lam_run = [lam_min(start.model, x) for x in np.asarray(run["theta_d_hat"])]
        recorded = np.ravel(run["ctrl_lambda_min_P"])
        np.testing.assert_allclose(recorded, lam_run, rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("margin", [None, 0.25])
def test_the_option_survives_the_saved_scenario(margin):
    """A run's saved scenario.toml (and a campaign's worst-case file, written the same way)
    keeps ``adaptation`` and ``physical_margin`` (read back equal); the default writes
    neither key."""
    from ffsm_pin.scenario.file import scenario_from_toml
    from ffsm_pin.scenario.writer import scenario_to_toml

    sc = builtin_scenario("case1")
    law = dataclasses.replace(sc.controller.lu_jia, adaptation="physical", physical_margin=margin)
    sc = dataclasses.replace(sc, controller=dataclasses.replace(sc.controller, lu_jia=law))
    back = scenario_from_toml(scenario_to_toml(sc))
    assert back.controller.lu_jia.adaptation == "physical"
    assert back.controller.lu_jia.physical_margin == margin
    text = scenario_to_toml(builtin_scenario("case1"))
    assert "adaptation" not in text and "physical_margin" not in text
