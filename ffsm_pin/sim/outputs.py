"""A run's output folder: its files written as a whole (docs/cli.md, "What is kept when
something fails"), through :class:`~ffsm_pin.sim.files.RunFolder`."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .files import RunFolder, held_interrupt, output_error
from .result import FIGURE_ROWS, RunResult

if TYPE_CHECKING:
    from ..scenario.spec import Scenario


def write_outputs(
    folder: str | Path,
    result: RunResult,
    scenario: Scenario | None = None,
    robot: Any = None,
    *,
    figures: bool = False,
    replay: bool = False,
    compress: bool = False,
    warn: Callable[[str], None] | None = None,
) -> dict:
    """Write a run's files into ``folder`` as a whole; return its summary.

    Parameters
    ----------
    folder : str or Path
        The output folder; an earlier run there is replaced only once every new file is
        complete.
    result : RunResult
        The run.
    scenario : Scenario or None
        The scenario as run (``scenario.toml``), or None.
    robot : Any
        The run's robot, for ``replay.html``.
    figures, replay : bool
        Draw the figures (``fig_*.png``) and ``replay.html``. A failure to draw them that is
        not an I/O error is reported through ``warn`` and the other files are written.
    compress : bool
        Deflate ``trajectory.npz`` (:meth:`~ffsm_pin.sim.result.RunResult.save`).
    warn : callable or None
        Called with a message when a figure or the replay could not be drawn.

    Raises
    ------
    OutputError
        A file could not be written (full disk, file-size limit, permissions): the message
        names it; the folder keeps the earlier run.

    Returns
    -------
    dict
        The run's summary.
    """
    from ..scenario.writer import scenario_to_toml

    warn = warn or (lambda message: print(f"warning: {message}", file=sys.stderr))
    with held_interrupt(warn), RunFolder(folder) as out:
        try:
            summary = result.write_data(out)
            if scenario is not None:
                out.path("scenario.toml").write_text(scenario_to_toml(scenario), encoding="utf-8")
            thin = result.thinned(FIGURE_ROWS) if figures or replay else result
            if figures:
                _drawn("figures", warn, _draw_figures, thin, out.staging)
            if replay and robot is not None:
                _drawn("replay.html", warn, _draw_replay, robot, thin, out.path("replay.html"))
        except OSError as exc:
            raise output_error(exc, Path(folder)) from None
        out.commit()
    return summary


def _draw_figures(result: RunResult, folder: Path) -> None:
    from .figures import write_figures  # matplotlib only when figures are drawn

    write_figures([result], folder)


def _draw_replay(robot: Any, result: RunResult, path: Path) -> None:
    from .replay import write_replay_html

    write_replay_html(robot, result, path)


def _drawn(what: str, warn: Callable[[str], None], fn: Callable[..., Any], *args: Any) -> None:
    """Draw an output that is not the recording: an I/O error fails the whole set (the disk
    is full), any other failure is reported and the run's data are written without it."""
    try:
        fn(*args)
    except OSError:
        raise
    except Exception as exc:  # noqa: BLE001 - reported, the run's data are still written
        warn(f"could not write {what}: {type(exc).__name__}: {exc}")
