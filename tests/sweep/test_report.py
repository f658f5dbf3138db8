"""report.md from DuckDB SQL: Wilson intervals against published values, worst cases with a
scenario file each, figures."""

from __future__ import annotations

import numpy as np
import pytest
from sweep_cases import SMALL

from ffsm_pin.scenario.file import load_scenario
from ffsm_pin.sweep.campaign import load_campaign
from ffsm_pin.sweep.cases import expand
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
    (out / "worst").mkdir()
    (out / "worst" / "case-00099.toml").write_text("# an earlier report's worst case\n")
    report = write_report(out, campaign).read_text()
    for name in ("fig_funnel_rate.png", "fig_max_u.png", "fig_settle.png", "fig_min_sigma.png"):
        assert (out / name).stat().st_size > 1000 and f"({name})" in report
    assert "| 0.3 | 10 | 5 | 50% | 24% - 76% | 19% - 81% | 0 | 1 |" in report
    assert "case 22: RuntimeError: boom" in report
    assert "| 0.1 | funnel left | 3 | 1.00 | 1.00 |" in report  # the stop causes
    # worst cases: not kept first, largest max |u_m| first; case 11 (u = 110) leads
    worst = sorted((out / "worst").iterdir())  # and no earlier report's case left beside them
    assert len(worst) == 10 and (out / "worst" / "case-00011.toml") in worst
    lines = [ln for ln in report.splitlines() if "--scenario worst/case-" in ln]
    assert lines[0].startswith("| 11 |")
    sc = load_scenario(out / "worst" / "case-00011.toml")  # the exact scenario of case 11
    assert sc.controller.estimates.seed == cases[11].estimates_seed
    assert sc.controller.estimates.spread == 0.1 and sc.duration == 4.0


# ------------------------------------------------------------------- reports that explain
USER_CONTROLLER = """
import numpy as np


class MyCtl:
    def __init__(self, ctx):
        self.n = ctx.n_joints

    def step(self, meas):
        return np.zeros(self.n)
"""


def _signals(case_index: int) -> dict:
    t = np.linspace(0.0, 1.0, 11)
    rho = np.tile([1.0, 1.0, 0.2], (11, 1))
    return {
        "t": t, "err_b": np.full((11, 1), 0.1), "err_z": 0.1 * rho, "rho_b": np.ones((11, 1)),
        "rho_z": rho, "bound_b_lower": -np.ones((11, 1)), "bound_b_upper": np.ones((11, 1)),
        "bound_z_lower": -rho, "bound_z_upper": rho, "u_m": np.full((11, 4), case_index),
        "u_cmd": np.full((11, 4), case_index),
    }  # fmt: skip


def _run(kind: str, case_index: int, kept: bool, stopped: bool = False, left=None) -> dict:
    funnel, component, t = left or (None, None, None)
    return {
        "status": "stopped" if stopped else "completed", "error": None, "controller": kind,
        "funnel_ok_b": True, "funnel_ok_z": kept, "completed": not stopped,
        "first_violation_funnel": funnel, "first_violation_component": component,
        "first_violation_t": t, "stop_time": t if stopped else None,
        "stop_cause": "funnel" if stopped else None, "max_abs_u": 10.0, "max_joint_torque": 6.0,
        "rms_err_z_late": 0.01 * (case_index % 7), "saturation_per_joint": [0.0, 0.5, 0.0, 0.1],
        "min_sigma_gjm": 0.2, "min_sigma": 0.1, "min_sigma_of": "J_m-hat U-hat",
        "joint_torque_limits": [30.0] * 4, "signals": _signals(case_index),
    }  # fmt: skip


