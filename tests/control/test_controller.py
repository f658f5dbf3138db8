"""The coordinated controller (ffsm_pin.control.controller): feasibility and input checks, and
the closed-loop properties of Section 3.4 that must hold along any run of the paper's case:
e(t) of Eq. (54) follows Eq. (55), w-hat_{m,r} follows Eq. (65), |theta_z-tilde| is
non-increasing (Eq. 43), and the plant keeps its momentum to rounding."""

from __future__ import annotations

import dataclasses
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from ffsm_pin.control.controller import (
    SCHEMES,
    CoordinatedController,
    SingularityWarning,
    check_feasibility,
)
from ffsm_pin.control.funnel import FunnelParams
from ffsm_pin.control.gains import Gains, SingularityPolicy
from ffsm_pin.control.lu_jia import LuJiaController
from ffsm_pin.control.lu_jia_params import LuJiaParams
from ffsm_pin.errors import FfsmError, InfeasibleTaskError, ScenarioError
from ffsm_pin.model.planar import BarycentricModel
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.scenario.spec import (
    ComponentReference,
    ControllerSpec,
    Estimates,
    InitialCondition,
    Performance,
    Reference,
    RobotSpec,
    Scenario,
)
from ffsm_pin.sim.run import Sensor, prepare, simulate

# The paper's case as shipped (Table 2 initial state, Eq. 80 reference, rho_b0 = 1.0), so the
# tests also guard the built-in scenario file.
CASE1 = builtin_scenario("case1")
EQ80, TABLE2, FUNNEL_B = CASE1.reference, CASE1.initial, CASE1.performance.funnel_b
FUNNEL_Z = Performance().funnel_z  # the paper's end-effector funnel
DTS = (2e-3, 1e-3, 5e-4)
DURATION = 2.0  # [s]


def paper_scenario(scheme="ppc", duration=DURATION, dt=1e-3, **controller):
    ctrl = ControllerSpec(lu_jia=LuJiaParams(scheme=scheme), **controller)
    perf = Performance(funnel_b=FUNNEL_B)
    return Scenario(RobotSpec(), TABLE2, EQ80, ctrl, duration=duration, dt=dt, performance=perf)


def with_backend(setup, backend: str):
    """The prepared setup with its controller rebuilt on ``backend`` ('numpy' reference or
    'numba' compiled period): the same estimates, funnels, gains and initial measurement."""
    # the same controller (estimates, funnels, gains, initial measurement) on `backend`
    setup.controller = LuJiaController(setup.controller.context, backend=backend)
    assert setup.controller.law.backend == backend
    return setup


def controller_for(robot, scheme, *, theta_z=None, theta_d=None, theta_b=None):
    """A CoordinatedController for ``robot`` at rest in a generic pose, true estimates unless
    given."""
    model = BarycentricModel(robot.geometry)
    n = robot.n_joints
    q = robot.configuration((0.0, 0.0, 0.1), 0.7 * (-1.0) ** np.arange(n))
    v = np.zeros(robot.model.nv)
    meas = Sensor(robot, model, full_model=False).measure(0.0, q, v)
    ref = Reference(ee=tuple(ComponentReference(float(c)) for c in meas.z_e + 0.05))
    return CoordinatedController(
        model,
        scheme=scheme,
        gains=Gains(),
        funnel_b=FUNNEL_B,
        funnel_z=FUNNEL_Z,
        reference=ref,
        base_attitude_ref=0.0,
        singularity=SingularityPolicy(),
        theta_z0=model.true_theta_z((0.0, 0.0)) if theta_z is None else theta_z,
        theta_d0=model.theta_d if theta_d is None else theta_d,
        theta_b0=model.true_theta_b(0.0) if theta_b is None else theta_b,
        initial=meas,
    )


