"""Reaction wheels in the loop (issue 40): ``[robot.satellite.wheels]`` in a run
(ffsm_pin/sim/wheels_run.py; docs/capture.md, "Wheels in the loop")."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude.mrp import to_rotation
from ffsm_pin.robot.wheels import Wheels
from ffsm_pin.scenario.file import builtin_path, scenario_from_toml
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.plant import Plant
from ffsm_pin.sim.setup import prepare
from ffsm_pin.sim.wheels_run import WheelsInLoop

DURATION = 0.4  # [s], 200 control periods of the 'spatial' case
WHEELS = "\n[robot.satellite.wheels]\ninertia = 0.05\n"


class WheelCommand:
    """The run's controller, with a constant wheel torque (the optional hook) and, when
    ``still``, zero joint torques."""

    def __init__(self, inner, tau_w, still: bool = False) -> None:
        self.inner, self.tau_w, self.still = inner, np.asarray(tau_w, float), still

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def step(self, meas):
        out = self.inner.step(meas)
        return (np.zeros(len(meas.q_m)), {}) if self.still else out

    def wheel_torque(self, meas):
        return self.tau_w


def _run(table: str, case: str = "spatial", tau_w=None, still: bool = False, **replace):
    sc = scenario_from_toml(builtin_path(case).read_text() + table)
    setup = prepare(dataclasses.replace(sc, duration=DURATION, **replace))
    if tau_w is not None:
        setup.controller = WheelCommand(setup.controller, tau_w, still)
    return simulate(setup), setup


@pytest.fixture(scope="module")
def commanded():
    """The 'spatial' case with three wheels commanded a constant torque (no limits)."""
    return _run(WHEELS, tau_w=[0.05, -0.03, 0.02])


def test_total_momentum_is_kept_with_the_wheels_commanded(commanded):
    """The recorded L (robot + R_b A h) is constant to rounding while the wheels take up
    momentum the robot gives away: the robot's own L changes by -R_b A h."""
    result, setup = commanded
    assert result.completed
    t, h = result["t"], result["wheel_momentum"]
    # h = tau t, exactly the integral of the constant torque (no limit reached)
    np.testing.assert_allclose(h, np.outer(t, [0.05, -0.03, 0.02]), rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(result["wheel_torque"], np.tile([0.05, -0.03, 0.02], (len(t), 1)))
    L = result["L"]
    _, L_robot = Plant(setup.robot).momentum_rows(result["q"], result["v"])
    stored = np.array([to_rotation(s) @ x for s, x in zip(result["q_b"], h, strict=True)])
    np.testing.assert_allclose(L - L_robot, stored, atol=1e-13)  # L = L_robot + R_b A h
    assert np.abs(stored[-1]).max() > 4e-3  # the wheels hold momentum: L_robot moved
    scale = np.abs(stored).max()
    assert np.abs(L - L[0]).max() < 1e-12 * scale
    assert np.abs(result["P"] - result["P"][0]).max() < 1e-12
    summary = result.summary()
    assert summary["drift_L"] < 1e-12 * scale
    assert summary["wheel_saturation_fraction"] == 0.0


def test_wheel_speeds_are_the_spin_relative_to_the_bus(commanded):
    """wheel_speed = h / J_s - a . w_b, w_b the bus rate in its own frame (from the recorded
    base twist v[3:6], Pinocchio's local frame of the root)."""
    result, _ = commanded
    expected = result["wheel_momentum"] / 0.05 - result["v"][:, 3:6]
    np.testing.assert_allclose(result["wheel_speed"], expected, rtol=1e-12, atol=1e-12)


def test_without_a_wheel_command_the_run_is_the_run_without_wheels():
    """Wheels at rest that nobody commands change nothing: the same states bit for bit."""
    plain, _ = _run("")
    wheeled, _ = _run(WHEELS)
    for key in ("q", "v", "u_m", "L", "P"):
        np.testing.assert_array_equal(wheeled[key], plain[key], err_msg=key)
    assert not wheeled["wheel_momentum"].any() and not wheeled["wheel_torque"].any()
    assert "wheel_momentum" not in plain


def _one_body(inertia) -> pin.Model:
    model = pin.Model()
    root = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "bus")
    model.appendBodyToJoint(
        root, pin.Inertia(100.0, np.zeros(3), np.diag(inertia)), pin.SE3.Identity()
    )
    model.gravity.setZero()
    return model


