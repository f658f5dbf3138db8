"""Kinematic level (ffsm_pin.control.kinematic) along closed-loop trajectories of the paper's
case: the identities Eq. (26) and Eq. (37) (Eq. 81 for case 3) hold where the pseudo-inverse is
undamped, the truth satisfies Eq. (15) and Eq. (4), and the complex-step derivative of w_mc
agrees with a central difference of w_mc.

Each closed loop runs on both controller backends (the numpy reference and the compiled numba
period). Everything the paper's identities need is recomputed here from the recorded signals
with the model's own matrices (``momentum_matrices``, ``jacobians``) and with psi, Phi written
out from Eqs. (20)-(22), independently of the controller's internals.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from ffsm_pin.control.kinematic import KinematicInputs
from ffsm_pin.control.lu_jia import LuJiaController
from ffsm_pin.control.lu_jia_params import LuJiaParams
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.scenario.spec import (
    ControllerSpec,
    Performance,
    RobotSpec,
    Scenario,
)
from ffsm_pin.sim.run import prepare, simulate

DURATION = 2.5  # [s] long enough for the adaptation to move every estimate
DT = 1e-3
# The paper's case as shipped (Table 2 initial state, Eq. 80 reference, rho_b0 = 1.0), so the
# tests also guard the built-in scenario file.
CASE1 = builtin_scenario("case1")
EQ80, TABLE2, FUNNEL_B = CASE1.reference, CASE1.initial, CASE1.performance.funnel_b
SAMPLES = 9  # times along the trajectory where the identities are checked


def _run(scheme: str, backend: str):
    sc = Scenario(
        RobotSpec(),
        TABLE2,
        EQ80,
        ControllerSpec(lu_jia=LuJiaParams(scheme=scheme)),
        duration=DURATION,
        dt=DT,
        performance=Performance(funnel_b=FUNNEL_B),
    )
    setup = prepare(sc)
    # the same controller (estimates, funnels, gains, initial measurement) on `backend`
    setup.controller = LuJiaController(setup.controller.context, backend=backend)
    assert setup.controller.law.backend == backend
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = simulate(setup)
    assert result.completed, result.stop_reason
    return setup, result


@pytest.fixture(scope="module", params=["numba", "numpy"])
def ppc_run(request):
    return _run("ppc", request.param)


@pytest.fixture(scope="module", params=["numba", "numpy"])
def case3_run(request):
    return _run("no-attitude", request.param)


def psi_Phi(err, rho, side_positive, sigma):
    """psi = R(e / rho) (Eq. 21) and Phi = dR/ds / rho (Eq. 22), element-wise."""
    s = err / rho
    psi = np.where(
        side_positive,
        np.log((sigma + s) / (sigma - sigma * s)),
        np.log((sigma + sigma * s) / (sigma - s)),
    )
    dR = np.where(side_positive, 1 / (sigma + s) + 1 / (1 - s), 1 / (1 + s) + 1 / (sigma - s))
    return psi, dR / rho


def sample_indices(result):
    n = len(result["t"])
    return np.unique(np.linspace(0, n - 2, SAMPLES).astype(int))


def inputs_at(result, k):
    """The kinematic inputs at sample k and their rates along the recorded trajectory."""
    s = result.signals
    dt = result.dt
    x = KinematicInputs(
        s["t"][k], s["q_b"][k, 0], s["q"][k, 4:], s["z_e"][k],
        s["theta_b_hat"][k], s["theta_z_hat"][k], s["w"][k, 0],
    )  # fmt: skip
    rates = KinematicInputs(
        1.0, s["w"][k, 0], s["w"][k, 1:], s["z_e_dot"][k],
        (s["theta_b_hat"][k + 1] - s["theta_b_hat"][k]) / dt,
        (s["theta_z_hat"][k + 1] - s["theta_z_hat"][k]) / dt, 0.0,
    )  # fmt: skip
    return x, rates


def shifted(x: KinematicInputs, rates: KinematicInputs, h: float) -> KinematicInputs:
    return KinematicInputs(
        *(np.asarray(a) + h * np.asarray(r) for a, r in zip(x, rates, strict=True))
    )


# ------------------------------------------------------------------------- Eqs. (26), (37)
def test_eq26_and_eq37_hold_along_the_closed_loop(ppc_run):
    setup, result = ppc_run
    s, model, g = result.signals, setup.model, setup.scenario.controller.lu_jia.gains
    fz, fb = setup.scenario.performance.funnel_z, setup.scenario.performance.funnel_b
    side_z, side_b = s["err_z"][0] >= 0, s["err_b"][0] >= 0  # Eq. (16)/(17): sign at t = 0
    checked = 0
    for k in range(0, len(s["t"]), 50):
        if s["damping"][k] != 0:
            continue
        q_b, q_m, w_mc = s["q_b"][k, 0], s["q"][k, 4:], s["w_mc"][k]
        th_b, th_z = s["theta_b_hat"][k], s["theta_z_hat"][k]
        # Eq. (26): H_bm-hat w_mc = A0-hat + k_b H_bb-hat L_b^T Phi_b psi_b, L_b = 1 (planar)
        psi_b, Phi_b = psi_Phi(s["err_b"][k], s["rho_b"][k], side_b, np.array(fb.sigma))
        H_bb, H_bm, A0 = model.momentum_matrices(th_b, q_b, q_m)
        rhs26 = A0 + g.k_b * H_bb[0, 0] * Phi_b * psi_b
        np.testing.assert_allclose(H_bm @ w_mc, rhs26, rtol=0, atol=1e-9)
        # Eq. (37): J_m-hat w_mc = -v0bar-hat + dz_ed/dt - k_z Phi_z psi_z
        psi_z, Phi_z = psi_Phi(s["err_z"][k], s["rho_z"][k], side_z, np.array(fz.sigma))
        _, J_m = model.jacobians(th_z, q_b, q_m)
        v0bar = np.array([th_z[0], th_z[1], 0.0])
        rhs37 = -v0bar + s["z_e_d_dot"][k] - g.k_z * Phi_z * psi_z
        np.testing.assert_allclose(J_m @ w_mc, rhs37, rtol=0, atol=1e-9)
        checked += 1
    assert checked >= 40  # undamped along (almost) the whole run
    # the identities are not trivially satisfied: the estimates moved and psi is not zero
    assert np.linalg.norm(s["theta_z_hat"][-1] - s["theta_z_hat"][0]) > 1e-3
    assert np.linalg.norm(s["theta_b_hat"][-1] - s["theta_b_hat"][0]) > 1e-3


def test_eq81_holds_along_case_3(case3_run):
    """Case 3, Eq. (81): J_m-hat w_mc = -v0bar-hat + dz_ed/dt - J_b-hat w_b - k_z Phi_z psi_z."""
    setup, result = case3_run
    s, model, g = result.signals, setup.model, setup.scenario.controller.lu_jia.gains
    sigma = np.array(setup.scenario.performance.funnel_z.sigma)
    side = s["err_z"][0] >= 0
    checked = 0
    for k in range(0, len(s["t"]), 50):
        if s["damping"][k] != 0:
            continue
        q_b, q_m, th_z = s["q_b"][k, 0], s["q"][k, 4:], s["theta_z_hat"][k]
        psi_z, Phi_z = psi_Phi(s["err_z"][k], s["rho_z"][k], side, sigma)
        J_b, J_m = model.jacobians(th_z, q_b, q_m)
        target = -np.array([th_z[0], th_z[1], 0.0]) + s["z_e_d_dot"][k] - g.k_z * Phi_z * psi_z
        np.testing.assert_allclose(
            J_m @ s["w_mc"][k], target - J_b[:, 0] * s["w"][k, 0], rtol=0, atol=1e-9
        )
        checked += 1
    assert checked >= 40


# ------------------------------------------------------------------------- truth: (15), (4)
def test_truth_satisfies_eq15_and_eq4_case1(ppc_run):
    check_truth(*ppc_run)


def test_truth_satisfies_eq15_and_eq4_case3(case3_run):
    check_truth(*case3_run)


def check_truth(setup, result):
    """The plant (Pinocchio, momentum projected) and the parametric model agree: Y_b theta_b = 0
    (Eq. 15) and Y_z theta_z + (0, 0, dq_e/dt) = dz_e/dt (Eq. 4) with the true vectors."""
    s, model = result.signals, setup.model
    # terms of Eq. (13) are H w ~ 40 kg m^2 * 1 rad/s: rounding of the sums ~ 1e-13
    scale = 1 + np.abs(setup.theta_b[0])
    for k in range(0, len(s["t"]), 10):
        q_b, q_m, w = s["q_b"][k, 0], s["q"][k, 4:], s["w"][k]
        assert abs((model.Y_b(q_b, q_m, w) @ setup.theta_b)[0]) <= 1e-11 * scale
        pred = model.Y_z(q_b, q_m, w) @ setup.theta_z
        pred[2] += model.ee_attitude_rate(w)
        np.testing.assert_allclose(pred, s["z_e_dot"][k], rtol=0, atol=1e-11)
    # and the estimates do not satisfy it (the adaptation has work to do)
    k = len(s["t"]) // 2
    Yb = model.Y_b(s["q_b"][k, 0], s["q"][k, 4:], s["w"][k])
    assert abs((Yb @ s["theta_b_hat"][0])[0]) > 1e-3


# ------------------------------------------------------------------------- dw_mc / dt
def test_complex_step_derivative_matches_central_difference_case1(ppc_run):
    check_derivative(*ppc_run, eq81=False)


def test_complex_step_derivative_matches_central_difference_case3(case3_run):
    check_derivative(*case3_run, eq81=True)


def check_derivative(setup, result, eq81: bool):
    """dw_mc/dt from KinematicLaw.command (one complex-step evaluation) against
    (w_mc(x + h r) - w_mc(x - h r)) / 2h along the recorded rates r."""
    law = setup.controller.law.kinematic  # stateless: funnels fixed at t = 0
    h = 1e-6  # truncation ~ h^2 |w_mc'''| ~ 1e-10; rounding ~ 1e-16 |w_mc| / h ~ 1e-9
    for k in sample_indices(result):
        if result["damping"][k] != 0:
            continue
        x, rates = inputs_at(result, k)
        cmd = law.command(x, rates)
        # the recorded w_mc (numpy or compiled backend) is the law's value
        np.testing.assert_allclose(cmd.w_mc, result["w_mc"][k], rtol=1e-10, atol=1e-12)
        fd = (law.evaluate(shifted(x, rates, h))[0] - law.evaluate(shifted(x, rates, -h))[0]) / (
            2 * h
        )
        scale = np.linalg.norm(cmd.w_mc_dot)
        assert scale > 1e-3  # a moving command, not a trivial zero
        np.testing.assert_allclose(cmd.w_mc_dot, fd, rtol=0, atol=1e-6 * scale)
        if eq81:  # Eq. (81) depends on w_b: its sensitivity, by difference too
            xp = x._replace(w_b=x.w_b + h)
            xm = x._replace(w_b=x.w_b - h)
            fd_wb = (law.evaluate(xp)[0] - law.evaluate(xm)[0]) / (2 * h)
            np.testing.assert_allclose(cmd.dwmc_dwb, fd_wb, rtol=0, atol=1e-7)
            assert np.linalg.norm(cmd.dwmc_dwb) > 0.1
        else:
            np.testing.assert_array_equal(cmd.dwmc_dwb, 0.0)


def test_derivative_along_each_input_separately(ppc_run):
    """The directional derivative is linear in the rates: the sum over single-input rates
    (t, q_b, q_m, z_e, theta_b, theta_z) equals the full one, and each part matches its own
    central difference (catches an input that the complex step does not reach)."""
    setup, result = ppc_run
    law = setup.controller.law.kinematic
    k = sample_indices(result)[4]
    x, rates = inputs_at(result, k)
    zero = KinematicInputs(*(0.0 * np.asarray(r) for r in rates))
    total = np.zeros(setup.model.n_joints)
    h = 1e-6
    for i, name in enumerate(KinematicInputs._fields[:6]):
        r = zero._replace(**{name: rates[i]})
        part = law.command(x, r).w_mc_dot
        fd = (law.evaluate(shifted(x, r, h))[0] - law.evaluate(shifted(x, r, -h))[0]) / (2 * h)
        np.testing.assert_allclose(part, fd, rtol=0, atol=1e-6 * max(1.0, np.linalg.norm(part)))
        total += part
    np.testing.assert_allclose(total, law.command(x, rates).w_mc_dot, rtol=1e-10, atol=1e-12)
