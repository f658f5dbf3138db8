"""Shared fixtures of the ffsm-pin test suite.

Fixtures
--------
``paper_robot`` (session)
    The paper's 4-DOF planar robot, ``load_robot("ffsm_planar4.urdf")`` (Lu & Jia 2019, Table 1).
``data_dir`` (session)
    ``pathlib.Path`` of ``tests/data`` (test robots, their tables, bad URDFs).
``rng`` (function)
    A fresh, seeded ``numpy.random.Generator`` (the same stream in every test).
``random_chain`` (session)
    ``random_chain(n_links, *, offaxis=False, seed=0) -> PlanarChain``: a random, physically
    sensible planar chain (base 40-60 kg, links 3-7 kg and 1.0-1.4 m), deterministic in
    ``(n_links, offaxis, seed)``. Collinear chains (``offaxis=False``) have every CoM, child
    joint and the end effector on the x axis of their body; off-axis chains have random 2-D
    CoMs (0.05-0.2 m off the joint line) and tips. Joint axes are +z or -z at random in both.
``make_chain`` (session)
    ``make_chain(n_links, *, offaxis=False, seed=0) -> FreeFloatingRobot``: writes
    ``random_chain(n_links, offaxis=offaxis, seed=seed)`` as a URDF into a temporary folder
    and loads it with :func:`ffsm_pin.load_robot`. Results are cached per argument tuple, so the
    fixture is cheap inside hypothesis tests (it is session-scoped for the same reason).
``random_state`` (session)
    ``random_state(robot, rng, *, speed=1.0) -> (q, v)``: a random plant state in Pinocchio
    conventions: base pose in a few metres, any attitude, joint angles in (-pi, pi), base
    linear velocity ~ 0.3 * speed m/s, rates ~ speed rad/s.
``spatial_chain`` (session)
    ``spatial_chain(n_links, seed=0) -> Robot``: a random spatial chain written by
    ``ffsm_pin.robot.writer`` into a temporary folder and loaded (free-flyer root): random unit
    joint axes, random joint-origin rotations and offsets, CoMs off the joint axes, full
    inertia tensors (random principal axes, principal moments satisfying the triangle
    inequality), an end-effector frame with a random pose. Deterministic, cached.
``spatial_state`` (session)
    ``spatial_state(robot, rng, speed=1.0) -> (q, v)``: a random plant state of a spatial robot
    (base anywhere, any attitude as an MRP on its short branch).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.attitude import mrp
from ffsm_pin.robot import FreeFloatingRobot, load_robot, load_spatial_robot
from ffsm_pin.robot.writer import (
    PlanarBody,
    PlanarChain,
    PlanarLink,
    SpatialBody,
    SpatialChain,
    SpatialLink,
    write_urdf,
)

DATA_DIR = Path(__file__).resolve().parent / "data"
SEED = 20190611


@pytest.fixture(scope="session")
def paper_robot() -> FreeFloatingRobot:
    """The paper's robot (shipped ``ffsm_planar4.urdf``)."""
    return load_robot("ffsm_planar4.urdf")


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """Folder ``tests/data``."""
    return DATA_DIR


@pytest.fixture
def rng() -> np.random.Generator:
    """Seeded numpy Generator, fresh for every test."""
    return np.random.default_rng(SEED)


