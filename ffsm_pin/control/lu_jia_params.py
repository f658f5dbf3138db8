"""The lu-jia controller's own parameters, and the keys of a scenario file they are read from.

The paper's controller (``type = "lu-jia"``, :class:`~.lu_jia.LuJiaController`) declares these
(``LuJiaController.params_model``): its ``scheme``, its gains, its null-space term and how
long it may stay damped near a singularity. A scenario file writes them where the paper puts
them (docs/cli.md), at the ``[controller]`` level::

    [controller]
    scheme = "ppc"                  # k_b, k_z, k_de, k_d, gamma_1, gamma_2, gamma_3 beside it
    saturation = "ignore"           # or "auxiliary" (k_chi, k_v beside it; docs/saturation.md)
    adaptation = "gradient"         # or "physical" (and physical_margin): theta_d-hat's law
    [controller.null_space]         # objective, gain, center
    [controller.singularity]        # max_damped_time (threshold is the run's, below)

and ``[controller.params] backend`` chooses its backend (:func:`~.lu_jia.backend_from`).
:class:`LuJiaKeys` is their schema: the scenario file's ``[controller]`` table is this model
with the run's own keys added (:class:`ffsm_pin.scenario.sections.ControllerModel`), so its
errors are one line naming the key, with the valid choices.

What the scenario holds for *every* controller is not here: the funnels of
``[controller.funnel]`` and the singularity threshold of ``[controller.singularity]`` are the
run's performance specification (:class:`ffsm_pin.scenario.spec.Performance`), by which every
run is judged. The paper's controller takes its transformation's funnels (Eq. 21) and its
damping threshold from there (:meth:`LuJiaParams.policy`), and derives an omitted ``k_b`` or
``k_z`` from those funnels (:meth:`LuJiaParams.from_keys`).

Other controllers may read these keys where they use them (the adaptive-ct baseline takes
gamma_1, gamma_2, gamma_3 as the defaults of its adaptation gains, and its theta_d law
``adaptation`` with ``physical_margin``); a scenario of any type
may give them, and they are validated the same way whatever the type.
"""

# mypy: disable-error-code="valid-type"
# (Literal over tuples built at run time; pydantic checks them)

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Annotated, Literal

from pydantic import Field, model_validator

from .._schema import Num, Pos, Table, Vec, default, fail
from .controller import SCHEMES
from .gains import ATTITUDE_RATE_SQUARED, Gains, SingularityPolicy, derived_gain
from .null_space import OBJECTIVES, NullSpace
from .physical import ADAPTATIONS
from .saturation import SATURATION_MODES, Saturation

#: The gains' keys at the ``[controller]`` level of a scenario file (the fields of Gains).
GAIN_KEYS = ("k_b", "k_z", "k_de", "k_d", "gamma_1", "gamma_2", "gamma_3")


