"""A batch's robots (ffsm_pin.sim.robots.SharedRobots): one load per ``[robot]`` section, every
call its own copy, equal to a fresh load bit for bit, and a run prepared with it equal to a run
prepared alone (planar and spatial)."""

from __future__ import annotations

import dataclasses
import pickle
import warnings

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.errors import FfsmError
from ffsm_pin.scenario.file import builtin_scenario
from ffsm_pin.sim.robots import SharedRobots, robot_of
from ffsm_pin.sim.run import prepare, simulate

SCENARIOS = ["case1", "spatial-realistic"]  # planar; spatial with a satellite and locked joints


@pytest.mark.parametrize("name", SCENARIOS)
def test_each_call_is_its_own_exact_copy(name):
    spec = builtin_scenario(name).robot
    shared = SharedRobots()
    a, b, c = (shared(spec) for _ in range(3))
    assert shared.loads == 1
    assert a is not b and a.model is not b.model and a.geometry is not b.geometry
    fresh = robot_of(spec)
    for copy in (a, b, c):
        assert copy.model == fresh.model  # pinocchio compares every field exactly
        assert pickle.dumps(copy) == pickle.dumps(fresh)
        for j in range(fresh.model.njoints):
            assert np.array_equal(copy.model.inertias[j].inertia, fresh.model.inertias[j].inertia)
            assert copy.model.inertias[j].mass == fresh.model.inertias[j].mass
    # a run that changes its robot in place changes no other run's robot
    a.model.inertias[1] = pin.Inertia.Random()
    assert a.model != fresh.model
    assert shared(spec).model == fresh.model and b.model == fresh.model


def test_sections_are_told_apart_and_failures_not_kept():
    planar, spatial = (builtin_scenario(n).robot for n in SCENARIOS)
    missing = dataclasses.replace(planar, urdf="no-such-robot.urdf")
    shared = SharedRobots()
    assert shared(planar).base == "planar" and shared(spatial).base == "free-flyer"
    assert shared(planar).n_joints != shared(spatial).n_joints
    assert shared.loads == 2
    messages = set()
    for _ in range(2):  # each run of a section that does not load raises as a single run does
        with pytest.raises(FfsmError) as err:
            shared(missing)
        messages.add(str(err.value))
    with pytest.raises(FfsmError) as alone:
        robot_of(missing)
    assert messages == {str(alone.value)}
    assert shared.loads == 2


@pytest.mark.parametrize("name", SCENARIOS)
def test_a_run_prepared_with_shared_robots_is_the_run_alone(name):
    sc = builtin_scenario(name)
    sc = dataclasses.replace(sc, duration=25 * sc.dt)
    shared = SharedRobots()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        alone = simulate(prepare(sc)).signals
        shared(sc.robot)  # the section loaded by an earlier case of the batch
        batched = simulate(prepare(sc, robots=shared)).signals
    assert shared.loads == 1
    assert set(alone) == set(batched)
    for key in alone:
        assert np.array_equal(np.asarray(alone[key]), np.asarray(batched[key])), key