@pytest.mark.parametrize("integrator", ["semi-implicit", "rk4"])
def test_a_wheel_torque_step_spins_the_bus_back_as_the_closed_form(integrator):
    """A free rigid body at rest with one wheel on its principal axis z: a torque step tau on
    the wheel gives h = tau t and the bus w_z = -tau t / I_z (L_total = I_z w_z + h = 0), its
    angle -tau t^2 / (2 I_z); the other axes stay at rest. The rate is exact (the momentum
    projection); so is RK4's angle (the bus torque is constant: w is linear in t), while the
    semi-implicit Euler step sums dt w_(k+1): its angle is off by exactly tau T dt / (2 I_z)."""
    I_z, tau, T = 7.0, 0.3, 1.0
    wheels = Wheels(np.array([[0.0], [0.0], [1.0]]), 0.02)
    for dt in (0.01, 0.005):
        plant = WheelsInLoop(_one_body([9.0, 8.0, I_z]), wheels, integrator, np.zeros(3), dt)
        q, v = pin.neutral(plant.model), np.zeros(6)
        plant.reset(q, v)
        plant.tau_cmd = np.array([tau])
        for _ in range(round(T / dt)):
            q, v, _ = plant.advance(q, v, np.zeros(0), dt)
        np.testing.assert_allclose(plant.h, [tau * T], rtol=1e-13)
        np.testing.assert_allclose(v[3:], [0.0, 0.0, -tau * T / I_z], rtol=1e-12, atol=1e-15)
        angle = pin.log3(pin.Quaternion(q[6], *q[3:6]).matrix())
        np.testing.assert_allclose(angle[:2], 0.0, atol=1e-15)
        euler = tau * T * dt / (2 * I_z) if integrator == "semi-implicit" else 0.0
        expected = -tau * T**2 / (2 * I_z) - euler
        assert angle[2] == pytest.approx(expected, rel=1e-12)


def test_torque_and_momentum_saturate():
    """A command above max_torque gives max_torque; h stops at max_momentum exactly, the
    torque is then zero; wheel_saturation_fraction counts those periods."""
    table = WHEELS + "max_torque = 0.1\nmax_momentum = [0.01, 0.02, 1.0]\n"
    result, setup = _run(table, tau_w=[0.5, -0.05, 0.5])
    tau, h, t = result["wheel_torque"], result["wheel_momentum"], result["t"]
    dt = setup.scenario.dt / setup.scenario.substeps
    assert np.abs(tau).max() <= 0.1 and np.abs(h).max(axis=0).tolist() <= [0.01, 0.02, 1.0]
    # wheel 0: 0.1 N m until h = 0.01 (at 0.1 s), then nothing; wheel 2 never cut by momentum
    full = t + 1e-9 < 0.1 - dt
    np.testing.assert_allclose(tau[full, 0], 0.1, rtol=1e-12)
    np.testing.assert_allclose(h[t > 0.1 + dt, 0], 0.01, rtol=1e-12)
    assert not tau[t > 0.1 + dt, 0].any()
    np.testing.assert_allclose(tau[:, 2], 0.1, rtol=1e-12)
    # wheel 1: -0.05 N m under both limits, h = -0.05 t
    np.testing.assert_allclose(h[:, 1], -0.05 * t, rtol=1e-12, atol=1e-16)
    # every period has wheel 2 cut by its torque limit
    assert result.summary()["wheel_saturation_fraction"] == 1.0
    L = result["L"]
    assert np.abs(L - L[0]).max() < 1e-12 * 0.4  # the limits keep the total momentum


def test_saturation_fraction_counts_the_periods_at_a_limit():
    """Only a momentum limit reached at 0.25 s of the 0.4 s: the fraction is that of the
    periods after it (counted from the recorded torques, an independent count)."""
    result, _ = _run(WHEELS + "max_momentum = 0.01\n", tau_w=[0.04, 0.0, 0.0])
    cut = ~np.isclose(result["wheel_torque"][:, 0], 0.04, rtol=1e-12)
    fraction = result.summary()["wheel_saturation_fraction"]
    assert fraction == pytest.approx(cut.mean(), abs=1.5 / len(cut))
    assert fraction == pytest.approx((0.4 - 0.25) / 0.4, abs=0.02)


