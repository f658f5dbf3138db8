"""``[robot.satellite.wheels]`` (issue 40): reaction wheels on the bus of a free-flyer robot.

:class:`WheelsModel` is the table's schema (its keys, types and the one-line refusals); the
scenario holds the :class:`ffsm_pin.robot.wheels.Wheels` it builds (``RobotSpec.wheels``), and
a run with wheels steps them with the robot (:mod:`ffsm_pin.sim.wheels_run`; docs/capture.md,
"Wheels in the loop"). A ``[robot.satellite]`` table that holds only the wheels adds no
satellite body: the wheels sit on the URDF's own root link (the bus).
"""

# mypy: disable-error-code="valid-type"
# (the field types are built at run time, or_list; pydantic checks them)

from __future__ import annotations

import re
from typing import Annotated, Literal

from pydantic import Field, model_validator

from .._schema import Num, Table, fail
from ..errors import ParameterError
from ..robot.wheels import WHEEL_CONTROLS, Wheels
from .values import or_list

#: A wheel's limit [N m or N m s]: > 0, infinite for none.
_Limit = Annotated[float, Field(gt=0)]
_NOT_GIVEN = float("inf")


class WheelsModel(Table):
    """``[robot.satellite.wheels]``: axes (``"xyz"`` or 3 rows of N numbers, the columns the
    wheels' spin axes in the bus frame), spin inertias [kg m^2], torque [N m] and momentum
    [N m s] limits (a number for every wheel, or one per wheel), and the wheels' command when
    the controller gives none (``control``)."""

    axes: str | list[list[Num]] = "xyz"  # "xyz" or 3 rows (checked below)
    inertia: or_list(Num)  # [kg m^2], > 0 (checked below, with the wheels' own message)
    max_torque: or_list(_Limit) = _NOT_GIVEN  # [N m]
    max_momentum: or_list(_Limit) = _NOT_GIVEN  # [N m s]
    control: Literal[WHEEL_CONTROLS] = WHEEL_CONTROLS[0]
    kp: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 0.0  # [N m / rad], attitude-pd
    kd: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 0.0  # [N m s / rad]

    @model_validator(mode="after")
    def physical(self):
        """Refuse ragged axes, a zero axis, an inertia <= 0 and a count that is not N, with
        :class:`~ffsm_pin.robot.wheels.Wheels`' message under the key's path."""
        if isinstance(self.axes, list) and len({len(row) for row in self.axes}) > 1:
            fail(("axes",), ": expected 3 rows of N numbers (one column per wheel), got rows "
                 f"of {[len(row) for row in self.axes]} numbers")  # fmt: skip
        try:
            self.wheels()
        except ParameterError as exc:
            found = re.match(r"wheels\.(\w+): (.*)", str(exc))
            key, why = (found.group(1), found.group(2)) if found else ("axes", str(exc))
            fail((key,), f": {why}")
        return self

    def wheels(self) -> Wheels:
        """The wheels of the table.

        Returns
        -------
        Wheels
            Axes, inertias, limits and their command.
        """
        return Wheels(
            self.axes,  # type: ignore[arg-type]  # a str or rows: Wheels reads both
            self.inertia, self.max_torque, self.max_momentum,  # type: ignore[arg-type]
            control=self.control, kp=self.kp, kd=self.kd,
        )  # fmt: skip