def _random_chain(n_links: int, *, offaxis: bool = False, seed: int = 0) -> PlanarChain:
    g = np.random.default_rng([SEED, n_links, int(offaxis), seed])

    def off(lo, hi):  # signed offset with |x| in [lo, hi]
        return float(g.choice([-1.0, 1.0]) * g.uniform(lo, hi))

    base_mass = g.uniform(40.0, 60.0)
    side = g.uniform(1.2, 1.8)
    base = PlanarBody(
        mass=base_mass,
        inertia=base_mass * side**2 / 6.0 * g.uniform(0.8, 1.2),
        com=(g.uniform(-0.1, 0.1), g.uniform(-0.1, 0.1) if offaxis else 0.0),
    )
    mount = (g.uniform(0.5, 0.9), g.uniform(-0.2, 0.2) if offaxis else 0.0)
    links = []
    for _ in range(n_links):
        mass = g.uniform(3.0, 7.0)
        length = g.uniform(1.0, 1.4)
        links.append(
            PlanarLink(
                mass=mass,
                inertia=mass * length**2 / 12.0 * g.uniform(0.8, 1.2),
                com=(g.uniform(0.3, 0.7) * length, off(0.05, 0.2) if offaxis else 0.0),
                tip=(length, g.uniform(-0.2, 0.2) if offaxis else 0.0),
                axis=int(g.choice([-1, 1])),
            )
        )
    kind = "offaxis" if offaxis else "collinear"
    return PlanarChain(
        name=f"random_{kind}{n_links}_s{seed}",
        base=base,
        mount=mount,
        links=tuple(links),
        base_size=(side, side),
    )


@pytest.fixture(scope="session")
def random_chain():
    """Factory ``random_chain(n_links, *, offaxis=False, seed=0) -> PlanarChain``."""
    return _random_chain


@pytest.fixture(scope="session")
def make_chain(tmp_path_factory):
    """Factory ``make_chain(n_links, *, offaxis=False, seed=0) -> FreeFloatingRobot``."""
    folder = tmp_path_factory.mktemp("chains")
    cache: dict[tuple[int, bool, int], FreeFloatingRobot] = {}

    def make(n_links: int, *, offaxis: bool = False, seed: int = 0) -> FreeFloatingRobot:
        key = (int(n_links), bool(offaxis), int(seed))
        if key not in cache:
            chain = _random_chain(*key[:1], offaxis=key[1], seed=key[2])
            cache[key] = load_robot(write_urdf(chain, folder / f"{chain.name}.urdf"))
        return cache[key]

    return make


def _random_state(robot: FreeFloatingRobot, rng: np.random.Generator, *, speed: float = 1.0):
    n = robot.n_joints
    q = robot.configuration(
        (rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-np.pi, np.pi)),
        rng.uniform(-np.pi, np.pi, n),
    )
    v = np.concatenate((0.3 * speed * rng.normal(size=2), speed * rng.normal(size=n + 1)))
    return q, v


@pytest.fixture(scope="session")
def random_state():
    """Factory ``random_state(robot, rng, *, speed=1.0) -> (q, v)`` (Pinocchio conventions)."""
    return _random_state


@pytest.fixture(scope="session")
def reduced_model_of():
    """geometry -> reduced model: "planar" the paper's 4-link robot, "spatial" the Panda on the
    built-in 'spatial' case's satellite (cached per session)."""
    from ffsm_pin.model import make_model
    from ffsm_pin.robot import load_robot
    from ffsm_pin.scenario.file import builtin_scenario

    cache = {}

    def get(geometry: str):
        if geometry not in cache:
            if geometry == "planar":
                robot = load_robot("ffsm_planar4.urdf")
            else:
                r = builtin_scenario("spatial").robot
                locked = dict(r.locked_joints)
                robot = load_robot(r.urdf, r.end_effector, base=r.base, locked_joints=locked,
                                   satellite=r.satellite)  # fmt: skip
            cache[geometry] = make_model(robot)
        return cache[geometry]

    return get


# ---------------------------------------------------------------------- spatial chains
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


def _random_spatial_state(robot, rng, speed=1.0):
    base = np.concatenate((rng.uniform(-2, 2, 3), mrp.shadow(rng.uniform(-1, 1, 3))))
    q = robot.configuration(base, rng.uniform(-np.pi, np.pi, robot.n_joints))
    v = rng.normal(scale=speed, size=robot.model.nv)
    v[:3] *= 0.3
    return q, v


@pytest.fixture(scope="session")
def spatial_state():
    return _random_spatial_state
