"""The figures of a run with ``[capture]`` (issue 40), in :mod:`.figures`' conventions.

* ``fig_approach.png``: the distance between the hand's and the target's grasp frames [m]
  and the relative speed of the two bodies at the hand's grasp point [m/s] over time (the
  recorded ``grasp_distance`` and ``grasp_speed``), each with its ``[capture]`` tolerance
  (dashed) and the capture instant (a vertical line);
* ``fig_impulse.png``: the impact's impulse on the hand at its grasp frame, its axes: three
  bars [N s] and three bars [N m s] (runs that captured).

Only runs with ``[capture]`` have them; several runs are overlaid (the bars side by side).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .figure_kit import _finish, _grid, _legend, _plot

CAPTURE_FIGURE_NAMES = ("fig_approach.png", "fig_impulse.png")
_TOLERANCE_STYLE: dict[str, Any] = {"color": "black", "linestyle": "--", "linewidth": 0.9}


def write_capture_figures(runs, labels, out_dir: Path, dpi: int) -> list[Path]:
    """Draw the capture figures of the runs that have ``[capture]`` into ``out_dir``.

    Parameters
    ----------
    runs : list of RunResult
        The runs (those without ``grasp_distance`` are left out).
    labels : list
        Legend entry per run (None: no legend).
    out_dir : Path
        The folder.
    dpi : int
        Resolution of the PNG files.

    Returns
    -------
    list of Path
        The files written (none when no run has ``[capture]``).
    """
    kept = [(r, lab) for r, lab in zip(runs, labels, strict=True) if "grasp_distance" in r]
    if not kept:
        return []
    paths = []
    for name, draw in zip(CAPTURE_FIGURE_NAMES, (_approach, _impulse), strict=True):
        fig = draw([r for r, _ in kept], [lab for _, lab in kept])
        FigureCanvasAgg(fig)
        path = Path(out_dir) / name
        fig.savefig(path, dpi=dpi)
        paths.append(path)
    return paths


def _approach(runs, labels) -> Figure:
    fig, axes = _grid(2, "Approach: hand to the target's grasp frame", runs)
    for k, (run, label) in enumerate(zip(runs, labels, strict=True)):
        t, color = run["t"], f"C{k}"
        _plot(axes[0], t, run["grasp_distance"], color=color, label=label)
        _plot(axes[1], t, run["grasp_speed"], color=color)
        out = run.capture
        if out is None:
            continue
        for ax, tol in zip(axes, (out.tolerance_position, out.tolerance_velocity), strict=True):
            if tol is not None:
                ax.axhline(tol, label="tolerance" if k == 0 else None, **_TOLERANCE_STYLE)
            if out.captured:
                ax.axvline(out.time, color=color, linewidth=0.9, alpha=0.8,
                           label="capture" if k == 0 else None)  # fmt: skip
    for ax in axes:
        ax.set_yscale("symlog", linthresh=1e-3)
        ax.set_ylim(bottom=0.0)
    ylabels = ("grasp frames' distance [m]", "relative speed [m/s]")
    _finish(axes, runs, ylabels, legends=(0,))
    _legend(axes[1], loc="upper right", fontsize=8)
    return fig


def _impulse(runs, labels) -> Figure:
    fig = Figure(figsize=(8.0, 3.6), layout="constrained")
    axes = fig.subplots(1, 2)
    names = ", ".join(r.scenario_name for r in runs)
    fig.suptitle(f"Impact impulse on the hand (its grasp frame, its axes)\n{names}", fontsize=10)
    width = 0.8 / len(runs)
    for k, (run, label) in enumerate(zip(runs, labels, strict=True)):
        out = run.capture
        impulse = None if out is None or out.impulse is None else np.asarray(out.impulse)
        if impulse is None:
            continue
        x = np.arange(3) + (k - (len(runs) - 1) / 2) * width
        axes[0].bar(x, impulse[:3], width, color=f"C{k}", label=label)
        axes[1].bar(x, impulse[3:], width, color=f"C{k}")
    if not any(r.capture is not None and r.capture.captured for r in runs):
        axes[0].text(0.5, 0.5, "no capture", transform=axes[0].transAxes, ha="center")
    for ax, unit, sym in zip(axes, ("N s", "N m s"), ("p", "h"), strict=True):
        ax.set_xticks(range(3), [f"${sym}_{c}$" for c in "xyz"])
        ax.axhline(0.0, color="0.6", linewidth=0.6)
        ax.set_ylabel(f"[{unit}]")
        ax.grid(True, axis="y", linewidth=0.3, alpha=0.6)
    axes[0].set_title("linear", fontsize=9)
    axes[1].set_title("angular", fontsize=9)
    _legend(axes[0], fontsize=8)
    return fig
