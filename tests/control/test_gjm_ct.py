"""The gjm-ct baseline (control/gjm_ct.py, docs/baselines.md) against what its law says it
does: with the true model the joint-rate error decays at k_v and then the end-effector error at
k_z (the closed loop of resolved motion through the generalized Jacobian, Umetani & Yoshida
1989), planar and spatial; the derived gains keep the shipped scenarios' funnels."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ffsm_pin.control.gjm_ct import GjmComputedTorque, GjmGains
from ffsm_pin.errors import ParameterError
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.scenario.spec import Estimates
from ffsm_pin.sim.run import Sensor, prepare, simulate


def _gjm(case: str, duration: float | None, initial: str | None = "true", **params):
    """The built-in case with type = "gjm-ct"; its own estimates when ``initial`` is None."""
    sc = builtin_scenario(case)
    est = sc.controller.estimates if initial is None else Estimates(initial=initial)
    ctrl = dataclasses.replace(sc.controller, type="gjm-ct", params=params, estimates=est)
    return dataclasses.replace(sc, controller=ctrl, duration=duration or sc.duration)


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_true_model_closed_loop_has_the_decay_rates_of_its_gains(case):
    k_z, k_v = 1.0, 40.0
    res = simulate(prepare(_gjm(case, 4.0, k_z=k_z, k_v=k_v)))
    assert res.completed, res.stop_reason
    t = np.asarray(res["t"])
    m3 = np.asarray(res["q_b"]).shape[1]
    # joint loop: |w_m - w_md| decays as exp(-k_v t) (computed torque on the exact model)
    dw = np.linalg.norm(np.asarray(res["w"])[:, m3:] - np.asarray(res["w_mc"]), axis=1)
    k = np.searchsorted(t, [0.02, 0.1])
    rate = np.log(dw[k[0]] / dw[k[1]]) / (t[k[1]] - t[k[0]])
    dt = res.dt  # the loop is discrete: w_m - w_md shrinks by (1 - k_v dt) per period
    assert rate == pytest.approx(-np.log(1 - k_v * dt) / dt, rel=2e-3)
    # task: once the joint loop has settled, every component decays as exp(-k_z t)
    err = np.asarray(res["err_z"])
    i1, i2 = np.searchsorted(t, [1.0, 3.5])
    ratio = err[i2] / err[i1]
    big = np.abs(err[i1]) > 1e-3  # components with an error to decay
    assert big.any()
    # rtol: the torque is held over a period, so the joints lag the command by about dt / 2
    # and the decay is slower by a factor of about 1 - k_z dt / 2 (0.25 % over 2.5 s at 2 ms)
    np.testing.assert_allclose(ratio[big], np.exp(-k_z * (t[i2] - t[i1])), rtol=5e-3)
    s = res.summary()
    assert s["drift_P"] < 1e-9 and s["drift_L"] < 1e-9


@pytest.mark.parametrize("case", ["case1", "planar5", "spatial"])
def test_derived_gains_keep_the_end_effector_funnel(case):
    """Default gains, the scenario's own estimates (Table 2 for case 1, 30 % error for
    planar5, the spatial case's), its whole duration."""
    res = simulate(prepare(_gjm(case, None, initial=None)))
    s = res.summary()
    assert res.completed, res.stop_reason
    assert s["funnel_ok_z"], s["first_violation_t"]


def test_derived_gains_follow_the_funnel_the_drift_and_the_step():
    from ffsm_pin.control.funnel import FunnelParams

    f = FunnelParams((1.0, 1.0, 0.2), (0.08, 0.08, 0.05), (0.22, 0.3, 0.22), (0.8, 0.8, 0.8))
    g = GjmGains.derived(f, 1e-3, 2, 3)
    assert g.k_z == pytest.approx((0.44, 0.6, 0.44)) and g.k_v == pytest.approx(6.0)
    # a drift of 0.128 m/s: 0.128 / (0.8 * 0.08) = 2 on the positions, not on the attitude
    g = GjmGains.derived(f, 1e-3, 2, 3, drift=0.128)
    assert g.k_z == pytest.approx((2.0, 2.0, 0.44)) and g.k_v == pytest.approx(20.0)
    fast = FunnelParams((1.0,) * 2, (0.1,) * 2, (5.0,) * 2, (0.8,) * 2)
    assert GjmGains.derived(fast, 0.01, 2, 2).k_v == pytest.approx(10.0)  # capped at 0.1 / dt


@pytest.mark.parametrize(
    "params, words", [({"kz": 1.0}, ["kz", "'k_z', 'k_v'"]), ({"k_v": -1.0}, ["k_v", "> 0"]),
                      ({"k_z": [1.0, 2.0]}, ["k_z", "expected 1 or 3"])],
)  # fmt: skip
def test_bad_params_name_the_key(params, words):
    with pytest.raises(ParameterError) as info:
        prepare(_gjm("case1", 1.0, **params))
    assert all(w in str(info.value) for w in words), str(info.value)


# ----------------------------------------------------------------- compiled period
@pytest.mark.parametrize("case", ["case1", "planar5", "spatial", "spatial-pose"])
def test_compiled_period_equals_the_numpy_reference(case):
    """The compiled period (control/gjm_ct_kernels.py) against step_numpy at random states and
    estimates off the truth: the same torque and command to rounding (different operation
    order: solves, the complex-step momentum rows), and the same damping decision."""
    setup = prepare(_gjm(case, 1.0, initial="perturbed"))
    ctrl = setup.controller
    assert ctrl.backend == "numba"
    sensor = Sensor(setup.robot, setup.model, full_model=False)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, v = setup.q0.copy(), setup.v0.copy()
        n = setup.robot.n_joints
        q[-n:] += rng.uniform(-0.2, 0.2, n)
        v[-n:] += rng.normal(0.0, 0.3, n)
        meas = sensor.measure(float(rng.uniform(0, 20)), q, v)
        got, want = ctrl.step_compiled(meas), ctrl.step_numpy(meas)
        scale = np.abs(want[0]).max()
        np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-12 * scale)
        for key in ("w_mc", "sigma_min", "damping"):
            np.testing.assert_allclose(got[1][key], want[1][key], rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_compiled_run_follows_the_numpy_run(case):
    """Whole runs on each backend (1 s): the trajectories agree to rounding growth."""
    sc = _gjm(case, 1.0, initial="perturbed")
    runs = []
    for backend in ("numba", "numpy"):
        setup = prepare(sc)
        setup.controller = GjmComputedTorque(setup.controller.context, backend=backend)
        runs.append(simulate(setup))
    a, b = runs
    for key in ("q", "u_m"):
        scale = np.abs(np.asarray(b[key])).max()
        np.testing.assert_allclose(a[key], b[key], rtol=0, atol=1e-9 * scale, err_msg=key)
