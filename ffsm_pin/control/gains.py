"""Controller gains and the singularity policy, as frozen validated dataclasses."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from ..errors import ParameterError


def _positive(obj, *names: str) -> None:
    for name in names:
        value = getattr(obj, name)
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ParameterError(
                f"{type(obj).__name__}.{name} must be a positive finite number, got {value!r}"
            )


@dataclass(frozen=True)
class Gains:
    """Gains of the coordinated controller (the paper's Section 4 values by default).

    k_b: attitude gain of Eq. (25) [1/s]; k_z: end-effector gain of Eq. (36) [1/s];
    k_de: filter rate of Eqs. (46), (50) [1/s]; k_d: sliding rate of Eq. (64) [1/s];
    gamma_1, gamma_2, gamma_3: adaptation gains of Eqs. (28), (42), (51).
    """

    k_b: float = 0.04
    k_z: float = 0.04
    k_de: float = 0.3
    k_d: float = 0.8
    gamma_1: float = 10.0
    gamma_2: float = 10.0
    gamma_3: float = 10.0

    def __post_init__(self) -> None:
        _positive(self, *(f.name for f in fields(self)))


@dataclass(frozen=True)
class SingularityPolicy:
    """What the kinematic law does near a singular ``J_m-hat U-hat`` (Eq. 36).

    threshold:
        sigma_min below which damped least squares starts [same units as J, m]. The damping
        is ``lambda^2 = threshold^2 - sigma_min^2``, so the damped inverse never amplifies by
        more than ``1 / threshold`` and is continuous where damping starts.
    max_damped_time:
        The run stops (cause ``"singular"``) when sigma_min stays below ``threshold`` for
        longer than this [s]. Damping keeps the law defined, so brief passages (the paper's
        case 2 passes a fold of the *estimated* arm for about 6 s before theta_z-hat adapts)
        are ridden out and reported; an arm held at a fold (e.g. a reference out of reach)
        is stopped.
    """

    threshold: float = 0.05
    max_damped_time: float = 10.0

    def __post_init__(self) -> None:
        _positive(self, "threshold", "max_damped_time")
