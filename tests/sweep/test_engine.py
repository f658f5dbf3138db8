"""How a campaign worker runs a case (sweep/engine.py): its rows in memory, its row the single
run's."""

from __future__ import annotations

import dataclasses
import math

from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.scenario.writer import scenario_to_toml
from ffsm_pin.sim import recorder
from ffsm_pin.sim.run import prepare, simulate
from ffsm_pin.sweep.engine import CASE_MEMORY_BYTES, run_case, summary_scalars

TIMING = {"wall_time_s", "steps_per_s", "case_wall_s", "case_cpu_s"}


def _same(a, b) -> bool:
    """Equal, NaN equal to NaN."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def test_a_campaign_case_keeps_its_rows_in_memory(monkeypatch):
    """A case's rows are read once, for its row, and never recovered: they stay in memory up
    to CASE_MEMORY_BYTES where a single run spills them past its chunk. With a 16 KiB chunk the
    single run of the case spills (the control) and the case makes no spool; its row is the
    single run's summary, every scalar but the timings equal."""
    monkeypatch.setattr(recorder, "CHUNK_BYTES", 2**14)
    sc = dataclasses.replace(builtin_scenario("case1"), duration=0.5)
    alone = simulate(prepare(sc))
    assert alone.signals.spilled
    spools: list[tuple] = []
    make_spool = recorder.make_spool

    def counted(*args, **kwargs):
        spools.append(args)
        return make_spool(*args, **kwargs)

    monkeypatch.setattr(recorder, "make_spool", counted)
    outcome = run_case(scenario_to_toml(sc))
    assert outcome["status"] == "completed"
    assert spools == []
    expected = summary_scalars(alone.summary())
    assert {k: v for k, v in expected.items() if k not in TIMING}
    for key, value in expected.items():
        if key not in TIMING:
            assert _same(outcome[key], value), key
    assert CASE_MEMORY_BYTES >= 2**20 * 32  # never less than a single run's chunk


def test_the_workers_keep_freed_memory(monkeypatch):
    """The campaign's workers start without Dask's MALLOC_TRIM_THRESHOLD_ (glibc would give
    each case's freed arrays back to the system, and the next case pay their page faults
    again; benchmarks/README.md), with Dask's one thread per numerical library kept."""
    import os

    from ffsm_pin.sweep.engine import shutdown, start_client

    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)  # (a nanny before may leak it)
    client, cluster = start_client(1, quiet=True)
    try:
        env = client.run(lambda: dict(os.environ))
    finally:
        shutdown(client, cluster)
    (worker_env,) = env.values()
    assert "MALLOC_TRIM_THRESHOLD_" not in worker_env
    assert worker_env["OMP_NUM_THREADS"] == "1" and worker_env["OPENBLAS_NUM_THREADS"] == "1"