def test_report_explains_failures_and_compares_pairs(campaign_file, tmp_path):
    """A user's controller (labelled by its class name) against lu-jia on 6 draws: why its
    runs failed (funnel, component, when), the paired table with its exact McNemar p-value,
    the run counts, the overlays of the median and worst runs."""
    ctl = tmp_path / "my_ctrl.py"
    ctl.write_text(USER_CONTROLLER, encoding="utf-8")
    kind = f"{ctl}:MyCtl"
    text = SMALL.replace("repeat = 2", "repeat = 6").replace(
        'key = "controller.estimates.spread"\nvalues = [0.1, 0.3]',
        f'key = "controller.type"\nvalues = ["lu-jia", "{kind}"]',
    )
    campaign = load_campaign(campaign_file(text))
    cases = expand(campaign)
    out = tmp_path / "out"
    out.mkdir()
    t = ResultsTable(out / "results.parquet", campaign.columns)
    t.add(cases[0], _run("lu-jia", 0, True), write=False)
    for case in cases[1:]:
        r = case.repeat
        if case.values["controller.type"] == "lu-jia":  # kept but for repeat 5 (a funnel stop)
            outcome = _run("lu-jia", case.index, r != 5, r == 5, ("z", 1, 2.0) if r == 5 else None)
        else:  # kept on repeats 0 and 1; the others leave z[0] at 1.0, 1.5, ...
            left = None if r < 2 else ("z", 0, 1.0 + 0.5 * (r - 2))
            outcome = _run(kind, case.index, r < 2, left=left)
        t.add(case, outcome, write=False)
    t.write()
    report = write_report(out, campaign).read_text()
    assert kind not in report  # labelled by the class name
    failed = report.split("## Why runs failed", 1)[1].split("\n## ", 1)[0]
    assert "| MyCtl | completed | z[0] | 4 of 6 | 1.00 | 1.75 |" in failed
    assert "| lu-jia | stopped: funnel | z[1] | 1 of 6 | 2.00 | 2.00 |" in failed
    # pairs by repeat index: both kept on 0, 1; only lu-jia on 2, 3, 4; neither on 5
    paired = report.split("## Paired comparison", 1)[1].split("\n## ", 1)[0]
    assert "| MyCtl | lu-jia | 6 | 2 | 0 | 3 | 1 | 0.25 | yes |" in paired  # p = 2 / 2^3
    many = report.split("## How many runs", 1)[1].split("\n## ", 1)[0]
    assert "The two closest controllers: MyCtl (33% of 6 runs) and lu-jia (83% of 6)" in many
    assert "| 33% (10% - 70%; exact 4% - 78%) |" in report  # 2 of 6: Wilson; Clopper-Pearson
    per = report.split("## Per controller", 1)[1].split("\n## ", 1)[0]
    assert "0% / 50% / 0% / 10%" in per and "0.1 (J_m-hat U-hat)" in per
    for name in ("fig_overlay_MyCtl.png", "fig_overlay_lu-jia.png"):
        assert (out / name).stat().st_size > 1000 and f"({name})" in report
    # the worst MyCtl run is the one that left first (repeat 2, left at 1.0 s)
    worst = next(c for c in cases if c.repeat == 2 and c.values["controller.type"] == kind)
    assert "**MyCtl**: median case" in report
    assert f"worst case {worst.index}." in report


def test_controller_labels():
    from ffsm_pin.sweep.report.text import controller_labels

    labels = controller_labels({
        "lu-jia": None, "/a/b/ctl.py:Mine": None, "pkg.mod:Theirs": "",
        "/a/c/x.py:PD": "[controller.params]\nlabel = 'joint PD'\n",
        "/a/one.py:Same": None, "/a/two.py:Same": None,
    })  # fmt: skip
    assert labels == {
        "lu-jia": "lu-jia", "/a/b/ctl.py:Mine": "Mine", "pkg.mod:Theirs": "Theirs",
        "/a/c/x.py:PD": "joint PD", "/a/one.py:Same": "one.py:Same",
        "/a/two.py:Same": "two.py:Same",
    }  # fmt: skip


def test_a_user_campaign_says_how_to_reproduce_it_from_anywhere(campaign_dir, tmp_path):
    """A user's campaign file lies outside the repository: its report's command names it and
    the output folder by absolute paths, so it runs from any folder (issue 41)."""
    campaign, _, out = campaign_dir
    report = write_report(out, campaign).read_text()
    line = next(ln for ln in report.splitlines() if ln.startswith("python -m ffsm_pin.sweep "))
    words = line.split()
    file, folder = words[3], words[words.index("--out") + 1]
    from pathlib import Path

    assert Path(file).is_absolute() and Path(file).is_file()
    assert Path(folder).is_absolute() and Path(folder) == out.resolve()
    assert "from any folder" in report


