"""The feasible rate of ``controller.saturation = "auxiliary"`` (issue 39, docs/saturation.md
"The feasible rate"): where the law's command exceeds the actuators' limits, the feedforward
of its dynamic level (the rate of the tracked w_mc + chi_v) is scaled to what the limits
deliver before the command is given, and the part not delivered is booked as the velocity
deficit chi_v. Checked against closed forms (the Schur complement, the deficit of the scaled
feedforward, the largest feasible scale) at random states and at a fold of the kinematic
level, numpy reference and compiled kernel equal, planar and spatial."""

from __future__ import annotations

import copy
import dataclasses
import warnings

import numpy as np
import pytest

from ffsm_pin.control import saturation_kernels as sk
from ffsm_pin.control.kinematic import KinematicInputs
from ffsm_pin.control.saturation import (
    Saturation,
    auxiliary_term,
    feasible_command,
    feasible_scale,
    feedforward_gain,
)
from ffsm_pin.scenario.devices import ActuatorSpec
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.run import Sensor, prepare

#: A built-in case of each geometry.
CASES = {"planar": "case1", "spatial": "spatial"}


def _setup(name: str, limit: float):
    sc = builtin_scenario(name)
    law = dataclasses.replace(sc.controller.lu_jia, saturation=Saturation("auxiliary"))
    sc = dataclasses.replace(sc, controller=dataclasses.replace(sc.controller, lu_jia=law))
    sc = dataclasses.replace(sc, actuators=ActuatorSpec(torque_limit=limit))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(sc)
    meas = Sensor(setup.robot, setup.model, full_model=False).measure(0.0, setup.q0, setup.v0)
    return setup, meas


def _random_case(setup, meas, rng, coupled: bool):
    """M-hat at a random configuration near the initial one, S = d w_mc / d w_b (zero for
    every scheme but Eq. 81, random otherwise), limits, a command and a feedforward."""
    model, ctrl = setup.model, setup.controller.law
    n, m3 = meas.q_m.size, ctrl.m3
    q_m = meas.q_m + rng.normal(0.0, 0.5, n)
    M = model.mass_matrix(ctrl.theta_d, meas.q_b, q_m)
    S = rng.normal(0.0, 0.3, (n, m3)) if coupled else np.zeros((n, m3))
    limit = rng.uniform(0.5, 2.0, n)
    return M, S, limit, rng.normal(0.0, 3.0, n), rng.normal(0.0, 50.0, n)


@pytest.mark.parametrize("geometry", CASES)
def test_the_feasible_command_in_closed_form(geometry):
    """At random states: G is the torque per unit feedforward of Eqs. (60a), (64)-(65) (the
    Schur complement M* for S = 0, for which M^-1 (0, G a) = (-M_bb^-1 M_bm a, a)); the
    command is u0 + s G a with u0 = u_c - G a; every joint within max(L_j, |u0_j|); s the
    largest such (s + 1e-9 breaks a bound, unless s = 1); and the deficit it books,
    M^-1 (0, u_f - u_c), has the joint rows -(1 - s) a: the part of the feedforward that is
    not delivered. Within the limits, u_c itself. Numpy and compiled equal."""
    setup, meas = _setup(CASES[geometry], 1.0)
    rng = np.random.default_rng(39)
    m3 = setup.controller.law.m3
    for k in range(20):
        M, S, limit, u0, a = _random_case(setup, meas, rng, coupled=k % 2 == 1)
        G = feedforward_gain(M, S)
        if k % 2 == 0:
            Mbb, Mbm = M[:m3, :m3], M[:m3, m3:]
            np.testing.assert_allclose(G, M[m3:, m3:] - Mbm.T @ np.linalg.solve(Mbb, Mbm),
                                       rtol=1e-12, atol=1e-12 * np.abs(M).max())  # fmt: skip
        else:  # the manifold's torque is affine in its target, slope G (finite difference)
            from ffsm_pin.control.manifold import manifold_input

            r, w_hat = rng.normal(size=M.shape[0]), rng.normal(size=M.shape[0])
            S_arg = S[:, 0] if m3 == 1 else S
            zero = manifold_input(M, r, w_hat, np.zeros(a.size), np.zeros(a.size), S_arg, 0.8)
            ones = manifold_input(M, r, w_hat, np.zeros(a.size), a, S_arg, 0.8)
            np.testing.assert_allclose(ones.u_m - zero.u_m, G @ a, rtol=1e-9,
                                       atol=1e-9 * np.abs(G @ a).max())  # fmt: skip
        g = G @ a
        u_c = u0 + g
        term = auxiliary_term(Saturation("auxiliary"), limit, (1.0, 1.0), 1e-3)
        assert term is not None
        u_f = feasible_command(limit, u_c, a, M, S)
        np.testing.assert_allclose(sk.feasible_command(term, u_c, a, M, S), u_f, rtol=1e-12,
                                   atol=1e-12 * np.abs(u_c).max())  # fmt: skip
        s = feasible_scale(u0, g, limit)
        assert 0.0 <= s <= 1.0
        np.testing.assert_allclose(u_f, u0 + s * g, rtol=1e-12, atol=1e-12 * np.abs(g).max())
        bound = np.maximum(limit, np.abs(u0))
        assert np.all(np.abs(u_f) <= bound * (1 + 1e-12))
        if s < 1.0:
            assert np.any(np.abs(u0 + (s + 1e-9) * g) > bound)
        if k % 2 == 0:
            deficit = np.linalg.solve(M, np.concatenate((np.zeros(m3), u_f - u_c)))
            np.testing.assert_allclose(deficit[m3:], -(1.0 - s) * a, rtol=1e-9,
                                       atol=1e-9 * np.abs(a).max())  # fmt: skip
        small = limit * rng.uniform(-1.0, 1.0, limit.size)  # within: the command itself
        assert feasible_command(limit, small, a, M, S) is small
        np.testing.assert_array_equal(sk.feasible_command(term, small, a, M, S), small)


