"""Fixtures of the spatial model tests.

``spatial_chain(n_links, seed) -> SpatialRobot`` (session): a random spatial chain written by
``ffsm_pin.robot.writer`` into a temporary folder and loaded: random unit joint axes, random
joint-origin rotations and offsets, CoMs off the joint axes, full inertia tensors (random
principal axes, principal moments satisfying the triangle inequality), an end-effector frame
with a random pose. Deterministic in (n_links, seed), cached.
``spatial_state(robot, rng) -> (q, v)``: a random plant state (base anywhere, any attitude).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude import mrp
from ffsm_pin.robot import load_spatial_robot
from ffsm_pin.robot.writer import SpatialBody, SpatialChain, SpatialLink, write_urdf


def random_inertia(rng, scale):
    """(ixx, iyy, izz, ixy, ixz, iyz) of a physical body: principal moments in [0.5, 1] scale
    (triangle inequality holds), random principal axes."""
    lam = rng.uniform(0.5, 1.0, 3) * scale
    Q = pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))
    inertia = Q @ np.diag(lam) @ Q.T
    return tuple(float(inertia[i, j]) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)))


def random_spatial_chain(n_links: int, seed: int) -> SpatialChain:
    rng = np.random.default_rng(1000 * n_links + seed)
    base = SpatialBody(
        mass=rng.uniform(100, 200), inertia=random_inertia(rng, 30.0), com=rng.uniform(-0.1, 0.1, 3)
    )
    links = []
    for _ in range(n_links):
        axis = rng.normal(size=3)
        links.append(
            SpatialLink(
                mass=rng.uniform(2, 8),
                inertia=random_inertia(rng, 0.3),
                com=rng.uniform(-0.2, 0.4, 3),
                origin_xyz=rng.uniform(-0.5, 0.5, 3),
                origin_rpy=rng.uniform(-np.pi, np.pi, 3),
                axis=axis / np.linalg.norm(axis),
            )
        )
    return SpatialChain(
        name=f"random{n_links}_{seed}",
        base=base,
        links=links,
        ee_xyz=rng.uniform(-0.2, 0.3, 3),
        ee_rpy=rng.uniform(-1, 1, 3),
    )


@pytest.fixture(scope="session")
def spatial_chain(tmp_path_factory):
    folder = tmp_path_factory.mktemp("spatial_chains")
    cache: dict = {}

    def make(n_links: int, seed: int = 0):
        key = (n_links, seed)
        if key not in cache:
            path = write_urdf(
                random_spatial_chain(n_links, seed), folder / f"c{n_links}_{seed}.urdf"
            )
            cache[key] = load_spatial_robot(path, "ee")
        return cache[key]

    return make


def _random_state(robot, rng, speed=1.0):
    base = np.concatenate((rng.uniform(-2, 2, 3), mrp.shadow(rng.uniform(-1, 1, 3))))
    q = robot.configuration(base, rng.uniform(-np.pi, np.pi, robot.n_joints))
    v = rng.normal(scale=speed, size=robot.model.nv)
    v[:3] *= 0.3
    return q, v


@pytest.fixture(scope="session")
def spatial_state():
    return _random_state
