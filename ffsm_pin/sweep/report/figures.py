"""The report's figures (matplotlib, Agg): the rate per grid point, distributions per grid
point, and per controller the median and worst runs against their funnels and the torques
against their limits (``fig_overlay_*.png``, from signals.parquet)."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .sql import query, quoted
from .text import is_number, label

__all__ = ["figures", "overlay_figures", "pick_runs"]


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figures(out: Path, cols, rates, points) -> dict[str, str]:
    """fig_funnel_rate.png, fig_max_u.png, fig_settle.png, fig_min_sigma.png; {name: file}.

    Parameters
    ----------
    out : Path
        The campaign folder.
    cols : sequence of str
        The grid's columns.
    rates : sequence of mapping
        The rows of ``RATE_SQL``, one per grid point.
    points : sequence of mapping
        The rows of ``POINTS_SQL``, one per run.

    Returns
    -------
    dict of str to str
        {name: file} of the figures drawn.
    """
    plt = _plt()
    labels = [label(r, cols) for r in rates]
    numeric = len(cols) == 1 and all(is_number(r[cols[0]]) for r in rates)
    xs = [float(r[cols[0]]) for r in rates] if numeric else list(range(len(rates)))
    files = {}

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    ok = [i for i, r in enumerate(rates) if r["rate"] is not None]
    ax.errorbar(
        [xs[i] for i in ok],
        [rates[i]["rate"] * 100 for i in ok],
        yerr=[  # >= 0: at a rate of 0 or 1 the bound equals the rate up to rounding
            [max(rates[i]["rate"] - rates[i]["rate_lo"], 0.0) * 100 for i in ok],
            [max(rates[i]["rate_hi"] - rates[i]["rate"], 0.0) * 100 for i in ok],
        ],
        fmt="o-",
        capsize=4,
    )
    ax.set_ylim(-5, 105)
    ax.set_ylabel("funnels kept [% of runs]")
    _xaxis(ax, cols, numeric, xs, labels)
    ax.set_title("funnel-keeping rate, 95 % Wilson intervals")
    ax.grid(alpha=0.3)
    files["rate"] = _save(fig, out / "fig_funnel_rate.png")

    groups: dict[str, list[dict[str, Any]]] = {lab: [] for lab in labels}
    for p in points:
        groups.setdefault(label(p, cols), []).append(p)
    have = set(points[0]) if points else set()
    u_key = "max_joint_torque" if "max_joint_torque" in have else "max_abs_u"
    s_key = "min_sigma_gjm" if "min_sigma_gjm" in have else "min_sigma"
    for key, name, ylabel, log in (
        (u_key, "max_u", {"max_abs_u": "max |u_m| (norm) over a run [N m]",
                          "max_joint_torque": "largest |u_i| over a run [N m]"}[u_key], True),
        ("settle_time_z", "settle", "settle time of err_z [s]", False),
        (s_key, "min_sigma", {"min_sigma": "min sigma over a run [m]",
                              "min_sigma_gjm": "min sigma_min(J*), true model [m]"}[s_key], False),
    ):  # fmt: skip
        fig, ax = plt.subplots(figsize=(6.4, 3.6))
        data = [[p[key] for p in groups[lab] if p[key] is not None] for lab in labels]
        pos = [x for x, d in zip(xs, data, strict=True) if d]
        width = 0.6 * (min(_gaps(xs)) if numeric and len(xs) > 1 else 1.0)
        if pos:
            ax.boxplot([d for d in data if d], positions=pos, widths=width, manage_ticks=False)
        if log and any(v > 0 for d in data for v in d):
            ax.set_yscale("log")
        if name == "min_sigma":  # the threshold of the controllers' damping
            thr = [p["damping_threshold"] for p in points if p["damping_threshold"] is not None]
            if thr:
                ax.axhline(thr[0], color="C3", ls="--", lw=1, label="damping threshold")
                ax.legend(loc="best")
        ax.set_ylabel(ylabel)
        _xaxis(ax, cols, numeric, xs, labels)
        ax.grid(alpha=0.3)
        files[name] = _save(fig, out / f"fig_{name}.png")
    return files


# ------------------------------------------------------------------------------ overlays
def pick_runs(runs: Sequence[Mapping[str, Any]]) -> tuple[Mapping[str, Any], Mapping[str, Any]]:
    """(median run, worst run) of one controller's runs.

    Worst: of the runs that did not keep both funnels, the one that left a funnel (or stopped)
    first; if every run kept them, the largest RMS end-effector error over the last half.
    Median: the run of median RMS end-effector error over the last half (the lower median;
    runs without one last).
    """
    late = sorted(
        (r for r in runs if r["rms_err_z_late"] is not None),
        key=lambda r: (r["rms_err_z_late"], r["case"]),
    )
    median = late[(len(late) - 1) // 2] if late else runs[0]
    failed = [r for r in runs if not r["kept"]]
    if failed:

        def when(r):
            t = r["first_violation_t"] if r["first_violation_t"] is not None else r["stop_time"]
            return (t is None, t if t is not None else 0.0, r["case"])

        return median, min(failed, key=when)
    return median, late[-1] if late else runs[-1]


def overlay_figures(
    out: Path, runs: Sequence[Mapping[str, Any]], by: tuple[str, ...], labels: Mapping[str, str]
) -> list[tuple[str, str, Mapping[str, Any], Mapping[str, Any]]]:
    """Per controller (and scenario), fig_overlay_<name>.png from ``signals.parquet`` in
    ``out``; [(title, file, median run, worst run)] of the figures drawn (none without the
    file).

    Parameters
    ----------
    out : Path
        The campaign folder.
    runs : sequence of mapping
        The rows of ``RUNS_SQL``.
    by : tuple of str
        Columns grouped by besides the controller (``("scenario",)`` or empty).
    labels : mapping of str to str
        Controller type -> its label.

    Returns
    -------
    list of tuple
        (title, file, median run, worst run) per figure.
    """
    path = out / "signals.parquet"
    if not path.is_file() or not runs:
        return []
    groups: dict[tuple, list[Mapping[str, Any]]] = {}
    for r in runs:
        groups.setdefault((*(r[c] for c in by), r["controller"]), []).append(r)
    picks = {g: pick_runs(rs) for g, rs in groups.items()}
    wanted = sorted({r["case"] for pair in picks.values() for r in pair})
    rows = query(
        f"SELECT * FROM read_parquet('{quoted(path)}') WHERE \"case\" IN "
        f'({", ".join(map(str, wanted))}) ORDER BY "case", t'
    )
    signals: dict[int, list[dict[str, Any]]] = {}
    for row in rows:
        signals.setdefault(row["case"], []).append(row)
    drawn = []
    for group, (median, worst) in sorted(picks.items(), key=lambda kv: [str(x) for x in kv[0]]):
        kind = group[-1]
        name = "all runs" if kind is None else labels.get(kind, str(kind))
        title = " / ".join([*(str(g) for g in group[:-1]), name])
        if median["case"] not in signals and worst["case"] not in signals:
            continue
        stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", "_".join([*(str(g) for g in group[:-1]), name]))
        file = _overlay(out / f"fig_overlay_{stem}.png", title, median, worst, signals)
        drawn.append((title, file, median, worst))
    return drawn


def _stack(rows: list[dict[str, Any]], key: str) -> np.ndarray | None:
    if not rows or rows[0].get(key) is None:
        return None
    return np.array([r[key] for r in rows], dtype=float)


def _overlay(path: Path, title: str, median, worst, signals) -> str:
    plt = _plt()
    fig, axes = plt.subplots(3, 2, figsize=(11, 7.5), sharex="col", squeeze=False)
    for col, (what, run) in enumerate((("median run", median), ("worst run", worst))):
        rows = signals.get(run["case"], [])
        top = axes[0, col]
        top.set_title(f"{what}: case {run['case']}, {_outcome(run)}", fontsize=9)
        if not rows:
            top.text(0.5, 0.5, "no signals for this case", ha="center", transform=top.transAxes)
            continue
        t = np.array([r["t"] for r in rows])
        for ax, which in ((axes[0, col], "z"), (axes[1, col], "b")):
            err, rho = _stack(rows, f"err_{which}"), _stack(rows, f"rho_{which}")
            lo, hi = _stack(rows, f"bound_{which}_lower"), _stack(rows, f"bound_{which}_upper")
            if err is None or rho is None:
                continue
            for i in range(err.shape[1]):  # e / rho against the bounds / rho
                (line,) = ax.plot(t, err[:, i] / rho[:, i], lw=1, label=f"{which}[{i}]")
                for bound in (lo, hi):
                    if bound is not None:
                        ax.plot(t, bound[:, i] / rho[:, i], color=line.get_color(), lw=0.8,
                                ls="--")  # fmt: skip
            ax.set_ylabel(f"err_{which} / rho_{which}")
            _legend(ax, col)
            ax.grid(alpha=0.3)
        ax = axes[2, col]
        u = _stack(rows, "u_m")
        limits = run.get("joint_torque_limits")
        if u is not None:
            scale = np.array([x if x else np.nan for x in limits], float) if limits else None
            for i in range(u.shape[1]):
                if scale is not None and np.isfinite(scale[i]):
                    ax.plot(t, u[:, i] / scale[i], lw=1, label=f"u[{i}]")
                else:
                    ax.plot(t, u[:, i], lw=1, label=f"u[{i}]")
            if scale is not None:
                for y in (-1, 1):
                    ax.axhline(y, color="k", lw=0.8, ls="--")
            ax.set_ylabel("u_m / limit" if scale is not None else "u_m [N m]")
            _legend(ax, col)
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
    fig.suptitle(f"{title}: errors against their funnels (dashed), torques against limits")
    return _save(fig, path)


def _legend(ax, col: int) -> None:
    """One legend per row, outside the right-hand panel."""
    if col == 1:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)


def _outcome(run: Mapping[str, Any]) -> str:
    if run["kept"]:
        return "kept both funnels"
    where = ""
    if run.get("first_violation_funnel") is not None:
        c = run.get("first_violation_component")
        where = f" {run['first_violation_funnel']}" + (f"[{c}]" if c is not None else "")
    t = run["first_violation_t"]
    left = f"left{where} at {t:.2f} s" if t is not None else "funnels kept"
    if run["status"] == "stopped":
        return f"{left}, stopped at {run['stop_time']:.2f} s" if t is not None else (
            f"stopped at {run['stop_time']:.2f} s")  # fmt: skip
    return left


def _xaxis(ax, cols, numeric, xs, labels) -> None:
    if numeric:
        ax.set_xlabel(cols[0])
        ax.set_xticks(xs)
    else:
        ax.set_xticks(xs)
        ax.set_xticklabels(labels, rotation=20 if len(xs) > 3 else 0, ha="right" if len(xs) > 3
                           else "center", fontsize=8)  # fmt: skip
        ax.set_xlabel(" x ".join(cols) if cols else "")


def _save(fig, path: Path) -> str:
    fig.tight_layout()
    # tight_layout() leaves a placeholder layout engine, for which savefig() first draws the
    # whole figure once more without rendering (a third of a figure's cost); with none it
    # draws once: the same pixels (tests/sweep/test_report.py)
    fig.set_layout_engine(None)
    fig.savefig(path, dpi=110)
    _plt().close(fig)
    return path.name


def _gaps(xs):
    s = sorted(xs)
    return [b - a for a, b in zip(s, s[1:], strict=False) if b > a] or [1.0]