class _Still:
    """A controller that holds zero joint torques (and has no wheel_torque hook)."""

    def __init__(self, inner) -> None:
        self.inner = inner

    def __getattr__(self, name):
        if name == "wheel_torque":
            raise AttributeError(name)
        return getattr(self.inner, name)

    def step(self, meas):
        return np.zeros(len(meas.q_m)), {}


def test_attitude_pd_turns_the_bus_back():
    """``control = "attitude-pd"`` with the arm still (zero joint torques): the 'spatial'
    case's bus attitude error (0.2 rad) shrinks steadily, below 30 % in 3 s (kp = 3 N m/rad,
    kd = 6 N m s/rad on a bus of a few kg m^2, arm included: about critically damped at about
    1 rad/s); without the wheels the bus does not move (no torque, no momentum)."""
    table = (
        '\n[robot.satellite.wheels]\ninertia = 0.05\ncontrol = "attitude-pd"\nkp = 3.0\nkd = 6.0\n'
    )
    errors = []
    for extra in (table, ""):
        sc = scenario_from_toml(builtin_path("spatial").read_text() + extra)
        setup = prepare(dataclasses.replace(sc, duration=3.0))
        setup.controller = _Still(setup.controller)
        result = simulate(setup)
        R_d = to_rotation(np.asarray(sc.reference.base_attitude, float))
        err = [np.linalg.norm(pin.log3(R_d.T @ to_rotation(x))) for x in result["q_b"]]
        errors.append((err[0], err[-1], result, err))
    (start, end, wheeled, wheeled_err), (start0, end0, _, _) = errors
    assert start > 0.15 and end < 0.3 * start
    assert (np.diff(wheeled_err) <= 1e-12).all()  # (damped: it never turns away again)
    assert end0 == pytest.approx(start0, rel=1e-9)
    L = wheeled["L"]
    assert np.abs(L - L[0]).max() < 1e-12 * np.abs(wheeled["wheel_momentum"]).max()


def test_wheels_through_a_capture():
    """The 'capture' case with wheels commanded a constant torque: the wheels keep their h
    across the capture (h = tau t on every row), and over the whole run, impact included, the
    recorded L of robot, target (free, then held) and wheels is constant to rounding while
    the wheels spin up (the wheels' torque is a couple: the robot's CoM stays on its line)."""
    tau = np.array([0.02, 0.01, -0.02])
    sc = scenario_from_toml(builtin_path("capture").read_text() + WHEELS)
    setup = prepare(dataclasses.replace(sc, duration=3.3))
    setup.controller = WheelCommand(setup.controller, tau)
    result = simulate(setup)
    summary = result.summary()
    assert summary["captured"] and summary["completed"]
    t, h, L = result["t"], result["wheel_momentum"], result["L"]
    np.testing.assert_allclose(h, np.outer(t, tau), rtol=1e-12, atol=1e-15)
    held = t >= summary["capture_time"]
    assert 10 < held.sum() < len(t)
    stored = np.abs(h[held]).max()
    assert np.abs(L - L[0]).max() < 1e-12 * max(stored, np.abs(L).max())
    assert np.abs(result["P"] - result["P"][0]).max() < 1e-12
    # detumble_time: the row after the last one (from the capture on) at which the held box
    # turns relative to the bus by 0.1 deg/s or more, recomputed with the quaternion's formula
    # (None: still turning at the end; this case holds the hand's position, not its attitude)
    x, y, z, w = result["target_pose"][:, 3:].T
    R = np.stack(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    ).transpose(2, 0, 1)
    rel = np.linalg.norm(
        np.einsum("nij,nj->ni", R, result["target_twist"][:, 3:]) - result["w"][:, :3], axis=1
    )
    fast = np.flatnonzero(held & (rel >= np.deg2rad(0.1)))
    if fast.size == 0:
        expected = t[held][0]
    else:
        expected = None if fast[-1] == len(t) - 1 else t[fast[-1] + 1]
    assert summary["detumble_time"] == expected


