"""What a killed run left: its spool read back into a run result (``--recover``, docs/cli.md).

A run longer than the recorder's memory chunk spills its rows into a spool folder inside its
output folder (:func:`ffsm_pin.sim.recorder.make_spool`), whose header (``spool.json``) is
written before any row: the scenario as run and the shape of every signal. A run that ends
normally removes its spool. One killed outright (``kill -9``, a power cut, a job scheduler's
time limit) leaves it; :func:`recover` rebuilds the run from the scenario (the robot, model and
funnels are deterministic), reads every row that reached every signal's file, computes the
signals the loop computes after a run (funnels, reference, errors, momentum, F_r; with a target
or wheels the whole system's, :mod:`.system_signals`, and a capture from the grasp the spool
noted, ``capture.json``) and returns a result with ``completed = False`` and
``stop_cause = "recovered"``. The rows still in memory
when the process died (at most one chunk, :data:`~ffsm_pin.sim.recorder.CHUNK_BYTES`) are
lost.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

from ..errors import FfsmError, ScenarioError, SimulationError
from .files import pid_alive
from .recorder import SPOOL_FORMAT, SPOOL_HEADER, SPOOL_PREFIX, Signals
from .result import RunResult
from .setup import Setup

__all__ = ["Recovered", "find_spools", "recover"]


@dataclass
class Recovered:
    """A run read back from its spool.

    Attributes
    ----------
    folder : Path
        The run's output folder (where the spool lies).
    spool : Path
        The spool folder (removed once ``result`` is no longer used).
    setup : Setup
        The run rebuilt from the scenario in the spool's header.
    result : RunResult
        The recovered run (``completed = False``, ``stop_cause = "recovered"``).
    """

    folder: Path
    spool: Path
    setup: Setup
    result: RunResult


def find_spools(folder: str | Path) -> list[Path]:
    """The spool folders in ``folder`` (or ``folder`` itself when it is one)."""
    folder = Path(folder)
    if not folder.is_dir():
        what = "not found" if not folder.exists() else "not a folder"
        raise ScenarioError(f"--recover {str(folder)!r}: {what}")
    if (folder / SPOOL_HEADER).is_file():
        return [folder]
    return sorted(p for p in folder.glob(f"{SPOOL_PREFIX}*") if (p / SPOOL_HEADER).is_file())


def recover(folder: str | Path) -> list[Recovered]:
    """Every run a killed process left in ``folder`` (its spools), read back.

    Raises
    ------
    FfsmError
        No spool in ``folder``, a spool whose run is still going, an unreadable header, or a
        scenario that no longer prepares (its robot file moved, say).
    """
    spools = find_spools(folder)
    if not spools:
        raise ScenarioError(
            f"--recover {str(folder)!r}: no spool of a killed run there (a run leaves one when "
            "it ends without writing its files after recording more rows than fit in memory)"
        )
    return [_recover(spool) for spool in spools]


def _recover(spool: Path) -> Recovered:
    from ..scenario.file import scenario_from_toml
    from .capture_run import target_motions
    from .recording import run_result, stop_outcome
    from .setup import prepare
    from .system_signals import system_outcomes, system_signals
    from .wheels_run import loop_plant

    try:
        header = json.loads((spool / SPOOL_HEADER).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ScenarioError(f"{spool / SPOOL_HEADER}: unreadable spool header ({exc})") from None
    if not isinstance(header, dict) or header.get("format") != SPOOL_FORMAT:
        raise ScenarioError(f"{spool / SPOOL_HEADER}: not a spool of this version ({SPOOL_FORMAT})")
    pid = int(header.get("pid", 0))
    if pid_alive(pid) and header.get("host") == _host():
        raise ScenarioError(
            f"{spool}: the run that writes this spool is still going (pid {pid}); stop it first"
        )
    shapes = {k: tuple(v) for k, v in header["shapes"].items()}
    rows = _complete_rows(spool, shapes)
    try:
        scenario = scenario_from_toml(header["scenario_toml"])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # (said when the run started)
            setup = prepare(scenario)
    except FfsmError as exc:
        raise ScenarioError(f"{spool}: the run's scenario no longer prepares: {exc}") from None
    raw = Signals({}, spool, shapes, rows)  # owns the spool: removed when no longer used
    # a target's and the wheels' momentum, and the grasp the spool noted (capture.json)
    _, capture = target_motions(setup)
    plant, wheels = loop_plant(setup)
    if capture is not None and (spool / "capture.json").is_file():
        capture.restore(json.loads((spool / "capture.json").read_text(encoding="utf-8")), plant)
    signals = system_signals(setup, raw, capture, wheels)
    t_last = float(signals["t"][-1]) if rows else 0.0
    reason = (
        f"recovered from the spool of a run that ended without writing its files (process "
        f"{pid}, started {header.get('started', '?')}); its last row on disk: t = {t_last:.4f} s"
    )
    result = run_result(
        setup,
        signals,
        steps=int(round(t_last / setup.scenario.dt)),
        wall_time_s=0.0,
        **stop_outcome(SimulationError(reason, time=t_last, cause="recovered")),
        events=list(setup.events),
        saturation_fraction=math.nan,  # counted by the loop, not recorded
        capture=None if capture is None else capture.outcome,
        outcomes=system_outcomes(signals, capture, wheels, None),
    )
    return Recovered(spool.parent, spool, setup, result)


def _complete_rows(spool: Path, shapes: dict[str, tuple[int, ...]]) -> int:
    """Rows that reached every signal's file (a spill cut short leaves some files longer)."""
    rows = None
    for key, shape in shapes.items():
        path = spool / f"{key}.bin"
        width = 8 * math.prod(shape)
        n = path.stat().st_size // width if path.is_file() else 0
        rows = n if rows is None else min(rows, n)
    return rows or 0


def _host() -> str:
    import socket

    return socket.gethostname()
