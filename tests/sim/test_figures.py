"""Paper-style figures from a synthetic RunResult (no simulation needed)."""

from __future__ import annotations

import matplotlib.image
import numpy as np
import pytest
from synthetic_run import synthetic_result

from ffsm_pin.sim.figures import FIGURE_NAMES, envelope_decimate, write_figures


def _check_png(path):
    assert path.is_file() and path.stat().st_size > 10_000
    img = matplotlib.image.imread(path)
    assert img.ndim == 3 and img.shape[0] > 300 and img.shape[1] > 300
    assert img[..., :3].std() > 0.05  # not a blank page


def test_one_run_writes_every_figure(tmp_path):
    # how long the figures take is measured in benchmarks/, not asserted here (no wall clock in
    # a test: it fails on a loaded machine, not on a slow change)
    result = synthetic_result(duration=30.0, dt=1e-3)  # 30001 samples
    paths = write_figures(result, tmp_path)
    assert [p.name for p in paths] == list(FIGURE_NAMES)
    for p in paths:
        _check_png(p)


def test_overlay_of_several_runs(tmp_path):
    runs = [
        synthetic_result(duration=10.0, dt=1e-3),
        synthetic_result(duration=10.0, dt=1e-3, scheme="no-ppc", phase=1.0),
        synthetic_result(duration=6.0, dt=1e-3, scheme="no-attitude", completed=False),
    ]
    paths = write_figures(
        runs, tmp_path, labels=["case 1", "case 2", "case 3"], thresholds=[0.05, 0.05, 0.02]
    )
    for p in paths:
        _check_png(p)


def test_diverged_run_with_non_finite_values_still_draws(tmp_path):
    result = synthetic_result(duration=2.0, dt=1e-3, completed=False)
    for key in ("u_m", "F_r", "w", "err_z"):
        result.signals[key][-1] = np.inf if key != "err_z" else np.nan
    for p in write_figures(result, tmp_path):
        _check_png(p)


def test_single_sample_run_draws(tmp_path):
    result = synthetic_result(duration=1e-3, dt=1e-3, completed=False)
    result.signals = {
        k: (v[:1] if v.ndim and len(v) == 2 and k not in ("theta_z", "theta_d", "theta_b") else v)
        for k, v in result.signals.items()
    }
    for p in write_figures(result, tmp_path):
        assert p.is_file()


def test_envelope_keeps_peaks_and_order():
    t = np.linspace(0.0, 30.0, 30001)
    y = np.sin(t)
    y[12345] = 100.0  # a one-sample spike
    y[20000] = -50.0
    x2, y2 = envelope_decimate(t, y, 500)
    assert len(x2) <= 2 * 500 + 4
    assert np.all(np.diff(x2) > 0)
    assert y2.max() == 100.0 and y2.min() == -50.0
    assert x2[0] == t[0] and x2[-1] == t[-1]


def test_no_run_is_an_error(tmp_path):
    with pytest.raises(ValueError):
        write_figures([], tmp_path)


def test_log_error_panel_and_no_legend_entry_repeating_the_title():
    """The error figure ends with |e_z|, |e_b| on a log scale; a single run's name is in the
    title only, never a legend entry (issue 21)."""
    from ffsm_pin.sim import figures

    res = synthetic_result(duration=2.0)
    runs = [res]
    labels = figures._labels(runs, None)
    for draw in (figures._errors, figures._velocities, figures._estimation, figures._torque,
                 figures._path):  # fmt: skip
        fig = draw(runs, labels, [0.05])
        if draw is not figures._path:  # the path figure has a short title of its own
            assert res.scenario_name in fig.get_suptitle()
        for ax in fig.axes:
            legend = ax.get_legend()
            texts = [t.get_text() for t in legend.get_texts()] if legend else []
            assert res.scenario_name not in texts, (draw.__name__, texts)
    fig = figures._errors(runs, labels, [0.05])
    assert fig.axes[-1].get_yscale() == "log"
    two = figures._labels([res, res], None)
    assert two == [res.scenario_name] * 2  # several runs: the legend tells them apart
