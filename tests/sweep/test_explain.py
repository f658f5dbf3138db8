"""What a case adds to its row (sweep/explain.py) and signals.parquet: min_sigma_gjm against
an independent computation from the model's State, the decimated signals against the run's
own rows (at most 500 per case, first and last kept), resume and replacement of a case's
signals."""

from __future__ import annotations

import dataclasses

import numpy as np
import pyarrow.parquet as pq
import pytest
from sweep_cases import SMALL

from ffsm_pin.model.state import State
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim.run import prepare, simulate
from ffsm_pin.sweep.campaign import load_campaign
from ffsm_pin.sweep.cases import expand
from ffsm_pin.sweep.engine import run_case
from ffsm_pin.sweep.explain import (
    MAX_ROWS,
    SIGNAL_KEYS,
    case_extras,
    kept_rows,
    sigmas_gjm,
)
from ffsm_pin.sweep.table import ResultsTable


def test_kept_rows():
    assert kept_rows(3).tolist() == [0, 1, 2]
    for n in (500, 501, 999, 1000, 1001, 123_457):
        rows = kept_rows(n)
        assert len(rows) == min(n, MAX_ROWS) and rows[0] == 0 and rows[-1] == n - 1
        assert np.all(np.diff(rows) > 0)


@pytest.mark.parametrize("case, duration", [("case1", 1.2), ("spatial", 1.2)])
def test_min_sigma_gjm_is_that_of_the_true_generalized_jacobian(case, duration):
    """At every kept row: J* = J_m - J_b H_bb^-1 H_bm (task rows) of the true model from
    State at the recorded (q, v); its sigma_min here from the eigenvalues of J* J*^T."""
    sc = dataclasses.replace(builtin_scenario(case), duration=duration, dt=0.002)
    setup = prepare(sc)
    res = simulate(setup)
    extras = case_extras(setup, res, res.summary())
    n = len(res["t"])
    rows = kept_rows(n)
    assert n > MAX_ROWS and len(rows) == MAX_ROWS
    state = State(setup.robot)
    nt = setup.n_task
    sigmas = []
    for i in rows:
        st = state.update(res["q"][i], res["v"][i])
        J_star = st.J_m[:nt] - st.J_b[:nt] @ np.linalg.inv(st.H_bb) @ st.H_bm
        sigmas.append(np.sqrt(np.linalg.eigvalsh(J_star @ J_star.T)[0]))
    assert extras["min_sigma_gjm"] == pytest.approx(min(sigmas), rel=1e-9)
    assert 0 < extras["min_sigma_gjm"]
    # not the controller's own measure (the paper's controller: J_m-hat U-hat, estimates)
    assert res.summary()["min_sigma_of"] == "J_m-hat U-hat"


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_min_sigma_gjm_is_the_state_by_state_minimum_bit_for_bit(case):
    """The stacked computation (kinematics-only updates, one solve and one SVD over the kept
    rows) gives the bytes of the readable one: a full State.update, its generalized Jacobian
    and an SVD per kept row, min() over them; and every row's sigma, not only the minimum."""
    sc = dataclasses.replace(builtin_scenario(case), duration=0.6, dt=0.002)
    setup = prepare(sc)
    res = simulate(setup)
    extras = case_extras(setup, res, res.summary())
    state = State(setup.robot)
    rows = kept_rows(len(res["t"]))
    sigmas = []
    for i in rows:
        J_star = state.update(res["q"][i], res["v"][i]).generalized_jacobian(setup.n_task)
        sigmas.append(float(np.linalg.svd(J_star, compute_uv=False)[-1]))
    assert np.float64(extras["min_sigma_gjm"]).tobytes() == np.float64(min(sigmas)).tobytes()
    assert sigmas_gjm(setup, res.signals, rows).tobytes() == np.array(sigmas).tobytes()


def test_signals_parquet_rows_are_the_runs(tmp_path):
    """A 601-row case keeps 500 rows in signals.parquet, the first and the last equal to the
    run's; a case run again replaces its rows, an error row has none, a resumed table keeps
    them under the case's new number."""
    sc = dataclasses.replace(builtin_scenario("case1"), duration=1.2, dt=0.002)
    res = simulate(prepare(sc))
    outcome = run_case(scenario_to_toml(sc))
    assert outcome["status"] == "completed"
    assert outcome["saturation_per_joint"] == [0.0] * 4 and outcome["min_sigma_gjm"] > 0
    campaign = load_campaign(_campaign(tmp_path))
    cases = expand(campaign)
    out = tmp_path / "out"
    out.mkdir()
    table = ResultsTable(out / "results.parquet", campaign.columns)
    table.add(cases[1], outcome)
    table.add(cases[2], {"status": "error", "error": "boom"})
    got = pq.read_table(out / "signals.parquet").to_pylist()
    assert len(got) == MAX_ROWS and {r["case"] for r in got} == {1}
    row = pq.read_table(out / "results.parquet").to_pylist()[0]
    assert "signals" not in row and row["saturation_per_joint"] == [0.0] * 4
    for r, i in ((got[0], 0), (got[-1], len(res["t"]) - 1)):
        assert r["t"] == res["t"][i]
        for key in SIGNAL_KEYS:
            assert r[key] == np.asarray(res[key][i]).reshape(-1).tolist(), key
    ts = [r["t"] for r in got]
    assert ts == sorted(ts) and len(set(ts)) == MAX_ROWS
    # resumed, renumbered (case 1 is now case 5), and a case run again replaces its rows
    again = ResultsTable(out / "results.parquet", campaign.columns)
    again.keep(table.rows[cases[1].case_hash], dataclasses.replace(cases[1], index=5))
    short = {**outcome, "signals": {k: v[:3] for k, v in outcome["signals"].items()}}
    again.add(cases[3], short)
    got = pq.read_table(out / "signals.parquet").to_pylist()
    assert [r["case"] for r in got].count(5) == MAX_ROWS
    assert [r["case"] for r in got].count(cases[3].index) == 3
    again.add(cases[3], {"status": "error", "error": "boom"})
    assert {r["case"] for r in pq.read_table(out / "signals.parquet").to_pylist()} == {5}
    assert sorted(p.name for p in out.iterdir()) == ["results.parquet", "signals.parquet"]


def _campaign(tmp_path):
    path = tmp_path / "campaign.toml"
    path.write_text(SMALL, encoding="utf-8")
    return path
