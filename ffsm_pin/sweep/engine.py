"""Running cases on a Dask cluster (dask.distributed, used as a library).

* :func:`start_client`: a :class:`~distributed.LocalCluster` of ``n_workers`` single-threaded
  worker processes (default: one per core) started with :data:`QUIET_WORKERS`, or a client of a
  running scheduler. The cluster's threads and processes (also a worker started later in place
  of a dead one) block SIGINT: a Ctrl-C in the terminal, which the terminal sends to every
  process of the campaign, interrupts the campaign process alone, which then stops the cluster.
* :func:`shutdown`: close the client and the cluster without a word (no Dask traceback or log
  of the cancelled tasks and closed connections, also after a Ctrl-C).
* The tasks (:mod:`ffsm_pin.sweep.worker`, named here too): :func:`warm_up` runs a few steps
  of a case, so that the numba kernels of its robot and controller are compiled (and saved to
  numba's on-disk cache) or loaded before its cases run; :func:`run_cases` submits one per
  robot and controller type of the campaign, and their batches wait for it: on an empty cache
  each pair's kernels are compiled once for the cluster, by one worker, not by every worker
  that reaches them. :func:`run_case` runs one case; :func:`run_batch`, the task, a batch of
  cases that share a robot (:mod:`ffsm_pin.sweep.batches`), those lock-step takes together;
  each case gives the outcome it gives alone.
* :func:`run_cases`: submits the batches and yields ``(case, outcome)`` per case as tasks
  finish. A worker that dies has its tasks re-run on another worker by the scheduler (up to
  ``distributed.scheduler.allowed-failures`` times, then each case of the batch is an
  ``error``); each future yields once, so each case gives exactly one outcome.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import signal
import threading
import uuid
import warnings
from collections.abc import Iterable, Iterator
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any

import dask
from distributed import Client, LocalCluster, as_completed
from distributed.scheduler import KilledWorker

from .batches import default_batch_size, kernel_key, make_batches
from .cases import Case
from .worker import (
    CASE_MEMORY_BYTES,
    WARMUP_STEPS,
    run_batch,
    run_case,
    summary_scalars,
    warm_up,
)

__all__ = [
    "CASE_MEMORY_BYTES",
    "QUIET_WORKERS",
    "TRIM_VARIABLE",
    "WARMUP_STEPS",
    "n_workers",
    "run_batch",
    "run_case",
    "run_cases",
    "shutdown",
    "start_client",
    "summary_scalars",
    "warm_up",
]

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

#: The variable of Dask's ``distributed.nanny.pre-spawn-environ`` (65536 by default) the
#: campaign's workers start without: it makes glibc give every freed array above 128 KB back
#: to the system, so that each case's arrays are fresh memory again (page faults: 1.8 us a step
#: of the spatial cells on one worker, benchmarks/README.md "Recorder memory kept in the
#: worker"); the worker holds its last cases' memory instead.
TRIM_VARIABLE = "MALLOC_TRIM_THRESHOLD_"


def _worker_environ() -> dict[str, Any]:
    """The environment a nanny starts its worker with: Dask's (its defaults and any setting of
    yours) less :data:`TRIM_VARIABLE`."""
    environ = dask.config.get("distributed.nanny.pre-spawn-environ", default={}) or {}
    return {key: value for key, value in environ.items() if key != TRIM_VARIABLE}


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
            spawn = {"distributed.nanny.pre-spawn-environ": _worker_environ()}
            with _sigint_blocked(), dask.config.set({**QUIET_WORKERS, **spawn}):
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