# ------------------------------------------------------------------------- feasibility
def test_three_link_robot_is_infeasible_with_attitude_regulation(make_chain):
    """m_1 >= (m_2 + m_3) + m_3 = 4 joints for the planar pose task plus the attitude."""
    robot = make_chain(3)
    assert robot.n_joints == 3
    for scheme in ("ppc", "no-ppc", "known-model"):
        with pytest.raises(InfeasibleTaskError) as info:
            check_feasibility(robot.n_joints, scheme)
        msg = str(info.value)
        assert re.search(r"\b4\b", msg) and re.search(r"\b3\b", msg), msg  # needs 4, has 3
        with pytest.raises(InfeasibleTaskError):
            controller_for(robot, scheme)
        # and before simulating: prepare() refuses the scenario
        sc = Scenario(
            RobotSpec(urdf=str(robot.urdf_path)),
            InitialCondition((0, 0, 0), (0.5, -0.5, 0.5), (0, 0, 0), base_twist=(0, 0, 0)),
            EQ80,
            ControllerSpec(lu_jia=LuJiaParams(scheme=scheme)),
        )
        with pytest.raises(InfeasibleTaskError, match=r"\b3\b"):
            prepare(sc)


def test_three_link_robot_is_accepted_without_attitude_regulation(make_chain):
    robot = make_chain(3)
    check_feasibility(robot.n_joints, "no-attitude")  # Eq. (81): 3 joints for 3 task rows
    ctrl = controller_for(robot, "no-attitude")
    assert ctrl.scheme == "no-attitude"
    with pytest.raises(InfeasibleTaskError, match=r"\b3\b"):
        check_feasibility(2, "no-attitude")


def test_four_and_five_joints_are_feasible_for_every_scheme(paper_robot, make_chain):
    for n in (4, 5):
        for scheme in SCHEMES:
            check_feasibility(n, scheme)
    for scheme in SCHEMES:
        controller_for(paper_robot, scheme)
        controller_for(make_chain(5, offaxis=True), scheme)


def test_unknown_scheme_is_refused():
    with pytest.raises(InfeasibleTaskError, match="ppc"):
        check_feasibility(4, "pcc")


# ------------------------------------------------------------------------- estimate sizes
@pytest.mark.parametrize("name", ["theta_z", "theta_d", "theta_b"])
@pytest.mark.parametrize("delta", [-1, 1])
@pytest.mark.parametrize("offaxis", [False, True])
def test_estimates_of_the_wrong_size_are_rejected(make_chain, name, delta, offaxis):
    robot = make_chain(5, offaxis=offaxis)
    model = BarycentricModel(robot.geometry)
    size = {"theta_z": model.n_z, "theta_d": model.n_d, "theta_b": model.n_b}[name]
    with pytest.raises(FfsmError, match=rf"{name}.*{size + delta}.*{size}"):
        controller_for(robot, "ppc", **{name: np.ones(size + delta)})


def test_paper_estimates_need_the_paper_sizes(make_chain):
    """Table 2's vectors (7, 15, 16 entries) do not fit a 5-link robot: refused by prepare."""
    robot = make_chain(5)
    init = InitialCondition((0, 0, 0), (0.8, -0.8, 0.8, -0.8, 0.8), (0,) * 5, base_twist=(0, 0, 0))
    sc = Scenario(RobotSpec(urdf=str(robot.urdf_path)), init, EQ80, ControllerSpec())
    with pytest.raises(ScenarioError, match="Table 2"):
        prepare(sc)


# ------------------------------------------------------------------------- closed loop
@pytest.fixture(scope="module", params=["numba", "numpy"])
def runs(request):
    """The paper's case 1 (rho_b0 = 1.0) for 2 s at three step sizes, on each backend."""
    out = {}
    for dt in DTS:
        result = simulate(with_backend(prepare(paper_scenario(dt=dt)), request.param))
        assert result.completed, result.stop_reason
        out[dt] = result
    return out


def _first_order_ratios(errors):
    return [errors[a] / errors[b] for a, b in zip(DTS[:-1], DTS[1:], strict=True)]


