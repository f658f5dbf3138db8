"""results.parquet: columns of the contract, one row per case hash, atomic rewrites."""

from __future__ import annotations

import time

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from sweep_cases import SMALL

from ffsm_pin.sweep import table as table_mod
from ffsm_pin.sweep.campaign import load_campaign
from ffsm_pin.sweep.cases import expand
from ffsm_pin.sweep.table import ResultsTable

CONTRACT = (
    "case", "case_hash", "controller.estimates.spread", "estimates_seed", "status", "error",
    "funnel_ok_b", "funnel_ok_z", "first_violation_t", "max_abs_u", "drift_P", "drift_L",
    "settle_time_b", "settle_time_z", "min_sigma", "completed", "stop_reason", "wall_time_s",
)  # fmt: skip


def outcome(k: int) -> dict:
    return {
        "status": "completed", "error": None, "funnel_ok_b": True, "funnel_ok_z": k % 2 == 0,
        "first_violation_t": None, "max_abs_u": 10.0 + k, "drift_P": 1e-14, "drift_L": 2e-13,
        "settle_time_b": 3.0, "settle_time_z": None, "min_sigma": 0.1, "completed": True,
        "stop_reason": None, "wall_time_s": 0.5, "steps": 2000, "new_scalar": 1.5,
    }  # fmt: skip


@pytest.fixture
def cases(campaign_file):
    campaign = load_campaign(campaign_file(SMALL))
    return campaign, expand(campaign)


def test_columns_types_and_one_row_per_case(cases, tmp_path):
    campaign, cs = cases
    (tmp_path / "out").mkdir()
    t = ResultsTable(tmp_path / "out" / "results.parquet", campaign.columns)
    t.add(cs[1], {"status": "error", "error": "ValueError: boom"})  # an error row first
    got = pq.read_table(t.path)
    assert got.num_rows == 1 and set(CONTRACT) <= set(got.column_names)
    assert got.schema.field("max_abs_u").type == pa.float64()  # typed though all null
    assert got.schema.field("funnel_ok_z").type == pa.bool_()
    for k, case in enumerate(cs):
        t.add(case, outcome(k))
    t.add(cs[2], outcome(7))  # the same case again replaces its row
    got = pq.read_table(t.path).to_pylist()
    assert [r["case"] for r in got] == [0, 1, 2, 3, 4]
    assert [r["case_hash"] for r in got] == [c.case_hash for c in cs]
    assert got[2]["max_abs_u"] == 17.0 and got[1]["status"] == "completed"
    assert got[1]["controller.estimates.spread"] == 0.1 and got[4]["repeat"] == 1
    assert got[0]["nominal"] and got[0]["grid_point"] is None
    assert got[3]["estimates_seed"] == cs[3].estimates_seed
    assert got[1]["new_scalar"] == 1.5  # summary scalars unknown to the table are kept
    assert got[1]["scenario_toml"] == cs[1].scenario_toml
    # no temporary file left
    assert sorted(t.path.parent.iterdir()) == sorted([t.path, t.signals.path])


def test_a_failed_write_leaves_the_previous_file(cases, tmp_path, monkeypatch):
    campaign, cs = cases
    t = ResultsTable(tmp_path / "results.parquet", campaign.columns)
    t.add(cs[0], outcome(0))
    t.add(cs[1], outcome(1))

    def half_write(table, where, **kw):
        with open(where, "wb") as f:
            f.write(b"PAR1 truncated")
        raise OSError("disk full")

    monkeypatch.setattr(table_mod.pq, "write_table", half_write)
    with pytest.raises(OSError, match="disk full"):
        t.add(cs[2], outcome(2))
    monkeypatch.undo()
    assert pq.read_table(t.path).num_rows == 2  # the last complete file, still readable
    assert not list(tmp_path.glob(".*.tmp"))  # the half-written temporary file is removed


def test_rewrites_are_throttled_to_a_share_of_wall_time(cases, tmp_path):
    campaign, cs = cases
    t = ResultsTable(tmp_path / "results.parquet", campaign.columns, min_interval_s=0.0,
                     write_share=1e-9)  # fmt: skip
    assert not t.write_due()  # nothing to write yet
    t.add(cs[0], outcome(0))  # written: the file exists with one row
    t.add(cs[1], outcome(1), write=t.write_due())
    # the last write took > 0 s, so waiting cost / 1e-9 means: not due for years
    assert not t.write_due() and t.dirty and pq.read_table(t.path).num_rows == 1
    t.flush()
    assert not t.dirty and pq.read_table(t.path).num_rows == 2 and t.writes == 2
    t.flush()  # nothing new: no rewrite
    assert t.writes == 2
    eager = ResultsTable(tmp_path / "eager.parquet", campaign.columns, min_interval_s=0.0,
                         write_share=1.0)  # fmt: skip
    eager.add(cs[0], outcome(0))
    eager.add(cs[1], outcome(1), write=False)
    time.sleep(0.3)  # a 1-row rewrite takes milliseconds: its own duration has passed again
    assert eager.write_due()
