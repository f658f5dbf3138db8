"""After a capture: what a controller is told of the body its hand now holds, and how the
shipped controllers take it into their estimates (issue 40; docs/capture.md, "The controller
after capture").

The run loop calls a controller's optional ``on_capture(event)`` once, at the control period
of the grasp, before that period's ``step``, with a :class:`CaptureEvent`: the time and, as
``[capture] estimates`` allows, the held body's inertial parameters in the end-effector frame
(``"true"``: exactly what the merged robot adds to the end-effector link; ``"perturbed"``: the
same drawn with the ``[controller.estimates]`` rule; ``"unknown"``: nothing).

The barycentric parameters are not linear in the bodies' masses (the mass fractions mu_j of
docs/model.md section 2 divide by the total mass), so the held body moves every V_k and every
entry of theta_d, not only the end-effector link's. :func:`held_body_increment` computes the
exact change the body makes to the parameters of the robot the controller's estimates were
made from (``ctx.robot.estimated``, the nominal robot), with the model's own
``parameters_of``; :func:`join_held_body` adds it to the estimate arrays in place (the same
arrays the compiled kernels advance, so both backends see it from the next period). With exact
estimates and ``"true"`` the controller's model is then the merged robot's to rounding.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pinocchio as pin

from .._docstrings import fill_doc
from ._docs import CONTROL_DOC

if TYPE_CHECKING:  # annotations only
    from ..model import ReducedModel
    from ..robot import Robot
    from .interface import ControllerContext


@dataclass(frozen=True)
class CaptureEvent:
    """What a controller's ``on_capture`` is handed at the grasp.

    Attributes
    ----------
    time : float
        The control period of the grasp [s] (its ``step`` follows, on the state after the
        impact).
    estimates : str
        ``[capture] estimates``: ``"unknown"``, ``"perturbed"`` or ``"true"``.
    held : pin.Inertia or None
        The held body's mass, CoM and inertia in the end-effector frame (``"true"``: the
        merged robot's addition to the end-effector link; ``"perturbed"``: drawn around it);
        None with ``"unknown"``.
    theta_d_true : ndarray or None
        The merged robot's true theta_d (Eq. 12), for the diagnostic e of Eq. (54) alone, as
        the context's ``truth`` before the capture (whatever ``estimates`` says); None: not
        given.
    momenta : tuple of ndarray or None
        (v_0 [m/s], A_0 [kg m^2/s]), the whole system's CoM velocity and angular momentum
        about its CoM just after the impact (the heads of theta_z and theta_b, Eqs. 4, 14):
        with ``"true"`` the true ones, with ``"perturbed"`` those with the drawn body in the
        hand; None with ``"unknown"`` (left to the adaptation).
    """

    time: float
    estimates: str
    held: pin.Inertia | None = None
    theta_d_true: np.ndarray | None = None
    momenta: tuple[np.ndarray, np.ndarray] | None = None


class ParameterIncrement(NamedTuple):
    """The change a held body makes to the barycentric parameters (docs/model.md section 2)."""

    V: np.ndarray  # V_0 .. V_n, the tail of theta_z (Eq. 4)
    theta_d: np.ndarray  # theta_d (Eq. 12), the tail of theta_b (Eq. 14)


@fill_doc(CONTROL_DOC)
def model_holding(robot: Robot, held: pin.Inertia) -> pin.Model:
    """The Pinocchio model of ``robot`` with ``held`` fixed to its end-effector frame (the
    body appended to the frame's joint, as :meth:`~ffsm_pin.robot.payload.Payload.attach`
    does).

    %(params_robot_held)s

    Returns
    -------
    pin.Model
        A new model (the robot's joints; the body in its end-effector joint's inertia).
    """
    model = pin.Model(robot.model)
    frame = model.frames[robot.ee_frame_id]
    model.appendBodyToJoint(int(frame.parentJoint), held, frame.placement)
    return model


@fill_doc(CONTROL_DOC)
def robot_holding(robot: Robot, held: pin.Inertia):
    """The geometry of ``robot`` with ``held`` fixed to its end-effector frame
    (:func:`model_holding`).

    %(params_robot_held)s

    Returns
    -------
    PlanarGeometry or SpatialGeometry
        The geometry of the robot holding it (read by the root's own reader).
    """
    model = model_holding(robot, held)
    return robot.root.geometry(model, robot.ee_frame_id, robot.body_names, robot.name)


def held_body_increment(robot: Robot, model: ReducedModel, held: pin.Inertia) -> ParameterIncrement:
    """The barycentric parameters of ``robot`` holding ``held`` less those of ``robot``.

    Parameters
    ----------
    robot : Robot
        The robot the estimates were made from (``ctx.robot.estimated``).
    model : ReducedModel
        The reduced model (its layout and ``parameters_of``).
    held : pin.Inertia
        The held body in the end-effector frame.

    Returns
    -------
    ParameterIncrement
        The change of V_0..V_n and of theta_d.
    """
    V1, d1 = model.parameters_of(robot_holding(robot, held))
    V0, d0 = model.parameters_of(robot.geometry)
    return ParameterIncrement(np.asarray(V1) - V0, np.asarray(d1) - d0)


def join_held_body(ctx: ControllerContext, state, event: CaptureEvent, events: list) -> bool:
    """Add the held body of ``event`` to the estimates in ``state`` in place: V_k in
    theta_z-hat's tail, theta_d in theta_d-hat and in theta_b-hat's tail; with the event's
    ``momenta`` (``"true"``, ``"perturbed"``), v_0 and A_0 in their heads (otherwise left to
    the adaptation).
    Nothing with ``"unknown"``.

    Parameters
    ----------
    ctx : ControllerContext
        The run's context (its robot's ``estimated`` bodies, its model and sizes).
    state : NamedTuple
        The controller's state with the arrays ``theta_z``, ``theta_d``, ``theta_b``.
    event : CaptureEvent
        The capture.
    events : list of str
        The controller's notes for the summary; one is added when the estimates change.

    Returns
    -------
    bool
        Whether the estimates changed.
    """
    if event.held is None:
        return False
    inc = held_body_increment(ctx.robot.estimated, ctx.model, event.held)
    state.theta_z[ctx.m2 :] += inc.V
    state.theta_d[:] += inc.theta_d
    state.theta_b[ctx.m3 :] += inc.theta_d
    if event.momenta is not None:  # the whole system's momenta after the impact
        state.theta_z[: ctx.m2] = event.momenta[0]
        state.theta_b[: ctx.m3] = event.momenta[1]
    events.append(
        f"t = {event.time:.4f} s: the held body ({event.estimates}, {event.held.mass:.4g} kg) "
        "joined the parameter estimates"
    )
    return True


__all__ = [
    "CaptureEvent", "ParameterIncrement", "held_body_increment", "join_held_body", "model_holding",
    "robot_holding",
]  # fmt: skip
