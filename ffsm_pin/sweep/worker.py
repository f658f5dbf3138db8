"""What a campaign's worker runs: the tasks :mod:`ffsm_pin.sweep.engine` submits.

* :func:`warm_up`: a task that runs a few steps of a case (alone and in lock-step), so that the
  numba kernels of its robot and controller are compiled (and saved to numba's on-disk cache)
  or loaded before its cases run.
* :func:`run_case`: one case. It never raises for a bad run: a run that raises becomes an
  ``error`` outcome with the error text, a run that stops early a ``stopped`` one.
* :func:`run_batch`: the task, a batch of cases that share a robot
  (:mod:`ffsm_pin.sweep.batches`), with the robot loaded once. The cases lock-step takes
  (:func:`ffsm_pin.sim.lockstep.lockstep_groups`) run together
  (:func:`ffsm_pin.sim.lockstep.simulate_lockstep`), the others one after the other; each case
  gives the outcome it gives alone (docs/campaigns.md, "Lock-step batches").
"""

from __future__ import annotations

import dataclasses
import functools
import time
import traceback
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .._cpu_time import work_time

if TYPE_CHECKING:
    from ..robot import Robot
    from ..scenario.spec import RobotSpec, Scenario
    from ..sim.chunk_pool import ChunkPool
    from ..sim.result import RunResult
    from ..sim.setup import Setup

__all__ = [
    "CASE_MEMORY_BYTES", "WARMUP_STEPS", "recorder_pool", "run_batch", "run_case",
    "summary_scalars", "warm_up",
]  # fmt: skip

#: Steps of a :func:`warm_up` run.
WARMUP_STEPS = 20

#: [bytes] A case's rows held in memory before its recorder spills them (``simulate``'s
#: ``memory_bytes``; a single run's chunk is 32 MiB). A case's rows are read once, for its row
#: of the table, and never recovered (a worker that dies has its case run again), so spilling
#: them is only a cost: 13 us a step of a 40 s ``spatial-realistic`` case, 14 % of its loop
#: (benchmarks/README.md, "A campaign case's rows in memory"). This bounds a worker's memory
#: for its rows; a longer case spills the rest as a single run does.
CASE_MEMORY_BYTES = 256 * 2**20


def warm_up(scenario_toml: str) -> None:
    """Run :data:`WARMUP_STEPS` steps of a scenario, alone and, when lock-step takes it, two
    copies in lock-step, so that the kernels its cases run are compiled (and saved to numba's
    on-disk cache) or loaded; never raises (a case that fails the same way reports it).

    Parameters
    ----------
    scenario_toml : str
        The scenario (a case's resolved scenario).
    """
    try:
        from ..scenario.file import scenario_from_toml
        from ..sim.lockstep import lockstep_obstacle, simulate_lockstep
        from ..sim.run import prepare, simulate

        sc = scenario_from_toml(scenario_toml)
        sc = dataclasses.replace(sc, duration=WARMUP_STEPS * sc.dt)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            setup = prepare(sc)
            if lockstep_obstacle(setup) is None:
                simulate_lockstep([setup, prepare(sc)])
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
    wall0, cpu0 = time.perf_counter(), work_time()
    try:
        scenario, setup = _prepared(scenario_toml, robots)
    except Exception as exc:  # noqa: BLE001 - recorded in the row, the campaign goes on
        return _error(exc, wall0, cpu0)
    return _simulated(scenario, setup, keep_dir, wall0, cpu0)


def _prepared(scenario_toml: str, robots) -> tuple[Scenario, Setup]:
    from ..scenario.file import scenario_from_toml
    from ..sim.run import prepare

    scenario = scenario_from_toml(scenario_toml)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return scenario, prepare(scenario, robots=robots)


def _error(exc: Exception, wall0: float, cpu0: float, shared=(0.0, 0.0)) -> dict[str, Any]:
    where = traceback.extract_tb(exc.__traceback__)[-1]
    text = f"{type(exc).__name__}: {exc} ({Path(where.filename).name}:{where.lineno})"
    return {"status": "error", "error": " ".join(text.split()), **_cost(wall0, cpu0, shared)}


def _outcome(scenario, setup, result: RunResult, keep_dir, wall0, cpu0, shared=(0.0, 0.0)):
    """The outcome of a case whose run gave ``result``: its summary's scalars, the extras of
    the report, its cost (``shared``: its share of a lock-step run's wall and CPU time [s]),
    its run folder written to ``keep_dir``."""
    from .explain import case_extras

    try:
        summary = result.summary()
        extras = case_extras(setup, result, summary)  # lists, min_sigma_gjm, signals
        if keep_dir is not None:
            from ..sim.outputs import write_outputs

            write_outputs(Path(keep_dir), result, scenario, setup.robot, figures=True, replay=True)
    except Exception as exc:  # noqa: BLE001 - recorded in the row, the campaign goes on
        return _error(exc, wall0, cpu0, shared)
    status = "completed" if result.completed else "stopped"
    scalars = summary_scalars(summary)
    return {"status": status, "error": None, **scalars, **extras, **_cost(wall0, cpu0, shared)}