@dataclass(frozen=True)
class LuJiaParams:
    """The lu-jia controller's own parameters (module docstring).

    Attributes
    ----------
    scheme : str
        The paper's variant, one of :data:`~.controller.SCHEMES`: ``"ppc"`` (case 1),
        ``"no-ppc"`` (case 2), ``"no-attitude"`` (case 3, Eq. 81) or ``"known-model"``.
    gains : Gains
        k_b, k_z, k_de, k_d, gamma_1, gamma_2, gamma_3 (:class:`~.gains.Gains`).
    null_space : NullSpace
        Beyond the paper: the term added to Eq. (36) (:class:`~.null_space.NullSpace`).
    max_damped_time : float
        The run stops (cause ``"singular"``) when the inverted task Jacobian stays damped for
        longer than this [s] (:class:`~.gains.SingularityPolicy`).
    saturation : Saturation
        Beyond the paper: ``saturation`` and the auxiliary system's rates ``k_chi``, ``k_v``
        (:class:`~.saturation.Saturation`).
    adaptation : str
        The law of theta_d-hat, one of :data:`~.physical.ADAPTATIONS`: ``"gradient"`` (the
        paper's Eq. 51) or ``"physical"`` (Eq. 51 projected onto the physical set,
        :mod:`.physical`, docs/robust.md).
    physical_margin : float or None
        eps of the physical set ``P(theta_d) >= eps I``; None: derived from the initial
        estimate (docs/gains.md).
    """

    scheme: str = "ppc"
    gains: Gains = field(default_factory=Gains)
    null_space: NullSpace = field(default_factory=NullSpace)
    max_damped_time: float = SingularityPolicy.max_damped_time
    saturation: Saturation = field(default_factory=Saturation)
    adaptation: str = "gradient"
    physical_margin: float | None = None

    def policy(self, threshold: float) -> SingularityPolicy:
        """The singularity policy of the law: damped below the run's ``threshold`` [m] (its
        performance specification's), stopped after :attr:`max_damped_time`."""
        return SingularityPolicy(threshold=threshold, max_damped_time=self.max_damped_time)

    @classmethod
    def from_keys(cls, keys: LuJiaKeys, funnel_b, funnel_z, dt: float, n_b: int) -> LuJiaParams:
        """The parameters of validated keys; an omitted ``k_b`` or ``k_z`` is derived from
        the run's funnels ``funnel_b``, ``funnel_z`` (FunnelParams) and control period ``dt``
        [s] (:func:`~.gains.derived_gain`, docs/gains.md; ``n_b`` attitude components).

        Parameters
        ----------
        keys : LuJiaKeys
            The validated keys.
        funnel_b, funnel_z : FunnelParams
            The run's attitude and end-effector funnels.
        dt : float
            The control period [s].
        n_b : int
            Attitude components.

        Returns
        -------
        LuJiaParams
            The parameters.
        """
        gains = {k: getattr(keys, k) for k in GAIN_KEYS}
        if gains["k_b"] is None:  # omitted: derived from the funnel and dt (docs/gains.md)
            gains["k_b"] = derived_gain(funnel_b, dt, ATTITUDE_RATE_SQUARED[n_b])
        if gains["k_z"] is None:
            gains["k_z"] = derived_gain(funnel_z, dt)
        ns = keys.null_space
        center = None if ns.center is None else tuple(float(x) for x in ns.center)
        return cls(
            scheme=keys.scheme,
            gains=Gains(**gains),
            null_space=NullSpace(objective=ns.objective, gain=ns.gain, center=center),
            max_damped_time=keys.singularity.max_damped_time,
            saturation=Saturation(keys.saturation, keys.k_chi, keys.k_v),
            adaptation=keys.adaptation,
            physical_margin=keys.physical_margin,
        )


# ------------------------------------------------------------------------------ the schema
_G = Gains()
_NS = NullSpace()


class NullSpaceKeys(Table):
    """``[controller.null_space]``: beyond the paper, the null-space term added to Eq. (36)."""

    objective: Literal[OBJECTIVES] = _NS.objective
    gain: Annotated[Num, Field(ge=0)] = _NS.gain
    center: Vec | None = None  # [rad], joint-centering only

    @model_validator(mode="after")
    def center_with_centering(self):
        """``center`` applies to the joint-centering objective only."""
        if self.center is not None and self.objective != "joint-centering":
            fail(
                ("center",),
                f": only used with objective = 'joint-centering' (objective is {self.objective!r})",
            )
        return self


class LuJiaSingularityKeys(Table):
    """The lu-jia controller's key of ``[controller.singularity]``."""

    max_damped_time: Pos = default(LuJiaParams, "max_damped_time")  # [s]


class LuJiaKeys(Table):
    """The lu-jia controller's keys of a scenario's ``[controller]`` table (module
    docstring); defaults: :class:`LuJiaParams`, ``k_b`` and ``k_z`` derived when omitted."""

    scheme: Literal[SCHEMES] = default(LuJiaParams, "scheme")
    k_b: Pos | None = None  # None: derived from the funnel and dt (gains.derived_gain)
    k_z: Pos | None = None
    k_de: Pos = _G.k_de
    k_d: Pos = _G.k_d
    gamma_1: Pos = _G.gamma_1
    gamma_2: Pos = _G.gamma_2
    gamma_3: Pos = _G.gamma_3
    null_space: NullSpaceKeys = NullSpaceKeys()
    singularity: LuJiaSingularityKeys = LuJiaSingularityKeys()
    saturation: Literal[SATURATION_MODES] = "ignore"  # docs/saturation.md
    k_chi: Pos | None = None  # [1/s] None: the slowest funnel's beta
    k_v: Pos | None = None  # [1/s] None: k_d
    adaptation: Literal[ADAPTATIONS] = default(LuJiaParams, "adaptation")
    physical_margin: Annotated[Num, Field(ge=0)] | None = None  # None: derived (gains.md)


__all__ = ["GAIN_KEYS", "LuJiaKeys", "LuJiaParams", "LuJiaSingularityKeys", "NullSpaceKeys"]
