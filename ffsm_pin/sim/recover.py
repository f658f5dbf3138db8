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
from types import SimpleNamespace

import numpy as np

from ..control.interface import Measurement
from ..errors import FfsmError, ScenarioError, SimulationError
from .files import pid_alive
from .recorder import SPOOL_FORMAT, SPOOL_HEADER, SPOOL_PREFIX, Signals
from .result import RunResult
from .setup import Setup
from .target import TargetState

__all__ = ["Recovered", "find_spools", "recover", "replay_approach"]


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
    approach_note = None
    if setup.approach is not None:  # the reference the controller was given, from the rows
        approach_note = replay_approach(setup, raw, capture, int(header.get("record_every", 1)))
    signals = system_signals(setup, raw, capture, wheels)
    t_last = float(signals["t"][-1]) if rows else 0.0
    actuators = setup.actuators  # the joints' saturation from the recorded applied torques
    n = setup.model.n_joints
    saturation, per_joint = (
        (0.0, [0.0] * n) if actuators is None else actuators.saturation_of_rows(raw.blocks)
    )
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
        saturation_fraction=saturation,
        saturation_per_joint=per_joint,
        capture=None if capture is None else capture.outcome,
        outcomes=system_outcomes(signals, capture, wheels, None),
        blas=header.get("blas"),  # the killed run's (None from a spool older than the key)
        versions=header.get("versions"),
    )
    if approach_note is not None:
        result.events.append(approach_note)
    return Recovered(spool.parent, spool, setup, result)


def replay_approach(setup: Setup, raw: Signals, capture, record_every: int) -> str | None:
    """Fill the approach's log (the reference the controller was given, :mod:`.approach`)
    from the recorded rows: its update run again, period after period, on what the
    controller saw (``meas_*``, the true columns without sensors) and the target's recorded
    true state (``target_pose``, ``target_twist``), the capture from ``capture``'s restored
    outcome. The target sensor's noise is drawn from the same seeded stream in the same
    order, so the log equals the run's up to the rounding of the recorded attitude (a
    quaternion). A run that recorded every ``record_every`` > 1 periods lacks the states the
    sensor's delay buffer reads: with ``[approach]`` its log stays NaN (no reference); without
    one (a ``[capture]``'s hold alone) the reference before the grasp is the scenario's, and
    the bus-frame hold after it is rebuilt when the grasp's period was recorded (the hold's
    start), else NaN from the grasp on.

    Parameters
    ----------
    setup : Setup
        The recovered run (its approach as prepared: log empty, sensor stream unread).
    raw : Signals
        The recorded rows.
    capture : CaptureMotion or None
        The run's capture hook, restored from the spool's note.
    record_every : int
        The run's recording interval (the spool header's).

    Returns
    -------
    str or None
        Why the reference could not be recovered (an event of the result), or None.
    """
    approach = setup.approach
    assert approach is not None
    if record_every != 1 and approach.spec is not None:
        return (
            f"the approach's reference is not recovered: the run recorded every {record_every} "
            "periods, the target sensor's delay needs every one (z_e_d stays NaN)"
        )
    outcome = None if capture is None or not capture.outcome.captured else capture.outcome
    note, t_stop = None, math.inf  # (the hold alone, the grasp's period not recorded)
    if outcome is not None and round(outcome.time / approach.dt) % record_every != 0:
        note = (
            f"the bus-frame hold's reference after the grasp is not recovered: the run recorded "
            f"every {record_every} periods, not the grasp's (z_e_d is NaN from t = "
            f"{outcome.time:.4f} s on)"
        )
        t_stop = outcome.time
    seen = "meas_" if setup.sensors is not None else ""
    nq_root = setup.robot.root.nq
    keys = ["t", "target_pose", "target_twist"] + (
        [f"{seen}{k}" for k in ("q_b", "q_m", "w", "z_e", "z_e_dot")]
        if seen
        else ["q_b", "q", "w", "z_e", "z_e_dot"]
    )
    for block in raw.blocks(keys):
        q_m = block["meas_q_m"] if seen else block["q"][:, nq_root:]
        for i, t in enumerate(block["t"]):
            if t >= t_stop:
                return note
            state = TargetState.from_recorded(block["target_pose"][i], block["target_twist"][i])
            held = outcome is not None and t >= outcome.time
            row = SimpleNamespace(state=state, outcome=outcome if held else None)
            approach.motion = row  # type: ignore[assignment]  # (a TargetMotion's two fields)
            q_b = block[f"{seen}q_b"][i]
            meas = Measurement(
                float(t), q_b if q_b.size > 1 else float(q_b[0]), np.array(q_m[i]),
                np.array(block[f"{seen}w"][i]), np.array(block[f"{seen}z_e"][i]),
                np.array(block[f"{seen}z_e_dot"][i]),
            )  # fmt: skip
            approach.update(meas)
    return note


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
