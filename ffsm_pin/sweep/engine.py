"""Running cases on a Dask cluster (dask.distributed, used as a library).

* :func:`start_client`: a :class:`~distributed.LocalCluster` of ``n_workers`` single-threaded
  worker processes (default: one per core) started with :data:`QUIET_WORKERS`, or a client of a
  running scheduler.
* :class:`WarmUp`: a worker plugin that runs a few steps of the campaign's scenario when a
  worker starts (also a worker that replaces a dead one), so the numba kernels are compiled or
  loaded from their on-disk cache once per worker, not once per case.
* :func:`run_case`: the task. It never raises for a bad run: a run that raises becomes an
  ``error`` outcome with the error text, a run that stops early a ``stopped`` one.
* :func:`run_cases`: submits the cases and yields ``(case, outcome)`` as tasks finish. A worker
  that dies has its tasks re-run on another worker by the scheduler (up to
  ``distributed.scheduler.allowed-failures`` times, then the case is an ``error``); each future
  yields once, so each case gives exactly one outcome.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import time
import traceback
import uuid
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import dask
from distributed import Client, LocalCluster, as_completed
from distributed.diagnostics.plugin import WorkerPlugin

from .campaign import Case

__all__ = ["QUIET_WORKERS", "WarmUp", "run_case", "run_cases", "start_client", "summary_scalars"]

WARMUP_STEPS = 20

#: Dask settings for the LocalCluster's processes: the worker's own periodic work, which is
#: CPU taken from the cases (a worker runs one case at a time and nobody reads a dashboard).
#: Measured on 1-worker clusters side by side (benchmarks/README.md, "Campaigns"): the worker
#: process spent 5.5 % of its cases' CPU outside them with Dask's defaults, 1.1 % with these.
#: A cluster started with ``dask worker`` takes the same keys as environment variables, e.g.
#: ``DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False``.
QUIET_WORKERS: dict[str, Any] = {
    # statistical profiler: samples the task thread's stack every 10 ms (dashboard only)
    "distributed.worker.profile.enabled": False,
    # event-loop health check, 20 ms by default; a case runs in its own thread, not the loop
    "distributed.admin.tick.interval": "1s",
    # CPU/memory/network samples for the dashboard, 500 ms by default
    "distributed.admin.system-monitor.interval": "2s",
    # worker and nanny memory polling, 100 ms by default; a case holds a few MB
    "distributed.worker.memory.monitor-interval": "1s",
}


def start_client(
    n_workers: int | None = None, scheduler: str | None = None, quiet: bool = False
) -> tuple[Client, LocalCluster | None]:
    """A client of a new LocalCluster (``n_workers`` processes of one thread; default one per
    core) or of the scheduler at ``scheduler`` (``tcp://host:port``)."""
    if scheduler is not None:
        return Client(scheduler, timeout="20s"), None
    n = n_workers or os.cpu_count() or 1
    with warnings.catch_warnings():  # "port 8787 in use" when another cluster runs: harmless
        warnings.simplefilter("ignore")
        with dask.config.set(QUIET_WORKERS):  # the nannies pass this config to their workers
            cluster = LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.CRITICAL if quiet else logging.ERROR,
            )
    return Client(cluster), cluster


class WarmUp(WorkerPlugin):
    """Compile (or load from cache) the kernels once per worker: a few steps of a scenario."""

    name = "ffsm-pin-warmup"

    def __init__(self, scenario_toml: str):
        self.scenario_toml = scenario_toml

    def setup(self, worker=None) -> None:  # noqa: D102 - WorkerPlugin API
        try:
            from ..scenario.file import scenario_from_toml
            from ..sim.run import prepare, simulate

            sc = scenario_from_toml(self.scenario_toml)
            sc = dataclasses.replace(sc, duration=WARMUP_STEPS * sc.dt)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                simulate(prepare(sc))
        except Exception:  # noqa: BLE001 - a case that fails the same way reports it
            pass


