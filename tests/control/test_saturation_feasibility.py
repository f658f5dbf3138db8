"""The torque feasibility condition of ``--check`` (docs/saturation.md, "The feasibility
condition"): closed forms, the forward dynamics it inverts, and the warning it gives."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.control.saturation_feasibility import (
    TorqueFeasibility,
    reach_acceleration,
    row_map,
    torque_needed,
)


def test_reach_of_an_accelerating_reference_is_its_closed_form():
    """A reference leaving the robot at constant acceleration c, z_d = c t^2 / 2, error 0 at
    t = 0 (upper side 1, lower -sigma): 2 excess / t^2 = c - 2 sigma rho(t) / t^2 grows with
    t, so the need is c - 2 sigma rho(T) / T^2 at T, the last time."""
    c, sigma, r0, ri, beta = 0.3, 0.8, 1.0, 0.05, 0.5
    ts = np.linspace(0.01, 20.0, 2000)
    rho = ((r0 - ri) * np.exp(-beta * ts) + ri)[:, None]
    d = (-c * ts**2 / 2)[:, None]
    accel, t_worst = reach_acceleration(d, rho, [-sigma], [1.0], ts)
    T = ts[-1]
    expected = c - 2 * sigma * rho[-1, 0] / T**2
    assert accel[0] == pytest.approx(expected, rel=1e-12) and t_worst[0] == T
    # a short run asks for nothing: the funnel's width covers the reference's motion
    short = ts < 1.0
    accel, t_worst = reach_acceleration(d[short], rho[short], [-sigma], [1.0], ts[short])
    assert accel[0] == 0.0 and np.isnan(t_worst[0])


def test_reach_is_the_least_acceleration_that_enters_the_funnel():
    """From rest at the returned A the robot's reach A t^2 / 2 covers the excess at every
    time, touching it at t_worst; one part in 1e6 less misses there."""
    rng = np.random.default_rng(3)
    ts = np.linspace(0.05, 10.0, 400)
    d = 0.5 + 0.3 * np.sin(np.outer(ts, rng.uniform(0.2, 2.0, 3)))
    rho = ((1.0 - 0.05) * np.exp(-np.outer(ts, [0.3, 1.0, 2.0])) + 0.05) * 0.6
    accel, t_worst = reach_acceleration(d, rho, [-0.8] * 3, [1.0] * 3, ts)
    excess = d - rho
    assert np.all(accel > 0)
    assert np.all(accel * ts[:, None] ** 2 / 2 >= excess - 1e-12)
    k = np.searchsorted(ts, t_worst)
    short = (1 - 1e-6) * accel * t_worst**2 / 2
    assert np.all(short < excess[k, np.arange(3)])


def test_one_joint_by_hand():
    """A 1-joint robot, one task row, base unactuated: M* = d - b^2/a, J* = j_m - j_b b/a,
    the need is |M* / J*| a_row; the warning fires just above the limit, not below."""
    a, b, d, jb, jm = 3.0, 0.7, 1.2, 0.4, 1.5
    M = np.array([[a, b], [b, d]])
    J = np.array([[jb, jm]])
    M_star, G, _ = row_map(M, J, np.ones((1, 1)), 1, attitude=False)
    assert M_star[0, 0] == pytest.approx(d - b * b / a, rel=1e-14)
    assert G[0, 0] == pytest.approx(jm - jb * b / a, rel=1e-14)
    need = abs((d - b * b / a) / (jm - jb * b / a)) * 0.25
    share = torque_needed(M_star, G, [0.25])
    assert share.sum() == pytest.approx(need, rel=1e-12)

    def report(limit):
        return TorqueFeasibility(
            ("z0",), np.array([0.25]), np.array([0.1]), np.array([2.0]), share,
            np.array([limit]),
        )  # fmt: skip

    assert report(need * 1.001).problem(["j1"]) is None
    text = report(need * 0.5).problem(["j1"])
    assert text is not None and "'j1'" in text and "2 x" in text and "beta_z" in text
    follow = TorqueFeasibility(
        ("z0",), np.array([0.05]), np.array([0.25]), np.array([2.0]), share, np.array([need / 4])
    )
    text = follow.problem(["j1"])
    assert text is not None and "reference.ee" in text and "\n" not in text


@pytest.mark.parametrize("case", ["case1", "spatial"])
def test_the_map_inverts_the_forward_dynamics(case):
    """The torque M* G^+ a, applied with the base unactuated (M dw/dt = (0, u) at rest), moves
    the funnel rows at a: the condition's map is the plant's, planar and spatial."""
    from ffsm_pin.control.compiled import no_warm_up
    from ffsm_pin.control.kinematic import attitude_matrix
    from ffsm_pin.scenario.file import builtin_scenario
    from ffsm_pin.sim.setup import prepare

    with no_warm_up():
        setup = prepare(builtin_scenario(case))
    model, m3 = setup.model, setup.model.m3
    q_b, q_m = setup.controller.context.initial.q_b, setup.controller.context.initial.q_m
    n_task = setup.controller.context.n_task
    J_b, J_m = model.jacobians(setup.theta_z, q_b, q_m)
    J = np.hstack((J_b[:n_task], J_m[:n_task]))
    M = model.mass_matrix(setup.theta_d, q_b, q_m)
    L_b = np.real(attitude_matrix(q_b, m3))
    M_star, G, _ = row_map(M, J, L_b, m3, attitude=True)
    a = np.random.default_rng(0).normal(size=G.shape[0])
    u = M_star @ np.linalg.pinv(G) @ a
    w_dot = np.linalg.solve(M, np.concatenate((np.zeros(m3), u)))
    rows = np.concatenate((L_b @ w_dot[:m3], J @ w_dot))
    np.testing.assert_allclose(rows, a, rtol=0, atol=1e-9 * np.abs(a).max())


def test_along_reference_integrates_the_least_norm_rates():
    """Constant maps and row rates: the joints move on the straight line q_m0 + G^+ r t and
    the base by L_b B G^+ r t (explicit Euler is exact here), and every configuration's maps
    are returned."""
    from ffsm_pin.control.saturation_feasibility import along_reference

    G = np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 2.0]])
    B = np.array([[0.1, -0.2, 0.3]])
    L_b = np.array([[2.0]])
    seen = []

    def maps(q_b, q_m):
        seen.append(float(q_b))
        return np.eye(3), G, B, L_b

    r = np.array([0.3, -0.1])
    ts = np.linspace(0.0, 4.0, 9)
    q_ms, mapped = along_reference(maps, lambda t, q_b, q_m: r, 0.2, np.zeros(3), ts)
    w_m = np.linalg.pinv(G) @ r
    np.testing.assert_allclose(q_ms, np.outer(ts, w_m), atol=1e-14)
    np.testing.assert_allclose(seen, 0.2 + ts * (L_b @ B @ w_m)[0], atol=1e-14)
    assert len(mapped) == ts.size
