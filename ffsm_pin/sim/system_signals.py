"""The whole system's signals and summary keys after a run with a target or wheels (issue
40), shared by the run loop and a run recovered from its spool (:mod:`.recover`).

:func:`system_signals` computes the signals after the run (:func:`.recording.recorded_signals`)
with the whole system's momentum (robot, target before the capture, the merged robot after it,
the wheels' stored momentum R_b A h) and the merged robot's true parameters after a capture
(:mod:`.held_truth`); :func:`system_outcomes` gives the summary keys the capture and the wheels
add: the capture's, ``detumble_time``, the final estimate errors against the merged robot, the
wheels' saturation fraction.
"""

from __future__ import annotations

from .capture_run import CaptureMotion
from .detumble import detumble_outcome
from .recorder import Signals
from .recording import recorded_signals
from .setup import Setup
from .wheels_run import MomentumRows, WheelsInLoop, WheelsOutcome

__all__ = ["system_outcomes", "system_signals"]


def system_signals(
    setup: Setup,
    raw: Signals,
    capture: CaptureMotion | None,
    wheels: WheelsInLoop | None,
    reaction=None,
    plant=None,
) -> Signals:
    """Every signal of the run, the whole system's momentum and truths included.

    Parameters
    ----------
    setup : Setup
        The run.
    raw : Signals
        The recorded rows.
    capture : CaptureMotion or None
        The run's capture hook (in its state at the run's end).
    wheels : WheelsInLoop or None
        The run's wheels.
    reaction, plant : optional
        :func:`~.recording.recorded_signals`' F_r pass and plant (made anew when None).

    Returns
    -------
    Signals
        The signals.
    """
    momentum: MomentumRows | None = None if capture is None else capture.momentum_rows
    if wheels is not None:
        momentum = wheels.total_momentum_rows(momentum)
    held = None if capture is None else capture.truth  # the merged robot's thetas, if held
    extra = None if held is None else held.constants()
    return recorded_signals(setup, raw, reaction, plant, momentum, extra)


def system_outcomes(
    signals: Signals,
    capture: CaptureMotion | None,
    wheels: WheelsInLoop | None,
    periods: int | None,
) -> tuple:
    """The summary keys of the capture and the wheels (none without either).

    Parameters
    ----------
    signals : Signals
        The run's signals (:func:`system_signals`).
    capture : CaptureMotion or None
        The run's capture hook.
    wheels : WheelsInLoop or None
        The run's wheels.
    periods : int or None
        Control periods run, for the wheels' saturation fraction; None: a recovered run,
        whose fraction is read from the recorded torques and commands (NaN for a recording
        without the commands).

    Returns
    -------
    tuple
        Objects with ``summary()`` (the run result's ``outcomes``).
    """
    out: tuple = ()
    if wheels is not None:
        if periods is not None:
            out += (wheels.outcome(periods),)
        elif "wheel_torque_cmd" in signals:
            out += (wheels.recorded_outcome(signals.blocks),)
        else:
            out += (WheelsOutcome(float("nan"), wheels.wheels),)
    held = None if capture is None else capture.truth
    if held is not None:  # the final estimate errors against the merged robot's
        out += (held.outcome(signals),)
    if capture is not None:  # when the held target stops turning relative to the bus
        rate = capture.detumble_rate  # [capture] detumble_rate [rad/s]
        out += (detumble_outcome(signals.blocks, capture.outcome.time, rate),)
    return out