def _fold(ctrl, meas):
    """(q_m at sigma_min = 0 of the kinematic level, the direction from meas.q_m to it):
    the minimum of sigma_min over the joint angles, near the initial configuration."""
    from scipy.optimize import minimize

    wb = meas.w[0] if ctrl.m3 == 1 else meas.w[: ctrl.m3]

    def sigma(q_m):
        x = KinematicInputs(0.0, meas.q_b, q_m, meas.z_e, ctrl.theta_b, ctrl.theta_z, wb)
        return ctrl.kinematic.evaluate(x)[3]

    res = minimize(sigma, meas.q_m, method="Nelder-Mead",
                   options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000})  # fmt: skip
    assert res.fun < 1e-3 * ctrl.kinematic.threshold
    return sigma, res.x


@pytest.mark.filterwarnings("ignore:.*near a singularity")  # (the point of the test)
@pytest.mark.parametrize("geometry", CASES)
def test_crossing_the_fold_does_not_make_the_command_spike(geometry):
    """The spike of issue 39: the joints cross the kinematic level's fold (sigma_min of
    J_m-hat U-hat below the damping threshold), the rate of the damped inverse's w_mc is
    large, and the paper's law asks M* dw_mc/dt for it. At such a period (half the threshold
    on the way to the fold, crossing it at 1 rad/s), the paper's command is more than 3x a
    limit set to the rest of its command, |u_c - G a|; with the option the command stays
    within that limit, and the paper's own command is what the option gives without
    limits."""
    setup, meas = _setup(CASES[geometry], 1e12)  # (no limit reached)
    ctrl = setup.controller.law
    ctrl.backend = "numpy"
    sigma, q_fold = _fold(ctrl, meas)
    step = q_fold - meas.q_m
    lo, hi = 0.0, 1.0  # bisect for sigma_min = threshold / 2 on the segment to the fold
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        above = sigma(meas.q_m + mid * step) > 0.5 * ctrl.kinematic.threshold
        lo, hi = (mid, hi) if above else (lo, mid)
    w = meas.w.copy()
    w[ctrl.m3 :] = step / np.linalg.norm(step)
    at = meas._replace(q_m=meas.q_m + lo * step, w=w)
    free = copy.deepcopy(ctrl).step_numpy(at, 1e-3)  # no limits: the paper's command
    paper = copy.deepcopy(ctrl)
    paper.auxiliary = None
    u_c = paper.step_numpy(at, 1e-3).u_m
    np.testing.assert_array_equal(free.u_m, u_c)
    M = setup.model.mass_matrix(ctrl.theta_d, at.q_b, at.q_m)
    g = feedforward_gain(M, np.zeros((u_c.size, ctrl.m3))) @ free.w_mc_dot
    limit = float(np.abs(u_c - g).max())
    assert np.abs(u_c).max() > 3.0 * limit  # the spike: the feedforward dominates
    bounded = copy.deepcopy(ctrl)
    assert bounded.auxiliary is not None
    bounded.auxiliary.term = bounded.auxiliary.term._replace(limit=np.full(u_c.size, limit))
    u_f = bounded.step_numpy(at, 1e-3).u_m
    assert np.abs(u_f).max() <= limit * (1 + 1e-9)
