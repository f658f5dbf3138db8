"""The plotting helpers of the run figures (:mod:`.figures`, :mod:`.capture_figures`): the
panel grid, the thinned line plot (a min/max envelope per pixel column, so that peaks survive
decimation), the runs' stops and the legends.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # no display needed; must precede any pyplot import anywhere

import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

MAX_COLUMNS = 1500  # envelope bins per line (2 points each)


def _grid(rows: int, title: str, runs) -> tuple[Figure, list[Axes]]:
    fig = Figure(figsize=(8.0, 1.75 * rows + 0.8), layout="constrained")
    axes = list(fig.subplots(rows, 1, sharex=True))
    names = ", ".join(f"{r.scenario_name} ({r.scheme or r.controller})" for r in runs)
    fig.suptitle(f"{title}\n{names}", fontsize=10)
    for ax in axes:
        ax.grid(True, linewidth=0.3, alpha=0.6)
        ax.tick_params(labelsize=8)
        ax.yaxis.label.set_size(9)
    t_end = max((float(r["t"][-1]) for r in runs if len(r["t"])), default=1.0)
    axes[-1].set_xlim(0.0, max(t_end, max(r.duration for r in runs)))
    axes[-1].set_xlabel("t [s]")
    return fig, axes


def _finish(axes, runs, ylabels, legends) -> None:
    """The panels' y labels, the runs' stops on every panel and a legend on the panels
    ``legends`` (indices)."""
    for ax, ylabel in zip(axes, ylabels, strict=True):
        ax.set_ylabel(ylabel)
        _mark_stops(ax, runs)
    for i in legends:
        _legend(axes[i], loc="upper right", fontsize=8)


def _legend(ax: Axes, **style) -> None:
    """A legend, when the panel has labelled lines (a panel may be empty: _note_absent)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**style)


def _mark_stops(ax: Axes, runs) -> None:
    for k, run in enumerate(runs):
        if not run.completed and len(run["t"]):
            t_stop = run.stop_time if run.stop_time is not None else float(run["t"][-1])
            ax.axvline(t_stop, color=f"C{k}", linestyle="--", linewidth=0.8, alpha=0.8)


def _plot(ax: Axes, x, y, *, envelope: bool = True, **style) -> None:
    """Plot y(x), thinned: a min/max envelope per bin if ``envelope``, else a plain stride."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if envelope:
        x, y = envelope_decimate(x, y, MAX_COLUMNS)
    else:
        step = max(1, len(x) // (2 * MAX_COLUMNS))
        if step > 1:
            x, y = np.append(x[::step], x[-1]), np.append(y[::step], y[-1])
    style.setdefault("linewidth", 1.0)
    ax.plot(x, y, **style)


def envelope_decimate(x: np.ndarray, y: np.ndarray, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Keep, per bin of consecutive samples, the samples with the smallest and largest y.

    At most ``2 * bins + 2`` points remain, in their original order; non-finite values are
    kept (they are where a diverging run ends).

    Parameters
    ----------
    x, y : ndarray
        The samples.
    bins : int
        Number of bins.

    Returns
    -------
    x, y : ndarray
        The samples kept.
    """
    n = len(y)
    if n <= 2 * bins:
        return x, y
    size = n // bins
    m = size * bins
    block = y[:m].reshape(bins, size)
    finite = np.where(np.isfinite(block), block, 0.0)
    i_min = np.argmin(finite, axis=1) + np.arange(bins) * size
    i_max = np.argmax(finite, axis=1) + np.arange(bins) * size
    idx = np.concatenate([i_min, i_max, np.arange(m, n), [0, n - 1]])
    bad = np.flatnonzero(~np.isfinite(y))
    if bad.size:
        idx = np.concatenate([idx, bad[:1]])
    idx = np.unique(idx)
    return x[idx], y[idx]
