"""``controller.estimates.initial = "perturbed"`` draws physical bodies (issue 41): every drawn
body is a rigid body within the spread, M(q, theta_d-hat) is positive definite at random
configurations by construction, a seed reproduces its draw, and a run writes what was drawn
(estimates.json) from which the same estimates follow."""

from __future__ import annotations

import dataclasses
import json
import math
import warnings

import numpy as np
import pytest

from ffsm_pin.model import make_model
from ffsm_pin.robot import check_inertia, load_robot
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.estimates import (
    INERTIA_KEYS,
    body_inertias,
    estimates_from_record,
    perturbed_bodies,
    robot_with_bodies,
)
from ffsm_pin.sim.loop import simulate
from ffsm_pin.sim.outputs import write_outputs
from ffsm_pin.sim.setup import prepare

# (urdf, base): the paper's collinear planar robot, the general (off-axis) 5-link one, and a
# 9-joint spatial arm on a satellite
ROBOTS = {
    "planar4": ("ffsm_planar4.urdf", "planar"),
    "planar5": ("ffsm_planar5.urdf", "planar"),
    "spatial9": ("spatial9.urdf", "free-flyer"),
}


def _robot(name):
    urdf, base = ROBOTS[name]
    robot = load_robot(urdf, "ee", base=base)
    options = {"backend": "numpy"} if base == "free-flyer" else {}
    return robot, make_model(robot, **options)


def _configurations(model, n, seed):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q_m = rng.uniform(-np.pi, np.pi, model.n_joints)
        if model.m3 == 1:
            yield rng.uniform(-np.pi, np.pi), q_m
        else:  # an MRP with |s| <= 1
            s = rng.normal(size=3)
            yield s / np.linalg.norm(s) * rng.uniform(0, 1) ** (1 / 3), q_m


@pytest.mark.parametrize("name", list(ROBOTS))
@pytest.mark.parametrize("spread", [0.3, 0.9])
def test_every_draw_is_physical_within_the_spread_and_M_hat_is_positive_definite(name, spread):
    robot, model = _robot(name)
    true = body_inertias(robot)
    planar = robot.base == "planar"
    for seed in range(6):
        bodies = perturbed_bodies(robot, model, spread, seed)
        for k, (b, t) in enumerate(zip(bodies, true, strict=True)):
            what = f"{name} seed {seed} body {k}"
            m, mt = float(b.mass), float(t.mass)
            assert m > 0 and abs(m / mt - 1) <= spread, what
            check_inertia(m, np.array(b.inertia), what)  # PD, triangle inequality
            lam = np.linalg.eigvalsh(np.array(b.inertia))
            lam_t = np.linalg.eigvalsh(np.array(t.inertia))
            assert np.all(lam >= (1 - spread) * lam_t - 1e-12), what
            assert np.all(lam <= (1 + spread) * lam_t + 1e-12), what
            shift = np.array(b.lever) - np.array(t.lever)
            It = np.array(t.inertia)
            r = math.sqrt(It[2, 2] / mt) if planar else math.sqrt(np.trace(It) / (2 * mt))
            assert np.linalg.norm(shift) <= spread * r * (1 + 1e-12), what
            if planar:
                assert shift[2] == 0.0
        drawn = robot_with_bodies(robot, bodies)
        _, theta_d = model.parameters_of(drawn.geometry)  # in the model's own layout
        for q_b, q_m in _configurations(model, 40, seed):
            M = model.mass_matrix(theta_d, q_b, q_m)
            assert np.linalg.eigvalsh((M + M.T) / 2)[0] > 0, f"{name} seed {seed}"


def test_a_collinear_robot_keeps_its_layout():
    """The paper's robot has the collinear layout (15 theta_d): its drawn CoMs stay on their
    body's line, and the parameters drawn fit the layout."""
    robot, model = _robot("planar4")
    assert model.layout.collinear
    for seed in range(5):
        drawn = robot_with_bodies(robot, perturbed_bodies(robot, model, 0.5, seed))
        V, theta_d = model.parameters_of(drawn.geometry)
        assert V.shape == (model.n_joints + 1,) and theta_d.shape == (model.n_d,)


def test_a_seed_reproduces_its_draw_and_another_seed_does_not():
    robot, model = _robot("spatial9")

    def draw(seed):
        return [
            (float(b.mass), *np.array(b.lever), *np.array(b.inertia).ravel())
            for b in perturbed_bodies(robot, model, 0.3, seed)
        ]

    assert draw(4) == draw(4)
    assert draw(4) != draw(5)


def test_the_true_bodies_give_the_true_parameters():
    for name in ROBOTS:
        robot, model = _robot(name)
        V, theta_d = model.parameters_of(robot_with_bodies(robot, body_inertias(robot)).geometry)
        np.testing.assert_array_equal(theta_d, model.theta_d)


def test_a_run_writes_what_was_drawn_and_the_estimates_follow_from_it(tmp_path):
    sc = builtin_scenario("planar5")
    sc = dataclasses.replace(sc, duration=0.01)
    assert sc.controller.estimates.initial == "perturbed"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(sc)
        result = simulate(setup)
    write_outputs(tmp_path, result, setup.scenario)
    record = json.loads((tmp_path / "estimates.json").read_text())
    assert set(record) >= {"bodies", "spread", "seed"}
    assert record["spread"] == sc.controller.estimates.spread
    assert record["seed"] == sc.controller.estimates.seed
    assert [b["name"] for b in record["bodies"]] == list(setup.robot.body_names)
    for body in record["bodies"]:
        assert set(body) == {"name", "mass", "com", "inertia"}
        assert len(body["com"]) == 3 and len(body["inertia"]) == len(INERTIA_KEYS)
    tz, td, tb = estimates_from_record(record, setup.robot, setup.model, setup.q0, setup.v0)
    traj = np.load(tmp_path / "trajectory.npz")
    np.testing.assert_array_equal(traj["theta_z_hat"][0], tz)
    np.testing.assert_array_equal(traj["theta_d_hat"][0], td)
    np.testing.assert_array_equal(traj["theta_b_hat"][0], tb)


def test_true_estimates_record_the_true_bodies_and_paper_estimates_none():
    sc = builtin_scenario("case1")
    est = dataclasses.replace(sc.controller.estimates, initial="true")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(
            dataclasses.replace(sc, controller=dataclasses.replace(sc.controller, estimates=est))
        )
    assert setup.controller.context.estimates is not None  # drawn when first read
    record = setup.drawn_estimates
    assert record["spread"] == 0.0 and record["initial"] == "true"
    assert record["bodies"][0]["mass"] == float(setup.robot.model.inertias[1].mass)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        paper = prepare(sc)
    assert paper.controller.context.estimates is not None
    assert sc.controller.estimates.initial == "paper" and paper.drawn_estimates == {}