def run_batch(
    scenario_tomls: Sequence[str],
    keep_dirs: Sequence[str | None] | None = None,
    after: object = None,
    lockstep: bool = True,
) -> list[dict[str, Any]]:
    """Simulate the cases of a batch (the task a worker runs).

    The robots of the batch are loaded once (:class:`~ffsm_pin.sim.robots.SharedRobots`:
    every case gets its own copy). With ``lockstep``, the cases that lock-step takes run
    together (:func:`~ffsm_pin.sim.lockstep.simulate_lockstep`, the same results bit for bit;
    each case's ``case_wall_s`` and ``case_cpu_s`` then hold its share of the lock-step run,
    by its steps); the others, and all of them without ``lockstep``, one after the other as
    :func:`run_case`. A case that raises is an ``error`` outcome of its own; a lock-step run
    that raises has its cases run one by one.

    Parameters
    ----------
    scenario_tomls : sequence of str
        The cases' resolved scenarios.
    keep_dirs : sequence of (str or None), or None
        Per case, where to write its run folder; None: nowhere.
    after : object
        Not read: what the batch's task waits for (:func:`~ffsm_pin.sweep.engine.run_cases`
        passes the futures of the warm-ups of the batch's kernels; Dask runs a task once its
        arguments are done).
    lockstep : bool
        Run the cases lock-step takes together.

    Returns
    -------
    list of dict
        The outcomes, in the order of the cases.
    """
    from ..sim.lockstep import lockstep_groups, simulate_lockstep
    from ..sim.robots import SharedRobots

    robots = SharedRobots()
    tomls = list(scenario_tomls)
    keeps = [None] * len(tomls) if keep_dirs is None else list(keep_dirs)
    if not lockstep or len(tomls) < 2:
        return [run_case(t, k, robots) for t, k in zip(tomls, keeps, strict=True)]
    outcomes: list[dict[str, Any] | None] = [None] * len(tomls)
    ready: dict[int, tuple] = {}  # case -> (scenario, setup, its set-up's wall and CPU [s])
    for i, toml in enumerate(tomls):
        wall0, cpu0 = time.perf_counter(), work_time()
        try:
            scenario, setup = _prepared(toml, robots)
        except Exception as exc:  # noqa: BLE001 - the case's own error
            outcomes[i] = _error(exc, wall0, cpu0)
            continue
        ready[i] = (scenario, setup, time.perf_counter() - wall0, work_time() - cpu0)
    order = sorted(ready)
    for group in lockstep_groups([ready[i][1] for i in order]):
        cases = [order[g] for g in group]
        wall0, cpu0 = time.perf_counter(), work_time()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                results = simulate_lockstep(
                    [ready[i][1] for i in cases],
                    memory_bytes=CASE_MEMORY_BYTES,
                    pool=recorder_pool(),
                )
        except Exception:  # noqa: BLE001 - its cases run alone below, set up again
            for i in cases:
                outcomes[i] = run_case(tomls[i], keeps[i], robots)
            continue
        wall, cpu = time.perf_counter() - wall0, work_time() - cpu0
        total = sum(r.steps + 1 for r in results)
        for i, res in zip(cases, results, strict=True):
            part = (res.steps + 1) / total
            scenario, setup, own_wall, own_cpu = ready[i]
            start = (time.perf_counter() - own_wall, work_time() - own_cpu)  # (its own part)
            outcomes[i] = _outcome(scenario, setup, res, keeps[i], *start,
                                   shared=(wall * part, cpu * part))  # fmt: skip
        del res  # (and the list: the recorders' memory back to the pool for the next group)
        results.clear()
    for i, (scenario, setup, own_wall, own_cpu) in ready.items():
        if outcomes[i] is None:  # one lock-step does not take: alone, on its set-up
            wall0, cpu0 = time.perf_counter() - own_wall, work_time() - own_cpu
            outcomes[i] = _simulated(scenario, setup, keeps[i], wall0, cpu0)
    return [o for o in outcomes if o is not None]


def _simulated(scenario, setup, keep_dir, wall0: float, cpu0: float) -> dict[str, Any]:
    """The outcome of the prepared ``setup`` run alone (``wall0``, ``cpu0``: when its case
    started, its set-up included)."""
    from ..sim.run import simulate

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = simulate(setup, memory_bytes=CASE_MEMORY_BYTES, pool=recorder_pool())
    except Exception as exc:  # noqa: BLE001 - recorded in the row, the campaign goes on
        return _error(exc, wall0, cpu0)
    return _outcome(scenario, setup, result, keep_dir, wall0, cpu0)


@functools.cache  # one per process, made by the first case that runs here
def recorder_pool() -> ChunkPool:
    """The worker process's :class:`~ffsm_pin.sim.chunk_pool.ChunkPool`: its cases' recorders
    reuse the memory of the cases before them (benchmarks/README.md, "Recorder memory kept in
    the worker").

    Returns
    -------
    ChunkPool
        The pool (one per process).
    """
    from ..sim.chunk_pool import ChunkPool

    return ChunkPool()


def _cost(wall0: float, cpu0: float, shared=(0.0, 0.0)) -> dict[str, float]:
    """Wall and CPU time of the whole case on its worker (parse, set-up, simulation, summary,
    run folder) [s], less the time of others' (a lock-step run's, which ``shared`` gives the
    case its part of); the summary's wall_time_s covers the simulation loop only."""
    wall, cpu = time.perf_counter() - wall0, work_time() - cpu0
    return {"case_wall_s": wall + shared[0], "case_cpu_s": cpu + shared[1]}
