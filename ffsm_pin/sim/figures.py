"""Paper-style figures (Lu & Jia 2019, Figs. 2-4) from one or several recorded runs.

:func:`write_figures` draws PNG files into a folder; several runs are overlaid (``--compare``).
Long runs are thinned for drawing with a min/max envelope per pixel column, so that peaks
(torque spikes, funnel touches) survive decimation.

Figures written:

* ``fig_errors.png``: attitude error e_b [rad] and end-effector errors e_z (x, y [m],
  attitude [rad]), each with its funnel bounds (Eqs. 16, 17) as black dotted lines (Fig. 2);
  spatial runs: one row per component (3 MRP attitude components, then x, y, z [m] and, for
  the pose task, the 3 end-effector MRP components);
* ``fig_velocities.png``: base rate w_b [rad/s], |d(p_e - p_e,d)/dt| [m/s],
  d(q_e - q_e,d)/dt [rad/s] and the joint rates w_m [rad/s] (Fig. 3);
* ``fig_estimation.png``: estimation errors of theta_b, theta_z, theta_d, |w-tilde| [rad/s]
  and |u_m| [N m] (Fig. 4);
* ``fig_torque.png``: reaction torque on the base F_r [N m] (Eq. 7) and the smallest
  singular value of J_m-hat U-hat [m] with the damping threshold;
* ``fig_path.png``: end-effector path and its reference in the plane [m];
* ``fig_wheels.png``, runs with reaction wheels only (docs/capture.md): each wheel's momentum
  h [N m s], motor torque [N m] and spin relative to the bus [rad/s].
* runs with ``[capture]``: ``fig_approach.png`` and ``fig_impulse.png``
  (:mod:`.capture_figures`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")  # no display needed; must precede any pyplot import anywhere

import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from .figure_kit import (  # noqa: E402  (the helpers the capture figures share)
    _finish,
    _grid,
    _legend,
    _mark_stops,
    _plot,
    envelope_decimate,  # noqa: F401  (still importable from here)
)

if TYPE_CHECKING:  # result.py imports this module to draw a run's figures
    from .result import RunResult

FIGURE_NAMES = (
    "fig_errors.png",
    "fig_velocities.png",
    "fig_estimation.png",
    "fig_torque.png",
    "fig_path.png",
)
WHEEL_FIGURE = "fig_wheels.png"  # (runs with [robot.satellite.wheels] only)
_FUNNEL_STYLE = {"color": "black", "linestyle": ":", "linewidth": 1.0}
_JOINT_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")
_RUN_STYLES: tuple[Any, ...] = ("-", "--", "-.", (0, (5, 1, 1, 1)))


def write_figures(
    results: RunResult | Sequence[RunResult],
    out_dir: str | Path,
    *,
    labels: Sequence[str] | None = None,
    thresholds: float | Sequence[float] | None = None,
    dpi: int = 110,
) -> list[Path]:
    """Draw the figures of one run, or overlay several, into ``out_dir``; return the paths.

    Parameters
    ----------
    results : RunResult or sequence of RunResult
        One run or several (overlaid).
    out_dir : str or Path
        Folder the PNG files are written to.
    labels : sequence of str or None
        Legend entry per run (default: the scenario names).
    thresholds : float or sequence of float or None
        Damping threshold on sigma_min [m] per run (default: each run's
        ``damping_threshold``, else 0.05, the default
        :class:`~ffsm_pin.control.gains.SingularityPolicy`).
    dpi : int
        Resolution of the PNG files.

    Returns
    -------
    list of Path
        The PNG files written.
    """
    # a RunResult is no iterable (it has no __iter__): several runs are any iterable of them
    runs = list(results) if isinstance(results, Iterable) else [results]
    if not runs:
        raise ValueError("write_figures needs at least one run")
    labels = _labels(runs, labels)
    if thresholds is None:
        thresholds = [0.05 if r.damping_threshold is None else r.damping_threshold for r in runs]
    elif np.isscalar(thresholds):
        thresholds = [float(thresholds)] * len(runs)  # type: ignore[arg-type]
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    draw = (_errors, _velocities, _estimation, _torque, _path)
    paths = []
    for name, fn in zip(FIGURE_NAMES, draw, strict=True):
        fig = fn(runs, labels, thresholds)
        FigureCanvasAgg(fig)
        path = out_dir / name
        fig.savefig(path, dpi=dpi)
        paths.append(path)
    if any("wheel_momentum" in run for run in runs):
        fig = _wheels(runs, labels)
        FigureCanvasAgg(fig)
        fig.savefig(out_dir / WHEEL_FIGURE, dpi=dpi)
        paths.append(out_dir / WHEEL_FIGURE)
    from .capture_figures import write_capture_figures  # runs with [capture]: approach, impulse

    return paths + write_capture_figures(runs, labels, out_dir, dpi)


# ------------------------------------------------------------------------------ figures
def _errors(runs, labels, thresholds) -> Figure:
    rows = _error_rows(runs[0])
    fig, axes = _grid(
        len(rows) + 1, "Tracking errors inside their prescribed-performance funnels", runs
    )
    _error_norms(axes[-1], runs, labels)
    for ax, (key, i, bound, ylabel) in zip(axes, rows, strict=False):
        drawn_bounds: list[np.ndarray] = []
        for k, (run, label) in enumerate(zip(runs, labels, strict=True)):
            t = run["t"]
            _plot(ax, t, run[key][:, i], color=f"C{k}", label=label)
            lo, hi = run[f"{bound}_lower"][:, i], run[f"{bound}_upper"][:, i]
            if not any(len(b) == len(lo) and np.allclose(b, lo) for b in drawn_bounds):
                drawn_bounds.append(lo)
                funnel_label = "funnel" if not drawn_bounds[1:] else None
                _plot(ax, t, lo, envelope=False, label=funnel_label, **_FUNNEL_STYLE)
                _plot(ax, t, hi, envelope=False, **_FUNNEL_STYLE)
        ax.axhline(0.0, color="0.8", linewidth=0.6, zorder=0)
        ax.set_ylabel(ylabel)
        _mark_stops(ax, runs)
    _legend(axes[0], loc="upper right", fontsize=8)
    return fig


def _labels(runs, labels) -> list:
    """Legend entry per run: the given ones, else the scenario names; none for a single run,
    whose name the title carries already."""
    if labels is not None:
        return list(labels)
    return [r.scenario_name for r in runs] if len(runs) > 1 else [None]


def _error_norms(ax: Axes, runs, labels) -> None:
    """|err_z| and |err_b| on a log scale: the errors fall by decades (the panel above them
    show the sign and the funnels)."""
    for k, (run, label) in enumerate(zip(runs, labels, strict=True)):
        t = run["t"]
        for key, style in (("err_z", "-"), ("err_b", ":")):
            norm = np.linalg.norm(np.asarray(run[key]).reshape(len(t), -1), axis=1)
            shown = np.where(norm > 0, norm, np.nan)  # log scale: zeros left out
            name = "|e_z|" if key == "err_z" else "|e_b|"
            _plot(ax, t, shown, color=f"C{k}", linestyle=style,
                  label=f"{label}: {name}" if label else name)  # fmt: skip
    if any(len(r["t"]) for r in runs):
        ax.set_yscale("log")
    ax.set_ylabel("|error| (log)")
    _mark_stops(ax, runs)
    _legend(ax, loc="upper right", fontsize=7, ncol=2)


def _velocities(runs, labels, thresholds) -> Figure:
    fig, axes = _grid(4, "Base rate, end-effector velocity errors and joint rates", runs)
    for k, (run, label) in enumerate(zip(runs, labels, strict=True)):
        t, color = run["t"], f"C{k}"
        de = run["z_e_dot"] - run["z_e_d_dot"]
        m3, m2 = _sizes(run)
        for i in range(m3):  # base angular velocity (inertial) components
            _plot(axes[0], t, run["w"][:, i], color=color, label=label if i == 0 else None,
                  linestyle=_RUN_STYLES[i % len(_RUN_STYLES)])  # fmt: skip
        _plot(axes[1], t, np.linalg.norm(de[:, :m2], axis=1), color=color, label=label)
        for i in range(m2, de.shape[1]):  # attitude components (pose task)
            _plot(axes[2], t, de[:, i], color=color, label=label if i == m2 else None)
        w_m = run["w"][:, m3:]
        for j in range(w_m.shape[1]):
            _plot(
                axes[3],
                t,
                w_m[:, j],
                color=_JOINT_COLORS[j % len(_JOINT_COLORS)],
                linestyle=_RUN_STYLES[k % len(_RUN_STYLES)],
            )
    ylabels = (
        r"$w_b$ [rad/s]",
        r"$|\dot p_e - \dot p_{e,d}|$ [m/s]",
        r"$\dot q_e - \dot q_{e,d}$ [rad/s or 1/s]",
        r"$w_m$ [rad/s]",
    )
    _finish(axes, runs, ylabels, legends=(0,))
    n_m = max(r["w"].shape[1] - _sizes(r)[0] for r in runs)
    handles = [
        Line2D([], [], color=_JOINT_COLORS[j % len(_JOINT_COLORS)], label=f"$w_{{m{j + 1}}}$")
        for j in range(n_m)
    ]
    if len(runs) > 1:  # joints by colour, runs by line style
        handles += [
            Line2D([], [], color="0.3", linestyle=_RUN_STYLES[k % len(_RUN_STYLES)], label=lab)
            for k, lab in enumerate(labels)
        ]
    axes[3].legend(handles=handles, loc="upper right", fontsize=7, ncol=min(4, len(handles)))
    return fig


def truth_rows(run, name: str) -> np.ndarray:
    """The true parameter ``name`` (``"theta_z"``, ``"theta_d"``, ``"theta_b"``) at each
    recorded row: the robot's, and after a capture the merged robot's (``<name>_captured``,
    docs/capture.md, "The true parameters after a capture").

    Parameters
    ----------
    run : RunResult
        The run.
    name : str
        The parameter vector.

    Returns
    -------
    ndarray, shape (rows, n)
        The truth per row.
    """
    t = np.asarray(run["t"])
    truth = np.broadcast_to(np.asarray(run[name])[None, :], (len(t), len(run[name])))
    capture = getattr(run, "capture", None)
    time = None if capture is None else capture.time
    if time is not None and f"{name}_captured" in run:
        after = np.asarray(run[f"{name}_captured"])[None, :]
        truth = np.where((t >= time)[:, None], after, truth)
    return truth


def _estimation(runs, labels, thresholds) -> Figure:
    fig, axes = _grid(5, "Estimation errors, filter error and control effort", runs)
    for k, (run, label) in enumerate(zip(runs, labels, strict=True)):
        t, color = run["t"], f"C{k}"
        for ax, name in zip(axes[:3], ("theta_b", "theta_z", "theta_d"), strict=True):
            if f"{name}_hat" in run:  # only controllers with estimates report them
                err = np.linalg.norm(run[f"{name}_hat"] - truth_rows(run, name), axis=1)
                _plot(ax, t, err, color=color, label=label)
        if "w_tilde" in run:
            _plot(axes[3], t, np.linalg.norm(run["w_tilde"], axis=1), color=color, label=label)
        _plot(axes[4], t, np.linalg.norm(run["u_m"], axis=1), color=color, label=label)
    for ax, key in zip(
        axes, ("theta_b_hat", "theta_z_hat", "theta_d_hat", "w_tilde"), strict=False
    ):
        _note_absent(ax, key, runs)
    axes[0].text(
        0.99,
        0.95,
        r"$\theta_b$ is determined only up to scale by Eq. (28) (docs/model.md section 5)",
        transform=axes[0].transAxes,
        ha="right",
        va="top",
        fontsize=7,
        color="0.35",
        bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none"},
    )
    ylabels = (
        r"$|\hat\theta_b - \theta_b|$",
        r"$|\hat\theta_z - \theta_z|$",
        r"$|\hat\theta_d - \theta_d|$",
        r"$|\tilde w|$ [rad/s]",
        r"$|u_m|$ [N m]",
    )
    _finish(axes, runs, ylabels, legends=(1,))
    return fig


def _torque(runs, labels, thresholds) -> Figure:
    fig, axes = _grid(2, "Reaction torque on the base and distance to singularity", runs)
    any_damped = False
    for k, (run, label, thr) in enumerate(zip(runs, labels, thresholds, strict=True)):
        t, color = run["t"], f"C{k}"
        F_r = np.asarray(run["F_r"])
        F_r = F_r[:, None] if F_r.ndim == 1 else F_r  # planar: one value per row
        for i in range(F_r.shape[1]):  # planar: one value; spatial: x, y, z components
            _plot(axes[0], t, F_r[:, i], color=color, label=label if i == 0 else None,
                  linestyle=_RUN_STYLES[i % len(_RUN_STYLES)])  # fmt: skip
        if "sigma_min" not in run:  # a controller that inverts no task Jacobian
            continue
        _plot(axes[1], t, run["sigma_min"], color=color)
        if k == 0 or thr != thresholds[0]:
            axes[1].axhline(
                thr, color="black", linestyle="--", linewidth=0.9, label="damping threshold"
            )
        damped = np.asarray(run["damping"]) > 0
        if damped.any():
            axes[1].fill_between(
                t,
                0,
                1,
                where=damped,
                transform=axes[1].get_xaxis_transform(),
                color=color,
                alpha=0.12,
                linewidth=0,
                label="damped (shaded)" if not any_damped else None,
            )
            any_damped = True
    _note_absent(axes[1], "sigma_min", runs)
    axes[1].set_ylim(bottom=0)
    ylabels = (r"$F_r$ [N m]", r"$\sigma_{min}(\hat J_m \hat U)$ [m]")
    _finish(axes, runs, ylabels, legends=(0, 1))
    return fig


def _path(runs, labels, thresholds) -> Figure:
    fig = Figure(figsize=(6.4, 5.6), layout="constrained")
    ax: Axes = fig.add_subplot()
    ref = runs[0]["z_e_d"]
    _plot(ax, ref[:, 0], ref[:, 1], envelope=False, color="black", linestyle=":", label="reference")
    for k, (run, label) in enumerate(zip(runs, labels, strict=True)):
        z = run["z_e"]
        _plot(ax, z[:, 0], z[:, 1], envelope=False, color=f"C{k}", label=label)
        if len(z):
            ax.plot(z[0, 0], z[0, 1], "o", color=f"C{k}", markersize=4)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title("End-effector path (o: start)", fontsize=10)
    ax.legend(fontsize=8)
    return fig


def _wheels(runs, labels) -> Figure:
    keys = ("wheel_momentum", "wheel_torque", "wheel_speed")
    fig, axes = _grid(3, "Reaction wheels: momentum, motor torque, spin", runs)
    for k, (run, label) in enumerate(zip(runs, labels, strict=True)):
        if "wheel_momentum" not in run:
            continue
        prefix = f"{label}, " if label else ""
        for ax, key in zip(axes, keys, strict=True):
            rows = np.asarray(run[key])
            for i in range(rows.shape[1]):  # one line per wheel
                _plot(ax, run["t"], rows[:, i], color=f"C{k}",
                      linestyle=_RUN_STYLES[i % len(_RUN_STYLES)],
                      label=f"{prefix}wheel {i}" if ax is axes[0] else None)  # fmt: skip
    ylabels = ("$h$ [N m s]", r"$\tau_w$ [N m]", r"$\Omega$ [rad/s]")
    _finish(axes, runs, ylabels, legends=(0,))
    return fig


# ------------------------------------------------------------------------------ helpers
def _sizes(run) -> tuple[int, int]:
    """(m3, m2) of a run: attitude components (1 planar, 3 spatial) and position components."""
    m3 = np.asarray(run["err_b"]).shape[-1]  # (rows, m3), rows may be 0
    return m3, (2 if m3 == 1 else 3)


def _error_rows(run) -> list[tuple[str, int, str, str]]:
    """(signal, column, bound, label) for every error component of a run."""
    m3, m2 = _sizes(run)
    n_task = run["err_z"].shape[1]
    if m3 == 1:
        rows = [("err_b", 0, "bound_b", r"$e_b$ [rad]")]
        names = [r"$e_{z,x}$ [m]", r"$e_{z,y}$ [m]", r"$e_{z,\phi}$ [rad]"]
    else:
        rows = [("err_b", i, "bound_b", f"$e_{{b,s{i + 1}}}$ [MRP]") for i in range(3)]
        names = [f"$e_{{z,{c}}}$ [m]" for c in "xyz"] + [
            f"$e_{{z,s{i + 1}}}$ [MRP]" for i in range(3)
        ]
    return rows + [("err_z", i, "bound_z", names[i]) for i in range(n_task)]


def _note_absent(ax: Axes, key: str, runs) -> None:
    """Say on the panel which runs' controllers do not report ``key``."""
    missing = [run.scenario_name for run in runs if key not in run]
    if missing:
        ax.text(
            0.5, 0.5, f"{key}: not reported by the controller of " + ", ".join(missing),
            transform=ax.transAxes, ha="center", va="center", fontsize=8, color="0.35",
        )  # fmt: skip
