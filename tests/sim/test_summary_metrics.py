"""The comparison metrics of summary.json (docs/cli.md): RMS end-effector error over the last
half, control effort, base attitude excursion, recomputed here from the recorded rows with
other formulas (rotation matrices for the excursion), planar and spatial."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ffsm_pin.attitude import mrp
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.run import prepare, simulate


@pytest.mark.parametrize("case, duration", [("case1", 2.0), ("spatial", 1.0)])
def test_comparison_metrics_from_the_rows(case, duration):
    res = simulate(prepare(dataclasses.replace(builtin_scenario(case), duration=duration)))
    s = res.summary()
    t, u, err = (np.asarray(res[k]) for k in ("t", "u_m", "err_z"))
    q_b = np.asarray(res["q_b"]).reshape(len(t), -1)
    late = t >= t[-1] / 2
    assert s["rms_err_z_late"] == pytest.approx(np.sqrt(np.mean(np.sum(err[late] ** 2, 1))))
    # effort: left rectangles here (one sum over all rows); the summary's trapezoids differ
    # from them by exactly dt / 2 (|u_0|^2 - |u_N|^2) on the uniform grid
    u2 = np.sum(u**2, axis=1)
    dt = t[1] - t[0]
    rectangles = float(np.sum(u2[:-1]) * dt)
    assert s["control_effort"] == pytest.approx(rectangles - 0.5 * dt * (u2[0] - u2[-1]), rel=1e-9)
    if q_b.shape[1] == 1:
        angle = np.abs(q_b[:, 0] - q_b[0, 0])
    else:  # the angle of R(q_b(0))^T R(q_b(t)) from its trace
        R0 = mrp.to_rotation(q_b[0])
        tr = np.array([np.trace(R0.T @ mrp.to_rotation(x)) for x in q_b])
        angle = np.arccos(np.clip((tr - 1) / 2, -1, 1))
    assert s["max_base_excursion"] == pytest.approx(angle.max(), rel=1e-6, abs=1e-9)
    assert s["max_base_excursion"] > 0


def test_save_writes_the_figures_when_asked(tmp_path):
    from ffsm_pin.sim.figures import FIGURE_NAMES

    res = simulate(prepare(dataclasses.replace(builtin_scenario("case1"), duration=0.2)))
    res.save(tmp_path / "plain")
    assert not list((tmp_path / "plain").glob("fig_*.png"))
    res.save(tmp_path / "figs", figures=True)
    assert sorted(p.name for p in (tmp_path / "figs").glob("fig_*.png")) == sorted(FIGURE_NAMES)