def _has_warmup(dask_worker=None) -> bool:
    return dask_worker is not None and WarmUp.name in dask_worker.plugins


def summary_scalars(summary: dict[str, Any]) -> dict[str, Any]:
    """The scalar entries of a run's summary.json (lists such as final_err_z are left out)."""
    return {k: v for k, v in summary.items() if v is None or isinstance(v, (bool, int, float, str))}


def run_case(scenario_toml: str, keep_dir: str | None = None) -> dict[str, Any]:
    """Simulate one case (on a worker): ``{"status", "error", **summary scalars}``.

    ``status`` is ``"completed"``, ``"stopped"`` (the run stopped early: a result) or
    ``"error"`` (the run raised; ``error`` holds the exception and where it happened);
    ``case_wall_s`` and ``case_cpu_s`` are the case's wall and CPU time on the worker [s].
    ``keep_dir``: write the run folder there as ``python -m ffsm_pin.sim`` does.
    """
    from ..scenario.file import scenario_from_toml
    from ..sim.run import prepare, simulate
    from .explain import case_extras

    wall0, cpu0 = time.perf_counter(), time.thread_time()
    try:
        scenario = scenario_from_toml(scenario_toml)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            setup = prepare(scenario)
            result = simulate(setup)
        summary = result.summary()
        extras = case_extras(setup, result, summary)  # lists, min_sigma_gjm, signals
        if keep_dir is not None:
            from ..sim.outputs import write_outputs

            write_outputs(Path(keep_dir), result, scenario, setup.robot, figures=True, replay=True)
    except Exception as exc:  # noqa: BLE001 - recorded in the row, the campaign goes on
        where = traceback.extract_tb(exc.__traceback__)[-1]
        text = f"{type(exc).__name__}: {exc} ({Path(where.filename).name}:{where.lineno})"
        return {"status": "error", "error": " ".join(text.split()), **_cost(wall0, cpu0)}
    status = "completed" if result.completed else "stopped"
    scalars = summary_scalars(summary)
    return {"status": status, "error": None, **scalars, **extras, **_cost(wall0, cpu0)}


def _cost(wall0: float, cpu0: float) -> dict[str, float]:
    """Wall and CPU time of the whole case on its worker (parse, set-up, simulation, summary,
    run folder) [s]; the summary's wall_time_s covers the simulation loop only."""
    return {"case_wall_s": time.perf_counter() - wall0, "case_cpu_s": time.thread_time() - cpu0}


def run_cases(
    client: Client, cases: Iterable[Case], keep_runs: Path | None = None
) -> Iterator[tuple[Case, dict[str, Any]]]:
    """Submit every case as a task; yield ``(case, outcome)`` in order of completion.

    Closing the generator (or an exception in the caller, e.g. Ctrl-C) cancels what is left.
    """
    cases = list(cases)
    if not cases:
        return
    have = client.run(_has_warmup)  # a running cluster's workers are warm already
    if not have or not all(have.values()):
        client.register_plugin(WarmUp(cases[0].scenario_toml), name=WarmUp.name)
    token = uuid.uuid4().hex[:8]
    futures = {}
    for case in cases:
        keep = None if keep_runs is None else str(keep_runs / f"case-{case.index:05d}")
        fut = client.submit(
            run_case,
            case.scenario_toml,
            keep,
            key=f"ffsm-case-{case.index}-{case.case_hash}-{token}",
            pure=False,
            retries=1,
        )
        futures[fut.key] = (fut, case)
    pending = set(futures)
    try:
        for fut in as_completed([f for f, _ in futures.values()]):
            case = futures[fut.key][1]
            pending.discard(fut.key)
            try:
                outcome = fut.result()
            except Exception as exc:  # noqa: BLE001 - KilledWorker and the like
                outcome = {"status": "error", "error": f"{type(exc).__name__}: {exc}"}
            fut.release()
            yield case, outcome
    finally:
        left = [futures[k][0] for k in pending]
        if left:
            client.cancel(left, force=True)