def test_attitude_pd_after_capture_starts_at_the_grasp():
    """``control = "attitude-pd-after-capture"``: no wheel torque before the grasp (h stays
    zero and the run is the one without wheels bit for bit), the PD's after it, with the whole
    system's L kept from the capture on."""
    table = (
        '\n[robot.satellite.wheels]\ninertia = 0.05\ncontrol = "attitude-pd-after-capture"\n'
        "kp = 20.0\nkd = 100.0\n"
    )
    runs = []
    for extra in (table, ""):
        sc = scenario_from_toml(builtin_path("capture").read_text() + extra)
        runs.append(simulate(prepare(dataclasses.replace(sc, duration=3.3))))
    wheeled, plain = runs
    summary = wheeled.summary()
    t, tau, h = wheeled["t"], wheeled["wheel_torque"], wheeled["wheel_momentum"]
    before = t < summary["capture_time"]
    assert summary["captured"] and not tau[before].any() and not h[before].any()
    assert np.abs(tau[~before]).min(axis=1).max() > 0 and np.abs(h[-1]).max() > 0
    for key in ("q", "v", "u_m"):
        np.testing.assert_array_equal(wheeled[key][before], plain[key][before], err_msg=key)
    L = wheeled["L"][~before]
    assert np.abs(L - L[0]).max() < 1e-12 * np.abs(wheeled["L"]).max()


def test_the_wheels_figure_is_drawn_for_runs_with_wheels(commanded, tmp_path):
    from ffsm_pin.sim.figures import FIGURE_NAMES, WHEEL_FIGURE, write_figures

    result, _ = commanded
    paths = write_figures(result, tmp_path / "w")
    assert [p.name for p in paths] == [*FIGURE_NAMES, WHEEL_FIGURE]
    assert (tmp_path / "w" / WHEEL_FIGURE).stat().st_size > 10_000
    plain, _ = _run("")
    assert [p.name for p in write_figures(plain, tmp_path / "p")] == list(FIGURE_NAMES)


@pytest.mark.parametrize("tau_w", [[0.1, 0.2], [0.1, np.nan, 0.0]])
def test_a_bad_wheel_torque_stops_the_run_as_a_controller_fault(tau_w):
    result, _ = _run(WHEELS, tau_w=tau_w)
    assert not result.completed and result.stop_cause == "controller"
    assert "wheel_torque returned" in result.stop_reason and "one per wheel" in result.stop_reason
    assert "\n" not in result.stop_reason


def test_a_campaign_varies_the_wheels_and_writes_their_column(tmp_path):
    """A campaign over a scenario with wheels (the bus attitude PD on): the wheels' keys can be
    varied, results.parquet has wheel_saturation_fraction typed, the nominal row (no limit)
    0 and a 1 mN m torque limit cutting every period's command."""
    import pyarrow.parquet as pq

    from ffsm_pin.sweep.campaign import load_campaign
    from ffsm_pin.sweep.cases import expand
    from ffsm_pin.sweep.engine import run_case
    from ffsm_pin.sweep.table import ResultsTable

    table = '\n[robot.satellite.wheels]\ninertia = 0.05\ncontrol = "attitude-pd"\nkp = 3.0\n'
    (tmp_path / "wheels.toml").write_text(builtin_path("spatial").read_text() + table)
    path = tmp_path / "campaign.toml"
    path.write_text(
        '[campaign]\nname = "wheel-limit"\nscenario = "wheels.toml"\nseed = 1\n'
        f"duration = {DURATION}\n\n"
        '[[vary]]\nkey = "robot.satellite.wheels.max_torque"\nvalues = [0.001]\n',
        encoding="utf-8",
    )
    campaign = load_campaign(path)
    cases = expand(campaign)
    results = ResultsTable(tmp_path / "results.parquet", campaign.columns)
    for case in cases:
        results.add(case, run_case(case.scenario_toml))
    got = pq.read_table(tmp_path / "results.parquet")
    assert got.schema.field("wheel_saturation_fraction").type == "double"
    rows = sorted(got.to_pylist(), key=lambda r: r["case"])
    assert [r["wheel_saturation_fraction"] for r in rows] == [0.0, 1.0]
