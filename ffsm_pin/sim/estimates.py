"""Initial parameter estimates of a scenario (``[controller.estimates]``): Table 2, the truth,
physical perturbations of the robot's bodies, or explicit vectors.

``initial = "perturbed"`` perturbs every body's mass, centre of mass and rotational inertia so
that every draw is a rigid body (:func:`perturb_body`), puts the drawn bodies into a copy of
the robot's Pinocchio model and reads the barycentric parameters from that copy with the
model's own code path (:meth:`~ffsm_pin.model.planar.BarycentricModel.parameters_of`). The
estimate of M(q, theta_d) is then the reduced inertia of a physical robot: positive definite
at every configuration by construction, no draw is ever refused or redrawn. The momenta in
theta_z and theta_b (v_0 and A_0) are those of the drawn robot at the measured initial state.

What was drawn is a record, written as ``estimates.json`` in the run's folder
(:func:`bodies_record`); :func:`estimates_from_record` computes the same estimates from it.
docs/model.md section 6 says what the spread means.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import pinocchio as pin

from .. import paper
from ..errors import ParameterError, ScenarioError
from ..model import ReducedModel, State
from ..robot import Robot
from ..scenario.spec import Scenario

__all__ = [
    "DrawnEstimates",
    "bodies_record",
    "estimates_from_record",
    "initial_estimates",
    "perturb_body",
    "perturbed_bodies",
    "robot_with_bodies",
]

#: Order of the six inertia entries in a record (as a URDF's <inertia>).
INERTIA_KEYS = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
_INERTIA_ENTRIES = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


class DrawnEstimates(NamedTuple):
    """(theta_z, theta_d, theta_b)-hat at t = 0, and what they were derived from (the record
    of :func:`bodies_record`; None for Table 2 and explicit vectors)."""

    theta_z: np.ndarray
    theta_d: np.ndarray
    theta_b: np.ndarray
    record: dict[str, Any] | None


def initial_estimates(
    scenario: Scenario,
    model: ReducedModel,
    truth,
    robot: Robot,
    q0: np.ndarray,
    v0: np.ndarray,
) -> DrawnEstimates:
    """(theta_z, theta_d, theta_b)-hat at t = 0 per ``[controller.estimates]`` (docs/cli.md).

    ``truth``: the plant's true parameters; ``robot``: the plant's robot; (``q0``, ``v0``): the
    initial state. Estimates are made from the bodies of ``robot.estimated`` (the plant's, or
    without the payload the controller does not know, :attr:`ffsm_pin.robot.Robot.estimated`).
    The known-model scheme takes ``truth``; "true" the parameters of those bodies (``truth``
    itself when they are the plant's); "paper" Table 2 (the paper's robot sizes only);
    "perturbed" those bodies drawn by :func:`perturbed_bodies`; "explicit" the given vectors.
    A ScenarioError names what does not fit.

    Parameters
    ----------
    scenario : Scenario
        Its ``[controller.estimates]`` and scheme are read.
    model : ReducedModel
        The parameters' layout.
    truth : tuple of ndarray
        The plant's true parameters.
    robot : Robot
        The plant's robot.
    q0, v0 : ndarray
        The initial state (Pinocchio convention).

    Returns
    -------
    DrawnEstimates
        The estimates and their record.
    """
    est = scenario.controller.estimates
    tz, td, tb = truth
    known = robot.estimated
    if scenario.controller.scheme == "known-model" or est.initial == "true":
        plant = scenario.controller.scheme == "known-model" or known is robot
        record = bodies_record(robot if plant else known, "true", 0.0, None)
        if plant:
            return DrawnEstimates(tz.copy(), td.copy(), tb.copy(), record)
        return DrawnEstimates(*barycentric_estimates(known, model, q0, v0), record)
    if est.initial == "paper":
        sizes = (model.n_z, model.n_d, model.n_b)
        paper_sizes = (len(paper.THETA_Z_HAT0), len(paper.THETA_D_HAT0), len(paper.THETA_B_HAT0))
        if sizes != paper_sizes:
            raise ScenarioError(
                f"controller.estimates.initial = 'paper' (Table 2) has sizes {paper_sizes} for "
                f"(theta_z, theta_d, theta_b), this robot needs {sizes}; use 'perturbed', "
                "'true' or 'explicit'"
            )
        return DrawnEstimates(
            np.array(paper.THETA_Z_HAT0, float),
            np.array(paper.THETA_D_HAT0, float),
            np.array(paper.THETA_B_HAT0, float),
            None,
        )
    if est.initial == "perturbed":
        drawn = robot_with_bodies(known, perturbed_bodies(known, model, est.spread, est.seed))
        record = bodies_record(drawn, "perturbed", est.spread, est.seed)
        return DrawnEstimates(*barycentric_estimates(drawn, model, q0, v0), record)
    out = []
    for name, given, size in (
        ("theta_z", est.theta_z, model.n_z),
        ("theta_d", est.theta_d, model.n_d),
        ("theta_b", est.theta_b, model.n_b),
    ):
        vec = np.asarray(given, dtype=float)
        if vec.shape != (size,):
            raise ScenarioError(
                f"controller.estimates.{name} has {vec.size} entries, this robot needs {size} "
                f"(layout: {_layout_name(model)})"
            )
        out.append(vec)
    return DrawnEstimates(out[0], out[1], out[2], None)


def _layout_name(model) -> str:
    if model.m3 == 3:
        return "spatial"
    return "collinear" if model.layout.collinear else "general 2-D"


# ------------------------------------------------------------------------------ bodies
def body_inertias(robot: Robot) -> list[pin.Inertia]:
    """The Pinocchio inertia of each body 0..n (about the body's joint frame)."""
    return [pin.Inertia(robot.model.inertias[j]) for j in range(1, robot.model.njoints)]


def perturb_body(
    body: pin.Inertia,
    spread: float,
    rng: np.random.Generator,
    *,
    planar: bool = False,
    line: Sequence[float] | None = None,
) -> pin.Inertia:
    """A rigid body drawn around ``body`` with relative ``spread`` s (docs/model.md section 6).

    * mass: m (1 + U(-s, s)), positive since s < 1;
    * centre of mass: moved by at most s r, r the RMS distance of the body's mass from its CoM
      (sqrt(tr(I_c) / (2 m)); planar sqrt(I_zz / m)): uniform in the ball of radius s r
      (planar: the disk in the x-y plane; along ``line``, the body's line in a collinear
      layout, when given);
    * rotational inertia about the CoM: the second moments of the mass along the principal
      axes (sigma_i = tr(I_c) / 2 - lambda_i >= 0) each times 1 + U(-s, s), and the principal
      axes turned by an angle U(-s, s) [rad] about a random axis (planar: about z). Every
      principal moment lambda_i = sigma_j + sigma_k stays within a factor 1 +- s of the true
      one, and the triangle inequality holds: a rigid body by construction.

    A planar body whose 3-D inertia is not physical (a URDF giving only I_zz) has only its
    I_zz scaled by 1 + U(-s, s). Every body takes the same 12 numbers from ``rng``.

    Parameters
    ----------
    body : pin.Inertia
        The true body.
    spread : float
        Relative spread s, 0 <= s < 1.
    rng : numpy.random.Generator
        The generator (12 numbers are drawn).
    planar : bool
        Move the CoM in the x-y plane and turn about z.
    line : sequence of float or None
        The body's line, along which the CoM moves.

    Returns
    -------
    pin.Inertia
        The drawn body.
    """
    s = float(spread)
    m, c, inertia = float(body.mass), np.array(body.lever), np.array(body.inertia)
    f_mass = 1.0 + rng.uniform(-s, s)
    g_com = rng.normal(size=3)
    u_com = rng.uniform(0.0, 1.0)
    f_moments = 1.0 + rng.uniform(-s, s, size=3)
    g_axis = rng.normal(size=3)
    angle = rng.uniform(-s, s)
    u_line = rng.uniform(-1.0, 1.0)
    # centre of mass
    if planar:
        r = math.sqrt(max(inertia[2, 2], 0.0) / m)
        if line is not None:
            shift = np.array([line[0], line[1], 0.0]) * (s * r * u_line)
        else:
            shift = np.array([g_com[0], g_com[1], 0.0])
            shift *= s * r * math.sqrt(u_com) / max(float(np.linalg.norm(shift)), 1e-300)
    else:
        r = math.sqrt(max(np.trace(inertia), 0.0) / (2.0 * m))
        shift = g_com * (s * r * u_com ** (1.0 / 3.0) / max(float(np.linalg.norm(g_com)), 1e-300))
    # rotational inertia about the CoM
    lam, axes = np.linalg.eigh((inertia + inertia.T) / 2.0)
    sigma = lam.sum() / 2.0 - lam
    if planar and sigma.min() < -1e-9 * max(lam.sum(), 1e-300):  # only I_zz is a planar body's
        new = inertia.copy()
        new[2, 2] *= f_moments[2]
    else:
        sigma = np.maximum(sigma, 0.0) * f_moments
        lam_new = sigma.sum() - sigma
        axis = np.array([0.0, 0.0, 1.0]) if planar else g_axis / np.linalg.norm(g_axis)
        turn = pin.AngleAxis(angle, axis).matrix()
        rot = turn @ axes
        new = rot @ np.diag(lam_new) @ rot.T
    new = (new + new.T) / 2.0
    return pin.Inertia(m * f_mass, c + shift, new)


def perturbed_bodies(
    robot: Robot, model: ReducedModel, spread: float, seed: int
) -> list[pin.Inertia]:
    """Every body of ``robot`` drawn by :func:`perturb_body` from one generator seeded with
    ``seed``, bodies in order 0..n. A planar robot whose parameters have the collinear layout
    keeps each CoM on its body's line (the layout has no parameter for an offset across it).

    Parameters
    ----------
    robot : Robot
        The robot.
    model : ReducedModel
        Its reduced model (its layout).
    spread : float
        Relative spread.
    seed : int
        Seed of the generator.

    Returns
    -------
    list of pin.Inertia
        Bodies 0..n.
    """
    rng = np.random.default_rng(seed)
    planar = robot.base == "planar"
    layout = getattr(model, "layout", None)
    collinear = planar and bool(getattr(layout, "collinear", False))
    angles = getattr(model, "direction_angles", None)
    out = []
    for k, body in enumerate(body_inertias(robot)):
        line = None
        if collinear and angles is not None:
            line = (math.cos(angles[k]), math.sin(angles[k]))
        out.append(perturb_body(body, spread, rng, planar=planar, line=line))
    return out


def robot_with_bodies(robot: Robot, bodies: Sequence[pin.Inertia]) -> Robot:
    """``robot`` with its bodies' inertias replaced (a copy of its Pinocchio model; the
    geometry read from the copy by the root's own reader, which checks every body).

    Parameters
    ----------
    robot : Robot
        The robot.
    bodies : sequence of pin.Inertia
        One per body, the base first (the joints of its Pinocchio model).

    Returns
    -------
    Robot
        The copy.
    """
    model = pin.Model(robot.model)
    if len(bodies) != model.njoints - 1:
        raise ParameterError(f"expected {model.njoints - 1} bodies, got {len(bodies)}")
    for j, body in enumerate(bodies, start=1):
        model.inertias[j] = body
    geometry = robot.root.geometry(model, robot.ee_frame_id, robot.body_names, robot.name)
    return dataclasses.replace(robot, model=model, geometry=geometry, payload=None, unloaded=None)


def barycentric_estimates(
    robot: Robot, model: ReducedModel, q0: np.ndarray, v0: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta_z, theta_d, theta_b) of ``robot``'s bodies in ``model``'s layout, with v_0 and
    A_0 the momenta of ``robot`` at the state (``q0``, ``v0``).

    Parameters
    ----------
    robot : Robot
        The robot whose bodies are used.
    model : ReducedModel
        The parameters' layout.
    q0, v0 : ndarray
        The initial state (Pinocchio convention).

    Returns
    -------
    theta_z, theta_d, theta_b : ndarray
        The parameter vectors.
    """
    V, theta_d = model.parameters_of(robot.geometry)
    st = State(robot).update(q0, v0)
    v_0 = np.atleast_1d(np.asarray(st.com_velocity, dtype=float))
    A_0 = np.atleast_1d(np.asarray(st.angular_momentum, dtype=float))
    return np.concatenate((v_0, V)), theta_d.copy(), np.concatenate((A_0, theta_d))


# ------------------------------------------------------------------------------ the record
def bodies_record(robot: Robot, initial: str, spread: float, seed: int | None) -> dict[str, Any]:
    """What ``estimates.json`` holds: ``{"initial", "bodies": [{"name", "mass", "com": [3],
    "inertia": [ixx, iyy, izz, ixy, ixz, iyz]}], "spread", "seed"}``; com in the body's frame
    [m], inertia about the CoM in the body's frame [kg m^2] (URDF conventions).

    Parameters
    ----------
    robot : Robot
        The robot whose bodies are recorded.
    initial : str
        The ``[controller.estimates] initial`` they come from.
    spread : float
        The relative spread they were drawn with.
    seed : int or None
        The seed they were drawn with.

    Returns
    -------
    dict
        The record.
    """
    bodies = []
    for name, body in zip(robot.body_names, body_inertias(robot), strict=True):
        i = np.array(body.inertia)
        bodies.append(
            {
                "name": name,
                "mass": float(body.mass),
                "com": [float(x) for x in body.lever],
                "inertia": [float(i[a, b]) for a, b in _INERTIA_ENTRIES],
            }
        )
    return {"initial": initial, "bodies": bodies, "spread": float(spread), "seed": seed}


def record_bodies(record: Mapping[str, Any]) -> list[pin.Inertia]:
    """The Pinocchio inertias of a record's bodies (:func:`bodies_record`)."""
    out = []
    for body in record["bodies"]:
        xx, yy, zz, xy, xz, yz = (float(x) for x in body["inertia"])
        inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        out.append(pin.Inertia(float(body["mass"]), np.array(body["com"], dtype=float), inertia))
    return out


def estimates_from_record(
    record: Mapping[str, Any],
    robot: Robot,
    model: ReducedModel,
    q0: np.ndarray,
    v0: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The initial estimates a run derived from its ``estimates.json`` (``record``), for its
    robot, model and initial state: the same numbers.

    Parameters
    ----------
    record : mapping
        The contents of ``estimates.json``.
    robot : Robot
        The run's robot.
    model : ReducedModel
        Its reduced model.
    q0, v0 : ndarray
        The initial state (Pinocchio convention).

    Returns
    -------
    theta_z, theta_d, theta_b : ndarray
        The initial estimates.
    """
    return barycentric_estimates(robot_with_bodies(robot, record_bodies(record)), model, q0, v0)
