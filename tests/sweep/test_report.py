"""report.md from DuckDB SQL: Wilson intervals against published values, worst cases with a
scenario file each, figures."""

from __future__ import annotations

import pytest
from sweep_cases import SMALL

from ffsm_pin.scenario.file import load_scenario
from ffsm_pin.sweep.campaign import expand, load_campaign
from ffsm_pin.sweep.report import RATE_SQL, query, sql, write_report
from ffsm_pin.sweep.table import ResultsTable

FUNNEL_STOP = "t = 1.0000 s: err_z[1] = 0.9 left its funnel (-0.8, 0.8)"


def outcome(kept: bool, stopped: bool, u: float) -> dict:
    return {
        "status": "stopped" if stopped else "completed", "error": None, "funnel_ok_b": True,
        "funnel_ok_z": kept, "max_abs_u": u, "settle_time_z": 4.0 if kept else None,
        "settle_time_b": 2.0, "min_sigma": 0.05 + u / 1000, "damping_threshold": 0.05,
        "completed": not stopped, "stop_reason": FUNNEL_STOP if stopped else None,
        "stop_time": 1.0 if stopped else None, "wall_time_s": 0.1,
    }  # fmt: skip


@pytest.fixture
def campaign_dir(campaign_file, tmp_path):
    """Spread 0.1: 0 of 10 runs keep the funnels (3 stop early); spread 0.3: 5 of 10, plus an
    error row that the rates leave out."""
    campaign = load_campaign(campaign_file(SMALL.replace("repeat = 2", "repeat = 11")))
    cases = expand(campaign)
    out = tmp_path / "out"
    out.mkdir()
    t = ResultsTable(out / "results.parquet", campaign.columns)
    t.add(cases[0], outcome(True, False, 40.0), write=False)
    for k, case in enumerate(cases[1:12]):  # spread 0.1
        t.add(case, outcome(False, k < 3, 100.0 + k), write=False)
    for k, case in enumerate(cases[12:]):  # spread 0.3
        if k == 10:
            t.add(case, {"status": "error", "error": "RuntimeError: boom"}, write=False)
        else:
            t.add(case, outcome(k % 2 == 0, False, 10.0 + k), write=False)
    t.write()
    return campaign, cases, out


def test_rates_and_wilson_intervals(campaign_dir):
    campaign, _, out = campaign_dir
    rows = query(sql(RATE_SQL, out / "results.parquet", list(campaign.columns)))
    assert [r["controller.estimates.spread"] for r in rows] == [0.1, 0.3]
    a, b = rows
    assert (a["n"], a["kept"], a["stopped"], a["errors"]) == (11, 0, 3, 0)
    assert (b["n"], b["kept"], b["stopped"], b["errors"]) == (10, 5, 0, 1)
    # Wilson 95 % intervals (Newcombe 1998, Table I / Brown, Cai & DasGupta 2001):
    # 5/10 -> 0.2366 .. 0.7634; 0/11 -> 0 .. 0.2588
    assert b["rate"] == 0.5
    assert b["rate_lo"] == pytest.approx(0.2366, abs=1e-4)
    assert b["rate_hi"] == pytest.approx(0.7634, abs=1e-4)
    assert a["rate_lo"] == pytest.approx(0.0, abs=1e-12)
    assert a["rate_hi"] == pytest.approx(0.2588, abs=1e-4)


def test_report_files(campaign_dir):
    campaign, cases, out = campaign_dir
    report = write_report(out, campaign).read_text()
    for name in ("fig_funnel_rate.png", "fig_max_u.png", "fig_settle.png", "fig_min_sigma.png"):
        assert (out / name).stat().st_size > 1000 and f"({name})" in report
    assert "| 0.3 | 10 | 5 | 50% | 24% - 76% | 19% - 81% | 0 | 1 |" in report
    assert "case 22: RuntimeError: boom" in report
    assert "| 0.1 | funnel left | 3 | 1.00 | 1.00 |" in report  # the stop causes
    # worst cases: not kept first, largest max |u_m| first; case 11 (u = 110) leads
    worst = sorted((out / "worst").iterdir())
    assert len(worst) == 10 and (out / "worst" / "case-00011.toml") in worst
    lines = [ln for ln in report.splitlines() if "--scenario worst/case-" in ln]
    assert lines[0].startswith("| 11 |")
    sc = load_scenario(out / "worst" / "case-00011.toml")  # the exact scenario of case 11
    assert sc.controller.estimates.seed == cases[11].estimates_seed
    assert sc.controller.estimates.spread == 0.1 and sc.duration == 4.0
