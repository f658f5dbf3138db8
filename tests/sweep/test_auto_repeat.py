"""repeat = "auto": batches of repeats until every grid point's 95 % Wilson interval is no
wider than +- target_half_width, or max_repeat (the cases' outcomes made up here, no cluster)."""

from __future__ import annotations

import math

import pyarrow.parquet as pq
import pytest
from sweep_cases import SMALL

from ffsm_pin.sweep import cli
from ffsm_pin.sweep.campaign import CampaignError, load_campaign

Z = 1.959963984540054


def half_width(k: int, n: int) -> float:
    p = k / n
    return Z * math.sqrt(p * (1 - p) / n + Z**2 / (4 * n * n)) / (1 + Z**2 / n)


def auto(extra: str) -> str:
    return SMALL.replace("repeat = 2", 'repeat = "auto"\n' + extra)


@pytest.fixture
def fake_cluster(monkeypatch):
    """engine.run_cases replaced: every case's outcome from ``outcome(case)``; ``batches``
    lists the repeat indices each call ran."""
    from ffsm_pin.sweep import engine

    state = {"outcome": None, "batches": []}

    def run_cases(client, todo, keep, batch_size=None):
        state["batches"].append(sorted({c.repeat for c in todo if not c.nominal}))
        for case in todo:
            yield case, state["outcome"](case)

    class FakeClient:
        def close(self):
            pass

    monkeypatch.setattr(engine, "start_client", lambda *a, **k: (FakeClient(), None))
    monkeypatch.setattr(engine, "run_cases", run_cases)
    return state


def done(kept: bool) -> dict:
    return {"status": "completed", "error": None, "funnel_ok_b": True, "funnel_ok_z": kept}


def per_point(out):
    rows = [r for r in pq.read_table(out / "results.parquet").to_pylist() if not r["nominal"]]
    points: dict[int, list[bool]] = {}
    for r in rows:
        points.setdefault(r["grid_point"], []).append(bool(r["funnel_ok_z"]))
    return points


def test_auto_keys_are_checked(campaign_file):
    c = load_campaign(campaign_file(auto("target_half_width = 0.1\nmax_repeat = 50")))
    assert c.auto is not None and (c.auto.target_half_width, c.auto.max_repeat) == (0.1, 50)
    assert c.repeat == math.ceil(Z**2 / (2 * 0.1) - Z**2)  # the first batch: 16
    assert load_campaign(campaign_file(auto(""))).auto.target_half_width == 0.05
    with pytest.raises(CampaignError, match='max_repeat: only with repeat = "auto"'):
        load_campaign(campaign_file(SMALL.replace("seed = 11", "seed = 11\nmax_repeat = 3")))
    with pytest.raises(CampaignError, match='expected an integer >= 1 or "auto"'):
        load_campaign(campaign_file(SMALL.replace("repeat = 2", 'repeat = "many"')))


def test_stops_at_the_first_batch_that_meets_the_target(campaign_file, tmp_path, fake_cluster):
    """Every run keeps its funnels: 6 runs per grid point give +- 0.2 (the first batch)."""
    fake_cluster["outcome"] = lambda case: done(True)
    out = tmp_path / "out"
    assert cli.main([str(campaign_file(auto("target_half_width = 0.2"))), "--out", str(out),
                     "--quiet"]) == 0  # fmt: skip
    assert fake_cluster["batches"] == [list(range(6))]
    points = per_point(out)
    assert [len(v) for v in points.values()] == [6, 6]
    assert half_width(6, 6) <= 0.2 < half_width(5, 5)
    assert "target met" in (out / "report.md").read_text()


def test_batches_until_the_target_is_met(campaign_file, tmp_path, fake_cluster):
    """Half of the runs keep their funnels: batches until the widest interval is +- 0.2, no
    sooner; a resume in the folder runs nothing."""
    fake_cluster["outcome"] = lambda case: done((case.repeat or 0) % 2 == 0)
    out = tmp_path / "out"
    path = campaign_file(auto("target_half_width = 0.2"))
    assert cli.main([str(path), "--out", str(out), "--quiet"]) == 0
    batches = fake_cluster["batches"]
    assert len(batches) > 1
    ends = [b[-1] + 1 for b in batches]  # repeats per grid point after each batch
    for r in ends[:-1]:  # not met before the last batch (repeats 0, 2, 4, ... kept)
        assert half_width((r + 1) // 2, r) > 0.2
    points = per_point(out)
    assert {len(v) for v in points.values()} == {ends[-1]}
    assert max(half_width(sum(v), len(v)) for v in points.values()) <= 0.2
    assert [b[0] for b in batches[1:]] == ends[:-1]  # each batch runs only the new repeats
    report = (out / "report.md").read_text()
    assert f"{ends[-1]} draws per grid point" in report and "target met" in report
    fake_cluster["batches"].clear()
    assert cli.main([str(path), "--out", str(out), "--quiet"]) == 0
    assert fake_cluster["batches"] == []
    assert {len(v) for v in per_point(out).values()} == {ends[-1]}


def test_stops_at_the_cap(campaign_file, tmp_path, fake_cluster):
    """+- 0.05 at a rate of 1/2 takes 381 runs; max_repeat = 15 stops the batches at 15."""
    fake_cluster["outcome"] = lambda case: done((case.repeat or 0) % 2 == 0)
    out = tmp_path / "out"
    text = auto("target_half_width = 0.2\nmax_repeat = 15")
    assert cli.main([str(campaign_file(text)), "--out", str(out), "--quiet"]) == 0
    assert fake_cluster["batches"][-1][-1] == 14
    assert {len(v) for v in per_point(out).values()} == {15}
    assert "not met at the cap of max_repeat = 15" in (out / "report.md").read_text()
