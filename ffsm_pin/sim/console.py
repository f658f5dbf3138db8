"""What ``python -m ffsm_pin.sim`` prints: the progress bar and warning lines on stderr
(:class:`Console`), the result table on stdout and a stopped run's line (docs/cli.md)."""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from .result import RunResult


def stop_line(result: RunResult) -> str:
    """One line: at which time the run stopped, and why."""
    t = result.stop_time
    if t is None and len(result["t"]):
        t = float(result["t"][-1])
    reason = (result.stop_reason or "unknown reason").replace("\n", " ")
    when = f"t = {t:.4g} s" if t is not None else "an unknown time"
    if reason.startswith("t ="):
        return f"run stopped early: {reason}"
    return f"run stopped early at {when}: {reason}"


def result_table(results: Sequence[RunResult], folders: Sequence[Path]) -> str:
    """The short table printed at the end: one column per run.

    Parameters
    ----------
    results : sequence of RunResult
        The runs.
    folders : sequence of Path
        Their output folders.

    Returns
    -------
    str
        The table.
    """
    columns = [_column(r, f) for r, f in zip(results, folders, strict=True)]
    keys = list(columns[0])
    if len(results) == 1:
        keys.remove("scenario")
    width = max(len(k) for k in keys)
    cols = [max(len(c[k]) for k in keys) for c in columns]
    lines = []
    for key in keys:
        cells = "  ".join(c[key].ljust(w) for c, w in zip(columns, cols, strict=True))
        lines.append(f"{key.ljust(width)}  {cells}".rstrip())
    return "\n".join(lines)


def _column(r: RunResult, folder: Path) -> dict[str, str]:
    from ..control.registry import controller_label  # (loads the controllers: not at import)

    s = r.summary()
    spatial = np.asarray(r["err_b"]).shape[-1] == 3  # (rows, m3), rows may be 0
    n_z = np.asarray(r["err_z"]).shape[-1]
    b_unit = "MRP" if spatial else "rad"
    z_unit = ("m" if n_z == 3 else "m,MRP") if spatial else ("m" if n_z == 2 else "m,m,rad")
    settle = f"{_num(s['settle_time_b'], '{:.2f}')} / {_num(s['settle_time_z'], '{:.2f}')}"
    return {
        "scenario": r.scenario_name,
        "controller": controller_label(r.controller) + (f" ({r.scheme})" if r.scheme else ""),
        "completed": _completed(r),
        "funnel b / z": f"{_kept(s['funnel_ok_b'])} / {_kept(s['funnel_ok_z'])}",
        "first violation [s]": _num(s["first_violation_t"], "{:.3f}"),
        f"final err_b [{b_unit}]": _vec(s["final_err_b"]),
        f"final err_z [{z_unit}]": _vec(s["final_err_z"]),
        "settle b / z [s]": settle,
        "max |u_m| [N m]": _num(s["max_abs_u"], "{:.4g}"),
        "max |F_r| [N m]": _num(s.get("max_abs_F_r"), "{:.4g}"),
        "min sigma_min [m]": _num(s.get("min_sigma"), "{:.3g}"),
        "drift P [kg m/s]": _num(s["drift_P"], "{:.2e}"),
        "drift L [kg m^2/s]": _num(s["drift_L"], "{:.2e}"),
        "simulated [s]": f"{s['simulated_time']:.3f} of {r.duration:g}",
        "wall time [s]": f"{r.wall_time_s:.2f}",
        "steps per second": _num(s["steps_per_s"], "{:.0f}"),
        "output": str(folder),
    }


def _completed(r: RunResult) -> str:
    if r.completed:
        return "yes"
    t = r.stop_time if r.stop_time is not None else (float(r["t"][-1]) if len(r["t"]) else 0)
    return f"no, stopped at {t:.3f} s"


def _kept(ok: bool) -> str:
    return "kept" if ok else "LEFT"


def _num(x, fmt: str) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-" if x is None else str(x)
    return fmt.format(x)


def _vec(values) -> str:
    if not values:
        return "-"
    return "[" + ", ".join(f"{v:.2e}" for v in values) + "]"


class Console:
    """Progress bar (tqdm, on stderr, erased at the end) and ``warning: ...`` lines.

    Parameters
    ----------
    quiet : bool
        No progress bar.
    stream : TextIO or None
        Where to write; None: standard error.
    width : int
        Width of the bar [characters].
    """

    def __init__(self, quiet: bool = False, stream: TextIO | None = None, width: int = 24):
        self.quiet = quiet
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self._bar = None
        self._dt = 1.0
        self._seen: set[str] = set()
        self.context = ""  # prefix of warnings (the run they belong to)
        self._interval = 0.1 if _isatty(self.stream) else 2.0  # [s] between redraws

    def start(self, name: str, duration: float, dt: float) -> None:
        """Open the progress bar of a run of ``duration`` [s] in steps of ``dt`` [s].

        Parameters
        ----------
        name : str
            The run's name.
        duration : float
            The run's horizon [s].
        dt : float
            Its step [s].
        """
        from tqdm import tqdm  # the same progress library as the campaigns (ffsm_pin.sweep)

        self._close()
        if self.quiet:
            return
        self._dt = dt
        self._bar = tqdm(
            total=duration,
            desc=name,
            file=self.stream,
            leave=False,
            mininterval=self._interval,
            ascii=".#",
            postfix="     0 steps/s",
            bar_format=f"{{desc}} [{{bar:{self.width}}}] {{n:6.2f}}/{{total:g}} s  {{postfix}}  "
            "ETA {remaining}",
        )
        self.progress(0.0)

    def progress(self, t: float) -> None:
        """Callback for :func:`ffsm_pin.sim.loop.simulate`: t = simulated time [s]."""
        bar = self._bar
        if bar is None:
            return
        elapsed = bar.format_dict["elapsed"]
        rate = t / self._dt / elapsed if elapsed > 0 else 0.0
        bar.set_postfix_str(f"{rate:6.0f} steps/s", refresh=False)
        bar.update(min(t, bar.total) - bar.n)

    def clear(self) -> None:
        """Erase the bar (it is drawn again at the next progress update of an unfinished run)."""
        if self._bar is None:
            return
        if self._bar.n >= self._bar.total:
            self._close()
        else:
            self._bar.clear()

    def _close(self) -> None:
        if self._bar is not None:
            try:
                self._bar.close()
            except (OSError, ValueError):  # closed pipe: progress is best effort
                pass
            self._bar = None

    def warn(self, message: str) -> None:
        """Print a ``warning:`` line without breaking the progress bar (unless quiet)."""
        if self.quiet:
            return
        self.clear()
        self._write(f"warning: {message}\n")

    def show_warning(self, message, category, filename, lineno, file=None, line=None) -> None:
        """Replacement for :func:`warnings.showwarning`: one ``warning: ...`` line.

        Parameters
        ----------
        message, category, filename, lineno, file, line : object
            As :func:`warnings.showwarning`'s; the message alone is written.
        """
        text = " ".join(str(message).split())
        if self.context:
            text = f"{self.context}: {text}"
        if text in self._seen:
            return
        self._seen.add(text)
        self.warn(text)

    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):  # closed pipe: progress is best effort
            pass


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False
