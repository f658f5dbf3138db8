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


# ------------------------------------------------------------------- reports that explain
def _first_outside(err, lo, hi):
    """(row, component) of the first recorded sample outside (lowest component), or None."""
    out = ~((err > lo) & (err < hi))
    rows = np.flatnonzero(out.any(axis=1))
    return None if not rows.size else (int(rows[0]), int(np.flatnonzero(out[rows[0]])[0]))


@pytest.mark.parametrize(
    "case, duration, limit", [("case1", 1.0, 20.0), ("spatial", 0.5, 0.25)]
)  # fmt: skip
def test_torque_saturation_and_first_violation_from_the_rows(case, duration, limit):
    """max_joint_torque, max_torque_norm, saturation_per_joint and the first violation,
    recomputed from the recorded rows: torque limits that some joints reach, every step
    recorded (so the control periods are the rows)."""
    sc = builtin_scenario(case)
    sc = dataclasses.replace(
        sc, duration=duration, actuators=dataclasses.replace(sc.actuators, torque_limit=limit)
    )
    res = simulate(prepare(sc))
    s = res.summary()
    assert res.completed
    u = np.asarray(res["u_m"])
    assert s["max_joint_torque"] == np.abs(u).max() == limit  # some joint at its limit
    assert s["max_torque_norm"] == s["max_abs_u"] == np.linalg.norm(u, axis=1).max()
    assert s["max_torque_norm"] > s["max_joint_torque"]
    per_joint = np.mean(np.abs(u) >= limit, axis=0)
    assert s["saturation_per_joint"] == pytest.approx(per_joint.tolist(), abs=0)
    assert 0 < max(s["saturation_per_joint"]) <= s["saturation_fraction"]
    assert s["saturation_fraction"] == pytest.approx(np.mean((np.abs(u) >= limit).any(axis=1)))
    first = {
        w: _first_outside(*(np.asarray(res[k]) for k in (f"err_{w}", f"bound_{w}_lower",
                                                          f"bound_{w}_upper")))
        for w in ("b", "z")
    }  # fmt: skip
    seen = [(row, w == "b", w, c) for w, rc in first.items() if rc is not None for row, c in [rc]]
    if seen:
        row, _, which, component = min(seen)
        assert (s["first_violation_funnel"], s["first_violation_component"]) == (which, component)
        assert s["first_violation_t"] == res["t"][row]
    else:
        assert s["first_violation_funnel"] is s["first_violation_component"] is None


def test_first_violation_of_a_run_that_leaves_a_funnel():
    """examples/joint_pd_planar.toml (a joint PD that ignores the end-effector reference)
    completes 5 s and leaves the end-effector funnel: funnel, component and time are those of
    the first sample outside, recomputed from the recorded errors and bounds."""
    from pathlib import Path

    from ffsm_pin.scenario.file import load_scenario

    path = Path(__file__).resolve().parents[2] / "examples" / "joint_pd_planar.toml"
    res = simulate(prepare(load_scenario(path)))
    s = res.summary()
    assert res.completed and s["funnel_ok_b"] and not s["funnel_ok_z"]
    err, lo, hi = (np.asarray(res[k]) for k in ("err_z", "bound_z_lower", "bound_z_upper"))
    row, component = _first_outside(err, lo, hi)
    assert s["first_violation_funnel"] == "z"
    assert s["first_violation_component"] == component
    assert s["first_violation_t"] == res["t"][row]
    # the component left: outside at that row, every component inside one row before
    assert not lo[row, component] < err[row, component] < hi[row, component]
    assert np.all((err[row - 1] > lo[row - 1]) & (err[row - 1] < hi[row - 1]))


@pytest.mark.parametrize(
    "reason, funnel, component",
    [
        ("t = 3.2000 s: end-effector error component 1 (y) = 0.91 left its funnel (-0.8, 0.9); "
         "the transformation (21) is undefined", "z", 1),
        ("t = 3.2000 s: base attitude error component 2 = 0.5 left its funnel (-0.4, 0.5); ...",
         "b", 2),
        ("t = 3.2000 s: base attitude error = 0.5 left its funnel (-0.4, 0.5); ...", "b", 0),
    ],
)  # fmt: skip
def test_first_violation_of_a_funnel_stop(reason, funnel, component):
    """The paper's controller stops before it records the sample outside its funnel: the
    first violation is the stop's funnel and the component its reason names."""
    from synthetic_run import synthetic_result

    res = dataclasses.replace(
        synthetic_result(duration=3.2), completed=False, stop_reason=reason, stop_time=3.2,
        stop_cause="funnel", stop_funnel=funnel,
    )  # fmt: skip
    s = res.summary()
    assert res.funnel_inside_b.all() and res.funnel_inside_z.all()  # no row outside
    assert s[f"funnel_ok_{funnel}"] is False
    assert (s["first_violation_funnel"], s["first_violation_component"]) == (funnel, component)
    assert s["first_violation_t"] == 3.2
