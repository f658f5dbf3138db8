"""The per-controller table of a campaign report (sweep/report.py, CONTROLLER_SQL) equals the
same statistics computed here with numpy from results.parquet: counts, the two rates with their
95 % Wilson score intervals (from the formula), medians."""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from ffsm_pin.sweep.campaign import load_campaign
from ffsm_pin.sweep.report import controller_table

Z = 1.959963984540054


def _wilson(k: int, n: int) -> tuple[float, float]:
    p = k / n
    centre = p + Z**2 / (2 * n)
    half = Z * math.sqrt(p * (1 - p) / n + Z**2 / (4 * n * n))
    return (centre - half) / (1 + Z**2 / n), (centre + half) / (1 + Z**2 / n)


def _synthetic(path, rng):
    kinds = ["lu-jia", "gjm-ct", "adaptive-ct"]
    rows = []
    for i in range(90):
        status = rng.choice(["completed", "stopped", "error"], p=[0.7, 0.2, 0.1])
        settled = rng.random() < 0.6
        rows.append({
            "case": i + 1, "nominal": False, "controller.type": kinds[i % 3], "status": status,
            "funnel_ok_b": bool(rng.random() < 0.6), "funnel_ok_z": bool(rng.random() < 0.8),
            "rms_err_z_late": rng.lognormal(-3, 1), "max_abs_u": rng.lognormal(3, 1),
            "saturation_fraction": rng.random(), "control_effort": rng.lognormal(5, 1),
            "max_base_excursion": rng.random(), "settle_time_z": rng.random() * 30 if settled
            else None,
        })  # fmt: skip
    rows.append({**rows[0], "case": 0, "nominal": True})  # never counted
    pq.write_table(pa.Table.from_pylist(rows), path)
    return [r for r in rows if not r["nominal"] and r["status"] != "error"]


def test_controller_table_equals_numpy(tmp_path):
    path = tmp_path / "results.parquet"
    runs = _synthetic(path, np.random.default_rng(5))
    table = {r["controller"]: r for r in controller_table(path)}
    assert sorted(table) == ["adaptive-ct", "gjm-ct", "lu-jia"]
    for kind, r in table.items():
        mine = [x for x in runs if x["controller.type"] == kind]
        n = len(mine)
        done = [x for x in mine if x["status"] == "completed"]
        kept = sum(x["funnel_ok_b"] and x["funnel_ok_z"] for x in done)
        kept_z = sum(x["funnel_ok_z"] for x in done)
        assert (r["n"], r["kept"], r["kept_z"]) == (n, kept, kept_z)
        assert r["rate"] == pytest.approx(kept / n) and r["rate_z"] == pytest.approx(kept_z / n)
        assert (r["rate_lo"], r["rate_hi"]) == pytest.approx(_wilson(kept, n), rel=1e-12)
        assert (r["rate_z_lo"], r["rate_z_hi"]) == pytest.approx(_wilson(kept_z, n), rel=1e-12)
        for key in ("rms_err_z_late", "max_abs_u", "saturation_fraction", "control_effort",
                    "max_base_excursion"):  # fmt: skip
            assert r[key] == pytest.approx(np.median([x[key] for x in mine]), rel=1e-12), key
        settles = [x["settle_time_z"] for x in mine if x["settle_time_z"] is not None]
        assert r["settled_z"] == len(settles)
        assert r["settle_time_z"] == pytest.approx(np.median(settles), rel=1e-12)


def test_per_scenario_controller_table_equals_numpy(tmp_path):
    """by = ("scenario",): one row per scenario and controller, each that group's counts."""
    path = tmp_path / "results.parquet"
    rng = np.random.default_rng(8)
    _synthetic(path, rng)
    rows = pq.read_table(path).to_pylist()
    for r in rows:
        r["scenario"] = "a" if r["case"] % 2 else "b"
    pq.write_table(pa.Table.from_pylist(rows), path)
    runs = [r for r in rows if not r["nominal"] and r["status"] != "error"]
    table = controller_table(path, by=("scenario",))
    assert [(r["scenario"], r["controller"]) for r in table] == sorted(
        {(r["scenario"], r["controller.type"]) for r in runs}
    )
    for r in table:
        group = (r["scenario"], r["controller"])
        mine = [x for x in runs if (x["scenario"], x["controller.type"]) == group]
        done = [x for x in mine if x["status"] == "completed"]
        assert r["n"] == len(mine)
        assert r["kept"] == sum(x["funnel_ok_b"] and x["funnel_ok_z"] for x in done)
        assert r["max_abs_u"] == pytest.approx(np.median([x["max_abs_u"] for x in mine]))


def test_builtin_comparison_campaign_is_valid():
    """compare-controllers: the three controllers on case 1, the 5-link robot and the
    realistic spatial case, every case valid."""
    from ffsm_pin.sweep.cases import expand

    c = load_campaign("compare-controllers")
    kinds = next(v.values for v in c.vary if v.key == "controller.type")
    assert set(kinds) == {"lu-jia", "gjm-ct", "adaptive-ct"}
    assert c.scenarios == ("case1", "planar5", "spatial-realistic")
    assert len(expand(c)) == c.n_cases


def test_rate_figure_with_rates_of_zero_and_one(tmp_path):
    """A rate of 0 (or 1) whose Wilson bound differs from it by rounding (n = 3: 4.9e-17)
    used to give matplotlib a negative error bar; the figure is drawn."""
    from ffsm_pin.sweep.report import RATE_SQL, figures, query, sql

    rows = [{"case": i + 1, "nominal": False, "x": float(i // 3), "status": "completed",
             "funnel_ok_b": i // 3 == 1, "funnel_ok_z": True, "max_abs_u": 1.0,
             "settle_time_z": None, "min_sigma": 0.1, "damping_threshold": 0.05}
            for i in range(6)]  # fmt: skip
    path = tmp_path / "results.parquet"
    pq.write_table(pa.Table.from_pylist(rows), path)
    rates = query(sql(RATE_SQL, path, ["x"]))
    assert [r["rate"] for r in rates] == [0.0, 1.0]
    files = figures(tmp_path, ["x"], rates, rows)
    assert (tmp_path / files["rate"]).stat().st_size > 0


def test_shipped_comparison_report_shows_its_results():
    """docs/campaigns/compare-controllers: the per-controller table of report.md is what
    controller_table computes from the results.parquet beside it (runs and kept counts)."""
    from pathlib import Path

    folder = Path(__file__).resolve().parents[2] / "docs" / "campaigns" / "compare-controllers"
    rows = controller_table(folder / "results.parquet", by=("scenario",))
    text = (folder / "report.md").read_text(encoding="utf-8")
    table = text.split("## Per controller and scenario", 1)[1].split("\n## ", 1)[0]
    lines = [ln for ln in table.splitlines() if ln.startswith("| ") and "---" not in ln][1:]
    assert len(lines) == len(rows) == 9
    for line, r in zip(lines, rows, strict=True):
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[:3] == [r["scenario"], r["controller"], str(r["n"])]
        assert cells[3].startswith(f"{r['rate']:.0%}") and cells[4].startswith(f"{r['rate_z']:.0%}")