def test_e_follows_eq55_up_to_first_order_in_dt(runs):
    """e = M w~ + Y_df theta_d~ (Eq. 54) obeys de/dt = -k_de e (Eq. 55) exactly in continuous
    time, so e(t) - e(0) exp(-k_de t) is the integration error alone: first order in dt."""
    k_de = Gains().k_de
    errors = {}
    for dt, r in runs.items():
        t, e = r["t"], r["e"]
        assert np.linalg.norm(e[0]) > 0.1  # Table 2: w-hat(0) = 0, so e(0) = M w(0) != 0
        errors[dt] = np.max(np.abs(e - e[0] * np.exp(-k_de * t)[:, None]))
    # halving dt halves the error (first-order method): ratio 2 within 15 %
    for ratio in _first_order_ratios(errors):
        assert 1.7 < ratio < 2.3, errors
    # and e really decays as Eq. (55) says: by exp(-0.6) = 0.55 over 2 s, to a few per cent
    r = runs[DTS[-1]]
    np.testing.assert_allclose(
        r["e"][-1], r["e"][0] * np.exp(-k_de * r["t"][-1]), atol=0.02 * np.abs(r["e"][0]).max()
    )


def test_w_hat_mr_decays_as_eq65(runs):
    """w-hat_{m,r} = w-hat_m - w_mc obeys dw-hat_{m,r}/dt = -k_d w-hat_{m,r} (Eq. 65): it follows
    w-hat_{m,r}(0) exp(-k_d t) up to an error that is first order in dt."""
    k_d = Gains().k_d
    errors = {}
    for dt, r in runs.items():
        wmr = r["w_hat"][:, 1:] - r["w_mc"]
        assert np.linalg.norm(wmr[0]) > 0.1  # w-hat(0) = 0, w_mc(0) != 0: a real transient
        errors[dt] = np.max(np.abs(wmr - wmr[0] * np.exp(-k_d * r["t"])[:, None]))
    for ratio in _first_order_ratios(errors):
        assert 1.7 < ratio < 2.3, errors


def test_theta_z_error_never_increases(runs):
    """Eq. (43): d theta_z~/dt = -Gamma_2 Y_z^T Y_z theta_z~, so |theta_z~| is non-increasing;
    the backward-Euler update keeps this for any dt (rounding allowance 1e-12 per step)."""
    for r in runs.values():
        err = np.linalg.norm(r["theta_z_hat"] - r["theta_z"], axis=1)
        assert np.all(np.diff(err) <= 1e-12 * err[0])
        assert err[-1] < err[0]  # and it does adapt


def test_momentum_drift_is_rounding(runs):
    """Free floating: P and L about the CoM are conserved. 4000 steps of rounding on momenta of
    order 10 (|P| ~ 9 kg m/s, |L| ~ 0.8 kg m^2/s) allow ~ 4000 * 2.2e-16 * 10 ~ 1e-11."""
    for r in runs.values():
        drift_P, drift_L = r.drift()
        assert drift_P < 1e-10 and drift_L < 1e-10
        assert np.linalg.norm(r["P"][0]) > 1.0 and abs(r["L"][0]) > 0.1  # non-zero momenta


def test_w_tilde_and_filter_consistent(runs):
    """The recorded w~ is w - w-hat (Eq. 46's estimation error) and the run recorded every
    signal finite."""
    for r in runs.values():
        np.testing.assert_allclose(r["w_tilde"], r["w"] - r["w_hat"], atol=1e-15)
        for key, value in r.signals.items():
            assert np.all(np.isfinite(value)), key


