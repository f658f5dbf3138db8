"""Running cases on a Dask cluster (dask.distributed, used as a library).

* :func:`start_client`: a :class:`~distributed.LocalCluster` of ``n_workers`` single-threaded
  worker processes (default: one per core) started with :data:`QUIET_WORKERS`, or a client of a
  running scheduler. The cluster's threads and processes (also a worker started later in place
  of a dead one) block SIGINT: a Ctrl-C in the terminal, which the terminal sends to every
  process of the campaign, interrupts the campaign process alone, which then stops the cluster.
* :func:`shutdown`: close the client and the cluster without a word (no Dask traceback or log
  of the cancelled tasks and closed connections, also after a Ctrl-C).
* :func:`warm_up`: a task that runs a few steps of a case, so that the numba kernels of its
  robot and controller are compiled (and saved to numba's on-disk cache) or loaded before its
  cases run; :func:`run_cases` submits one per robot and controller type of the campaign, and
  their batches wait for it: on an empty cache each pair's kernels are compiled once for the
  cluster, by one worker, not by every worker that reaches them.
* :func:`run_case`: one case. It never raises for a bad run: a run that raises becomes an
  ``error`` outcome with the error text, a run that stops early a ``stopped`` one.
* :func:`run_batch`: the task, a batch of cases that share a robot
  (:mod:`ffsm_pin.sweep.batches`), run one after the other by :func:`run_case` with the robot
  loaded once; each case gives the outcome it gives alone.
* :func:`run_cases`: submits the batches and yields ``(case, outcome)`` per case as tasks
  finish. A worker that dies has its tasks re-run on another worker by the scheduler (up to
  ``distributed.scheduler.allowed-failures`` times, then each case of the batch is an
  ``error``); each future yields once, so each case gives exactly one outcome.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import os
import signal
import threading
import time
import traceback
import uuid
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import dask
from distributed import Client, LocalCluster, as_completed
from distributed.scheduler import KilledWorker

from .._cpu_time import work_time
from .batches import default_batch_size, kernel_key, make_batches
from .cases import Case

if TYPE_CHECKING:
    from ..robot import Robot
    from ..scenario.spec import RobotSpec

__all__ = [
    "QUIET_WORKERS",
    "n_workers",
    "run_batch",
    "run_case",
    "run_cases",
    "shutdown",
    "start_client",
    "summary_scalars",
    "warm_up",
]

WARMUP_STEPS = 20

#: [bytes] A case's rows held in memory before its recorder spills them (``simulate``'s
#: ``memory_bytes``; a single run's chunk is 32 MiB). A case's rows are read once, for its row
#: of the table, and never recovered (a worker that dies has its case run again), so spilling
#: them is only a cost: 13 us a step of a 40 s ``spatial-realistic`` case, 14 % of its loop
#: (benchmarks/README.md, "A campaign case's rows in memory"). This bounds a worker's memory
#: for its rows; a longer case spills the rest as a single run does.
CASE_MEMORY_BYTES = 256 * 2**20

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
    """A client of a new LocalCluster or of a running scheduler.

    Parameters
    ----------
    n_workers : int or None
        Worker processes of the new LocalCluster, one thread each (default: one per core).
    scheduler : str or None
        Address of a running scheduler (``tcp://host:port``) instead of a new cluster.
    quiet : bool
        Silence the cluster's logs below CRITICAL (else below ERROR).

    Returns
    -------
    tuple
        The client and the cluster (None for a running scheduler). The cluster's threads and
        processes block SIGINT (module docstring); a Ctrl-C while it starts takes effect once
        it has started, and it is closed again.
    """
    if scheduler is not None:
        return Client(scheduler, timeout="20s"), None
    n = n_workers or os.cpu_count() or 1
    cluster = None
    try:
        with warnings.catch_warnings():  # "port 8787 in use" when another cluster runs: harmless
            warnings.simplefilter("ignore")
            # the nannies pass this config to their workers
            with _sigint_blocked(), dask.config.set(QUIET_WORKERS):
                cluster = LocalCluster(
                    n_workers=n,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    silence_logs=logging.CRITICAL if quiet else logging.ERROR,
                )
        return Client(cluster), cluster
    except BaseException:
        if cluster is not None:
            shutdown(None, cluster)
        raise


def _sigint_blocked() -> AbstractContextManager[object]:
    """Block SIGINT in the calling (main) thread for the ``with`` block.

    A thread inherits the signal mask of the thread that starts it and a process that of the
    thread that forks it, across ``exec`` too: the cluster's event-loop thread, started in the
    block, and every worker process it ever spawns never see SIGINT (otherwise each worker
    prints a traceback of its interrupted event loop on Ctrl-C). A SIGINT that arrives in the
    block is delivered to this thread when the block ends.
    """
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not (
        threading.main_thread()
    ):
        return contextlib.nullcontext()
    # multiprocessing's resource tracker, started by the first queue of the cluster, unblocks
    # SIGINT in the thread that starts it: started now, it has nothing left to unblock
    from multiprocessing import resource_tracker

    resource_tracker.ensure_running()
    stack = contextlib.ExitStack()
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    if signal.SIGINT not in old:
        stack.callback(signal.pthread_sigmask, signal.SIG_UNBLOCK, {signal.SIGINT})
    return stack


def shutdown(client: Client | None, cluster: LocalCluster | None) -> None:
    """Close ``client`` and then ``cluster`` (either may be None) without a word.

    Dask logs (or raises) ``CancelledError``, ``CommClosedError`` and the like while tasks are
    cancelled and connections close, e.g. after a Ctrl-C; those are silenced here: the
    ``distributed``, ``tornado`` and ``asyncio`` loggers of this process and (for a cluster of
    our own) of its workers stay silent from now on. A second Ctrl-C while closing still
    interrupts (the cluster's processes end with this one).

    Parameters
    ----------
    client : distributed.Client or None
        The Dask client.
    cluster : distributed.LocalCluster or None
        The cluster of our own.
    """
    _silence_logs()
    if client is not None and cluster is not None:  # our own workers: they log as they close
        with contextlib.suppress(Exception, asyncio.CancelledError):
            client.run(_silence_logs, on_error="ignore")
    for close in (getattr(client, "close", None), getattr(cluster, "close", None)):
        if close is not None:
            with contextlib.suppress(Exception, asyncio.CancelledError):
                close()


def _silence_logs() -> None:
    """No more logs from Dask and its event loop in this process (a worker's, or ours)."""
    for name in ("distributed", "tornado", "asyncio"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def warm_up(scenario_toml: str) -> None:
    """Run :data:`WARMUP_STEPS` steps of a scenario, so that the kernels its cases run are
    compiled (and saved to numba's on-disk cache) or loaded; never raises (a case that fails
    the same way reports it).

    Parameters
    ----------
    scenario_toml : str
        The scenario (a case's resolved scenario).
    """
    try:
        from ..scenario.file import scenario_from_toml
        from ..sim.run import prepare, simulate

        sc = scenario_from_toml(scenario_toml)
        sc = dataclasses.replace(sc, duration=WARMUP_STEPS * sc.dt)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate(prepare(sc))
    except Exception:  # noqa: BLE001 - a case that fails the same way reports it
        pass


def summary_scalars(summary: dict[str, Any]) -> dict[str, Any]:
    """The scalar entries of a run's summary.json (lists such as final_err_z are left out)."""
    return {k: v for k, v in summary.items() if v is None or isinstance(v, (bool, int, float, str))}


def run_case(
    scenario_toml: str,
    keep_dir: str | None = None,
    robots: Callable[[RobotSpec], Robot] | None = None,
) -> dict[str, Any]:
    """Simulate one case (on a worker): ``{"status", "error", **summary scalars}``.

    ``status`` is ``"completed"``, ``"stopped"`` (the run stopped early: a result) or
    ``"error"`` (the run raised; ``error`` holds the exception and where it happened);
    ``case_wall_s`` and ``case_cpu_s`` are the case's wall and CPU time on the worker [s], the
    CPU time of its thread and of the helper thread its after-run signals use
    (:mod:`ffsm_pin._cpu_time`).
    ``keep_dir``: write the run folder there as ``python -m ffsm_pin.sim`` does.

    Parameters
    ----------
    scenario_toml : str
        The case's resolved scenario.
    keep_dir : str or None
        Where to write the run folder; None: nowhere.
    robots : callable or None
        Where the run's robot comes from (a batch's
        :class:`~ffsm_pin.sim.robots.SharedRobots`); None: loaded from its URDF.

    Returns
    -------
    dict
        The outcome.
    """
    from ..scenario.file import scenario_from_toml
    from ..sim.run import prepare, simulate
    from .explain import case_extras

    wall0, cpu0 = time.perf_counter(), work_time()
    try:
        scenario = scenario_from_toml(scenario_toml)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            setup = prepare(scenario, robots=robots)
            result = simulate(setup, memory_bytes=CASE_MEMORY_BYTES)
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


def run_batch(
    scenario_tomls: Sequence[str],
    keep_dirs: Sequence[str | None] | None = None,
    after: object = None,
) -> list[dict[str, Any]]:
    """Simulate the cases of a batch one after the other (the task a worker runs).

    Each case is :func:`run_case`, with the robots of the batch loaded once
    (:class:`~ffsm_pin.sim.robots.SharedRobots`: every case gets its own copy); a case that
    raises is an ``error`` outcome of its own and the next case runs.

    Parameters
    ----------
    scenario_tomls : sequence of str
        The cases' resolved scenarios.
    keep_dirs : sequence of (str or None), or None
        Per case, where to write its run folder; None: nowhere.
    after : object
        Not read: what the batch's task waits for (:func:`run_cases` passes the futures of
        the warm-ups of the batch's kernels; Dask runs a task once its arguments are done).

    Returns
    -------
    list of dict
        The outcomes, in the order of the cases.
    """
    from ..sim.robots import SharedRobots

    robots = SharedRobots()
    keeps = [None] * len(scenario_tomls) if keep_dirs is None else list(keep_dirs)
    return [run_case(t, k, robots) for t, k in zip(scenario_tomls, keeps, strict=True)]


def _cost(wall0: float, cpu0: float) -> dict[str, float]:
    """Wall and CPU time of the whole case on its worker (parse, set-up, simulation, summary,
    run folder) [s]; the summary's wall_time_s covers the simulation loop only."""
    return {"case_wall_s": time.perf_counter() - wall0, "case_cpu_s": work_time() - cpu0}


def n_workers(client: Client) -> int:
    """Workers of the client's cluster now (at least 1).

    Parameters
    ----------
    client : distributed.Client
        The Dask client.

    Returns
    -------
    int
        The count.
    """
    return max(1, len(client.scheduler_info().get("workers", {})))


def run_cases(
    client: Client,
    cases: Iterable[Case],
    keep_runs: Path | None = None,
    batch_size: int | None = None,
) -> Iterator[tuple[Case, dict[str, Any]]]:
    """Submit the cases in batches (:func:`run_batch`); yield ``(case, outcome)`` per case as
    batches finish.

    First one :func:`warm_up` task per robot and controller type
    (:func:`~ffsm_pin.sweep.batches.kernel_key`), of its first case, ahead of the batches
    (a priority); each batch waits for the warm-ups of its cases' pairs.

    Closing the generator (or an exception in the caller, e.g. Ctrl-C) cancels what is left.

    Parameters
    ----------
    client : distributed.Client
        The Dask client.
    cases : iterable of Case
        The cases to run.
    keep_runs : Path or None
        Folder the run folders are kept in; None: not kept.
    batch_size : int or None
        Most cases in a batch (:func:`~ffsm_pin.sweep.batches.make_batches`); None:
        :func:`~ffsm_pin.sweep.batches.default_batch_size` for the cluster's workers.

    Yields
    ------
    case : Case
        A finished case.
    outcome : dict
        Its outcome (:func:`run_case`).
    """
    cases = list(cases)
    if not cases:
        return
    size = batch_size or default_batch_size(len(cases), n_workers(client))
    token = uuid.uuid4().hex[:8]
    futures: dict[Any, tuple[Any, list[Case], bool]] = {}  # key -> (future, batch, waits)
    pending = set()
    # each robot and controller: its kernels compiled once, by one warm-up task that its
    # batches wait for (else every worker that reaches them first compiles them too)
    warm: dict[Any, Any] = {}
    for case in cases:
        key = kernel_key(case)
        if key not in warm:
            warm[key] = client.submit(
                warm_up, case.scenario_toml, key=f"ffsm-warm-{case.index}-{token}",
                pure=False, retries=1, priority=1,
            )  # fmt: skip

    def submit(batch: list[Case], key: str, wait: bool = True):
        tomls = [c.scenario_toml for c in batch]
        keeps = None
        if keep_runs is not None:
            keeps = [str(keep_runs / f"case-{c.index:05d}") for c in batch]
        # the warm-ups of the batch's kernels (none for a batch submitted again: a warm-up
        # lost with its worker does not fail it twice)
        after = [warm[k] for k in dict.fromkeys(map(kernel_key, batch))] if wait else []
        fut = client.submit(run_batch, tomls, keeps, after, key=key, pure=False, retries=1)
        futures[fut.key] = (fut, batch, bool(after))
        pending.add(fut.key)
        return fut

    for batch in make_batches(cases, size):
        first = batch[0]
        submit(batch, f"ffsm-batch-{first.index}-{len(batch)}-{first.case_hash}-{token}")
    resubmitted: set[str] = set()
    try:
        completed = as_completed([f for f, _, _ in futures.values()])
        for fut in completed:
            _, batch, waited = futures[fut.key]
            pending.discard(fut.key)
            try:
                outcomes = fut.result()
            except Exception as exc:  # noqa: BLE001 - the cluster's, not a case's (run_case)
                again = waited or not isinstance(exc, KilledWorker)  # (a warm-up's, maybe)
                if again and batch[0].case_hash not in resubmitted:
                    # a failure of the cluster's machinery around a worker that died (seen:
                    # an asyncio object bound to the dead worker's loop), or of a warm-up the
                    # batch waited for: the batch once more, waiting for nothing
                    resubmitted.add(batch[0].case_hash)
                    fut.release()
                    completed.add(submit(batch, f"{fut.key}-again", wait=False))
                    continue
                text = f"{type(exc).__name__}: {exc}"
                outcomes = [{"status": "error", "error": text} for _ in batch]
            fut.release()
            yield from zip(batch, outcomes, strict=True)
    finally:
        left = [futures[k][0] for k in pending]
        left += [w for w in warm.values() if not w.done()]
        if left:  # the client may be closing already (Ctrl-C): nothing to cancel then
            with contextlib.suppress(Exception, asyncio.CancelledError):
                client.cancel(left, force=True)