def test_option_variants_are_paired_on_their_draws():
    """Controller options (not only controller.type) are paired run by run: the runs of the
    same spread and repeat index, one row per spread; a variant is named by its option's
    value; the counts and the exact McNemar p-value follow the kept flags."""
    from ffsm_pin.sweep.report.sections import paired_rows

    cols = ["controller.saturation", "controller.estimates.spread"]
    kept = {  # (saturation, spread) -> kept per repeat
        ("ignore", 0.1): [True, True, True], ("auxiliary", 0.1): [True, True, True],
        ("ignore", 0.3): [False, False, True], ("auxiliary", 0.3): [True, True, True],
    }  # fmt: skip
    runs = [
        {"controller.saturation": sat, "controller.estimates.spread": spread, "repeat": r,
         "kept": k, "estimates_seed": 100 * r + int(10 * spread)}
        for (sat, spread), ks in kept.items() for r, k in enumerate(ks)
    ]  # fmt: skip
    rows = paired_rows(runs, cols)
    assert len(rows) == 1  # one pair of variants, the spreads pooled by grid point and repeat
    (row,) = rows
    assert {row["a"], row["b"]} == {"saturation=ignore", "saturation=auxiliary"}
    assert row["pairs"] == 6 and row["both"] == 4 and row["neither"] == 0
    only_aux = row["only_a"] if row["a"] == "saturation=auxiliary" else row["only_b"]
    assert only_aux == 2 and row["only_a"] + row["only_b"] == 2
    assert row["p"] == 0.5  # two discordant pairs, both one way: 2 / 2^2
    assert row["common"]


def test_the_shared_duckdb_reads_a_rewritten_file_as_a_fresh_one(tmp_path):
    """query() keeps one DuckDB per process (opening one per query was a tenth of a small
    campaign's report): a Parquet file rewritten with other values of the same size and
    the same modification time is read anew, and every answer is a fresh connection's."""
    import os

    import duckdb
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ffsm_pin.sweep.report.sql import connection

    path = tmp_path / "t.parquet"
    text = f"SELECT sum(x) AS s, count(*) AS n FROM read_parquet('{path}')"
    for values in ([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]):
        pq.write_table(pa.table({"x": values}), path)
        os.utime(path, ns=(1_000_000_000, 1_000_000_000))  # the same stamp both times
        fresh = duckdb.connect()
        try:
            expected = fresh.execute(text).fetchall()
        finally:
            fresh.close()
        assert [(r["s"], r["n"]) for r in query(text)] == expected == [(sum(values), 3)]
    assert connection() is connection()


def test_a_figure_saved_without_the_layout_placeholder_has_the_same_pixels(tmp_path):
    """The report saves its figures after tight_layout() with no layout engine left (one
    draw, not a dry one first): the same PNG as matplotlib's own tight_layout() + savefig(),
    on a figure like the overlays (shared axes, legends outside the axes, a suptitle)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ffsm_pin.sweep.report.figures import _save

    def figure():
        fig, axes = plt.subplots(3, 2, figsize=(11, 7.5), sharex="col", squeeze=False)
        t = np.linspace(0.0, 4.0, 500)
        for k, ax in enumerate(axes.flat):
            for i in range(3):
                ax.plot(t, np.sin((i + 1) * t + k), lw=1, label=f"z[{i}]")
                ax.plot(t, 0.5 + 0.1 * i + 0 * t, lw=0.8, ls="--")
            ax.set_ylabel(f"err_{k} / rho_{k}")
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
        fig.suptitle("lu-jia: errors against their funnels (dashed), torques against limits")
        return fig

    ours = tmp_path / _save(figure(), tmp_path / "ours.png")
    fig = figure()
    fig.tight_layout()
    fig.savefig(tmp_path / "matplotlib.png", dpi=110)
    plt.close(fig)
    a, b = plt.imread(ours), plt.imread(tmp_path / "matplotlib.png")
    assert a.shape == b.shape and a.shape[0] > 800
    assert a.tobytes() == b.tobytes()


def test_the_report_says_what_its_rows_were_computed_with(campaign_file, tmp_path):
    """Rows from workers with other BLAS kernels: the report counts each and says what a mix
    means; rows without the columns' values (campaigns run before they existed) add nothing."""
    campaign = load_campaign(campaign_file(SMALL))
    cases = expand(campaign)
    out = tmp_path / "out"
    out.mkdir()
    t = ResultsTable(out / "results.parquet", campaign.columns)
    versions = "ffsm-pin 0.2.0, numpy 2.4.6"
    for k, case in enumerate(cases):
        kernels = (
            None if k == 0 else ("openblas 0.3.31 Haswell" if k < 3 else "openblas 0.3.31 SkylakeX")
        )
        t.add(case, {**outcome(True, False, 10.0), "blas": kernels, "versions": versions},
              write=False)  # fmt: skip
    t.write()
    text = write_report(out, campaign).read_text()
    line = next(x for x in text.splitlines() if x.startswith("Computed with "))
    assert f"openblas 0.3.31 Haswell ({versions}): 2 rows" in line
    assert f"openblas 0.3.31 SkylakeX ({versions}): {len(cases) - 3} rows" in line
    assert "OPENBLAS_CORETYPE" in line  # the mix is explained