# ------------------------------------------------------------------------- controlled stop
def test_arm_held_at_a_fold_stops_cleanly():
    """A reference out of reach stretches the arm into its fold: the damped inverse keeps the
    numbers finite, a warning is issued when damping starts, and the run stops with cause
    'singular' once sigma_min has stayed below the threshold for max_damped_time."""
    policy = SingularityPolicy(threshold=0.05, max_damped_time=0.5)
    far = Reference(ee=(ComponentReference(8.0), ComponentReference(3.0), ComponentReference(0.5)))
    init = InitialCondition(
        (0.0, 0.0, 0.18), TABLE2.joints, (0.0,) * 4, com_at_origin=True,
        com_velocity=(0.0, 0.0), base_rate=0.0,
    )  # fmt: skip
    wide = FunnelParams((20.0, 20.0, 5.0), (0.08, 0.08, 0.05), (0.22,) * 3, (0.8,) * 3)
    ctrl = ControllerSpec(
        lu_jia=LuJiaParams(scheme="no-ppc", max_damped_time=policy.max_damped_time),
        estimates=Estimates("true"),
    )
    perf = Performance(FUNNEL_B, wide, singularity_threshold=policy.threshold)
    sc = Scenario(RobotSpec(), init, far, ctrl, duration=20.0, dt=1e-3, performance=perf)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        setup = prepare(sc)
        result = simulate(setup)
    assert setup.reach_horizon == 0.0  # reported before simulating
    assert any(issubclass(w.category, SingularityWarning) for w in caught)
    assert not result.completed
    assert "singular" in result.stop_reason and "0.5 s" in result.stop_reason
    assert any("damped least squares is active" in ev for ev in result.events)
    t, sigma, damping = result["t"], result["sigma_min"], result["damping"]
    damped_from = t[np.flatnonzero(damping == 0)[-1] + 1]
    # stopped max_damped_time after damping started (within one step)
    assert result.stop_time - damped_from == pytest.approx(policy.max_damped_time, abs=2e-3)
    assert np.all(sigma[t >= damped_from] < policy.threshold)
    for key, value in result.signals.items():
        assert np.all(np.isfinite(value)), key


def test_step_row_without_the_true_theta_d_names_what_it_needs(make_chain):
    """``step_row`` returns the signals' row, whose e of Eq. (54) needs the true theta_d: a
    controller made without it refuses the call by name, rather than a row of None."""
    robot = make_chain(4)
    ctrl = controller_for(robot, "ppc")
    assert ctrl.theta_d_true is None
    q = robot.configuration((0.0, 0.0, 0.1), 0.7 * (-1.0) ** np.arange(robot.n_joints))
    meas = Sensor(robot, ctrl.model, full_model=False).measure(0.0, q, np.zeros(robot.model.nv))
    with pytest.raises(FfsmError, match="step_row needs theta_d_true"):
        ctrl.step_row(meas, 1e-3)


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_damped_since_follows_each_stretch_of_damped_periods(backend):
    """``damped_since`` is the start of the current stretch of periods whose damping is
    positive, and None after a period without: checked against the damping each period
    reports, period by period, over planar5's first 7.3 s, which enter damped least squares
    at about 5.68 s and leave it at about 7.15 s (an ordinary period of the compiled backend
    skips the bookkeeping: this holds it to the same state). Entering warns once, pointing at
    the line that called the law (the paper's controller's ``step``), not inside it."""
    from ffsm_pin.sim.plant import Plant

    sc = builtin_scenario("planar5")
    # a threshold above the arm's sigma_min between 5.7 and 7.1 s (the shipped 0.05 m is never
    # reached from its physical estimates, docs/null_space.md)
    performance = dataclasses.replace(sc.performance, singularity_threshold=0.09)
    sc = dataclasses.replace(sc, performance=performance)
    setup = prepare(sc)
    ctrl = setup.controller
    if backend == "numpy":
        ctrl = LuJiaController(ctrl.context, backend="numpy")
    law, layout = ctrl.law, ctrl.signal_layout
    sensor = Sensor(setup.robot, setup.model, full_model=False)
    plant = Plant(setup.robot)
    q, v, dt = setup.q0.copy(), setup.v0.copy(), setup.scenario.dt
    plant.reset(q, v)
    expected, stretches = None, 0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SingularityWarning)
        for k in range(7300):
            t = k * dt
            u_m, signals = ctrl.step(sensor.measure(t, q, v))
            if signals.row[layout.index("damping")] > 0:
                stretches += expected is None
                expected = t if expected is None else expected
            else:
                expected = None
            assert law.damped_since == expected, t
            q, v, _ = plant.step(q, v, u_m, dt)
    assert stretches == 1 and expected is None  # one stretch, entered and left
    assert len(caught) == 1, [str(w) for w in caught]
    assert Path(caught[0].filename).name == "lu_jia.py"  # LuJiaController.step's call
