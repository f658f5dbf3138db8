"""Reaction wheels fixed in the bus (issue 40, ``[robot.satellite.wheels]``): their axes,
spin inertias and limits, and the torque they put on the bus (docs/capture.md, "Reaction
wheels"). The plant that steps them with the robot is :class:`ffsm_pin.sim.wheels.WheeledPlant`.

The state of N wheels is h (N,) [N m s]: each wheel's absolute angular momentum about its axis
(column i of A, 3 x N, unit vectors in the bus frame). dh/dt = tau_w, and the bus feels
-(A tau_w + w_b x A h).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .._docstrings import doc_entries, fill_doc
from ..errors import ParameterError, check_keys

# numpydoc entries its docstrings share (ffsm_pin._docstrings)
_DOC = doc_entries(
    h="""
        h : array_like, shape (k,)
            Wheel momenta [N m s].""",
    w_bus="""
        w_bus : array_like, shape (3,)
            The bus's angular velocity, bus frame [rad/s].""",
    params_h_w_bus=("h", "w_bus"),
)

#: The wheels' command when the controller gives none (``control``): ``"none"`` (zero
#: torque), ``"attitude-pd"`` (the bus attitude held at the reference by a PD law on the
#: wheels, :meth:`Wheels.attitude_pd`; our extension, docs/capture.md) or
#: ``"attitude-pd-after-capture"`` (the same from a ``[capture]``'s grasp on, zero before).
WHEEL_CONTROLS = ("none", "attitude-pd", "attitude-pd-after-capture")
_LIMITS = ("axes", "inertia", "max_torque", "max_momentum")
_KEYS = (*_LIMITS, "control", "kp", "kd")


def _per_wheel(value, n: int, key: str, *, positive: bool = True) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ParameterError(f"wheels.{key}: expected one number or {n}, got shape {arr.shape}")
    if np.isnan(arr).any() or (positive and not (arr > 0).all()):
        raise ParameterError(f"wheels.{key}: every value must be > 0, got {arr.tolist()}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
@fill_doc(_DOC)
class Wheels:
    """N reaction wheels fixed in the bus.

    Attributes
    ----------
    axes : ndarray
        (3, N) spin axes in the bus (root joint) frame, unit vectors (``"xyz"``: the three
        frame axes; other columns are normalised, a zero column is refused).
    inertia : ndarray
        (N,) spin (axial) inertias J_s [kg m^2], > 0.
    max_torque : ndarray
        (N,) motor torque limits [N m], > 0 (``inf``: none).
    max_momentum : ndarray
        (N,) momentum capacities, ``abs(h_i) <= max_momentum`` [N m s], > 0 (``inf``: none).
    control : str
        The command when the controller gives none (:data:`WHEEL_CONTROLS`).
    kp, kd : float
        The ``"attitude-pd"`` gains [N m / rad], [N m s / rad], >= 0.
    """

    axes: np.ndarray
    inertia: np.ndarray
    max_torque: np.ndarray = np.inf  # type: ignore[assignment]  # a number stands for all
    max_momentum: np.ndarray = np.inf  # type: ignore[assignment]
    control: str = "none"
    kp: float = 0.0
    kd: float = 0.0

    def __post_init__(self) -> None:
        axes = self.axes
        if isinstance(axes, str):
            if axes != "xyz":
                raise ParameterError(
                    f"wheels.axes: {axes!r} unknown; give 'xyz' or a 3 x N matrix of axes"
                )
            axes = np.eye(3)
        axes = np.array(axes, dtype=float)
        if axes.ndim != 2 or axes.shape[0] != 3 or axes.shape[1] < 1:
            raise ParameterError(
                f"wheels.axes: expected 'xyz' or a 3 x N matrix (one column per wheel), got "
                f"shape {axes.shape}"
            )
        norms = np.linalg.norm(axes, axis=0)
        if not (np.isfinite(norms).all() and (norms > 1e-12).all()):
            bad = [i for i, x in enumerate(norms) if not (np.isfinite(x) and x > 1e-12)]
            raise ParameterError(f"wheels.axes: wheel(s) {bad} have a zero or non-finite axis")
        # (columns of unit length kept as given: a saved scenario reads back bit for bit)
        axes = np.where(np.abs(norms - 1.0) <= 4e-16, axes, axes / norms)
        axes.setflags(write=False)
        n = axes.shape[1]
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "inertia", _per_wheel(self.inertia, n, "inertia"))
        object.__setattr__(self, "max_torque", _per_wheel(self.max_torque, n, "max_torque"))
        object.__setattr__(self, "max_momentum", _per_wheel(self.max_momentum, n, "max_momentum"))
        if self.control not in WHEEL_CONTROLS:
            raise ParameterError(
                f"wheels.control: {self.control!r} unknown; valid choices: "
                f"{', '.join(map(repr, WHEEL_CONTROLS))}"
            )
        for key in ("kp", "kd"):
            gain = float(getattr(self, key))
            if not (gain >= 0 and np.isfinite(gain)):
                raise ParameterError(f"wheels.{key}: must be a finite number >= 0, got {gain}")
            object.__setattr__(self, key, gain)

    @classmethod
    def from_mapping(cls, table: Mapping) -> Wheels:
        """From a dict (e.g. a scenario's ``[robot.satellite.wheels]``): ``axes`` (default
        ``"xyz"``), ``inertia`` (required), ``max_torque`` and ``max_momentum`` (default: no
        limit); a number stands for every wheel. Unknown keys are errors."""
        check_keys(table, _KEYS, "wheels")
        if "inertia" not in table:
            raise ParameterError("wheels: 'inertia' (each wheel's spin inertia, kg m^2) is missing")
        return cls(
            axes=table.get("axes", "xyz"),
            inertia=table["inertia"],
            max_torque=table.get("max_torque", np.inf),
            max_momentum=table.get("max_momentum", np.inf),
            control=table.get("control", "none"),
            kp=table.get("kp", 0.0),
            kd=table.get("kd", 0.0),
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Wheels):
            return NotImplemented
        return all(np.array_equal(getattr(self, k), getattr(other, k)) for k in _KEYS)

    def __hash__(self) -> int:  # by value, as __eq__ (a RobotSpec is a cache key)
        arrays = (self.axes, self.inertia, self.max_torque, self.max_momentum)
        return hash(
            (self.axes.shape, *(a.tobytes() for a in arrays), self.control, self.kp, self.kd)
        )

    def table(self) -> dict:
        """The ``[robot.satellite.wheels]`` table that builds these wheels again
        (:meth:`from_mapping`): ``axes = "xyz"`` for the three frame axes, else the 3 x N
        rows; a number where every wheel has the same value; an infinite limit left out.

        Returns
        -------
        dict
            Key -> value, TOML-ready (floats and lists of floats).
        """
        axes = "xyz" if np.array_equal(self.axes, np.eye(3)) else self.axes.tolist()
        out: dict = {"axes": axes}
        for key in ("inertia", "max_torque", "max_momentum"):
            arr = getattr(self, key)
            if np.isinf(arr).all():
                continue
            out[key] = float(arr[0]) if (arr == arr[0]).all() else arr.tolist()
        if self.control != "none":
            out.update(control=self.control, kp=self.kp, kd=self.kd)
        return out

    @property
    def n(self) -> int:
        """The number of wheels."""
        return int(self.axes.shape[1])

    def limit(self, h, tau, dt: float) -> np.ndarray:
        """The torques [N m] the wheels apply for commanded ``tau`` over ``dt`` [s] from
        momenta ``h``: clipped to +-max_torque, then so that ``abs(h + tau dt) <= max_momentum``
        (a wheel at its capacity gives no more torque that way).

        Parameters
        ----------
        %(h)s
        tau : array_like, shape (k,)
            Commanded torques [N m].
        dt : float
            The step [s].

        Returns
        -------
        ndarray, shape (k,)
            The torques applied [N m].
        """
        h, tau = np.asarray(h, dtype=float), np.asarray(tau, dtype=float)
        out = np.clip(tau, -self.max_torque, self.max_torque)
        return np.clip(out, (-self.max_momentum - h) / dt, (self.max_momentum - h) / dt)

    def momentum_bus(self, h) -> np.ndarray:
        """A h: the wheels' angular momentum in the bus frame [N m s]."""
        return self.axes @ np.asarray(h, dtype=float)

    def bus_torque(self, h, tau, w_bus) -> np.ndarray:
        """The torque on the bus [N m], bus frame: -(A tau + w_bus x A h).

        Parameters
        ----------
        %(h)s
        tau : array_like, shape (k,)
            Wheel torques [N m].
        %(w_bus)s

        Returns
        -------
        ndarray, shape (3,)
            The torque [N m], bus frame.
        """
        return -(self.axes @ np.asarray(tau, float) + np.cross(w_bus, self.momentum_bus(h)))

    def spin_rates(self, h, w_bus) -> np.ndarray:
        """Each wheel's spin relative to the bus [rad/s]: h_i / J_s,i - a_i . w_bus.

        %(params_h_w_bus)s

        Returns
        -------
        ndarray, shape (k,)
            Spin rates [rad/s].
        """
        return np.asarray(h, float) / self.inertia - self.axes.T @ np.asarray(w_bus, float)

    @cached_property
    def allocation(self) -> np.ndarray:
        """A^+ (k, 3): the least-norm wheel vector x with A x = v is ``allocation @ v`` (with
        three independent axes the only one); :meth:`storing`'s and :meth:`attitude_pd`'s
        allocation, computed once."""
        return np.linalg.pinv(self.axes)

    def storing(self, momentum) -> np.ndarray:
        """The wheel momenta h = A^+ L that store the angular momentum L (bus frame): of the
        h with A h = L the one of least norm (with 3 independent axes the only one), the
        allocation of :meth:`attitude_pd`.

        Parameters
        ----------
        momentum : array_like, shape (3,)
            L, bus frame [N m s].

        Returns
        -------
        ndarray, shape (k,)
            Wheel momenta [N m s].
        """
        return self.allocation @ np.asarray(momentum, float)

    def attitude_pd(self, rotation_error, w_bus) -> np.ndarray:
        """The ``"attitude-pd"`` command [N m]: the wheel torques whose reaction on the bus is
        ``-(kp phi + kd w_bus)`` (least squares over the wheels, A^+), phi the rotation vector
        of the bus attitude error in the bus frame (the gyroscopic torque w_b x A h is left to
        the PD).

        Parameters
        ----------
        rotation_error : array_like, shape (3,)
            phi: the rotation from the desired bus attitude to the bus's, bus frame [rad].
        %(w_bus)s

        Returns
        -------
        ndarray, shape (k,)
            Commanded wheel torques [N m].
        """
        wanted = self.kp * np.asarray(rotation_error, float) + self.kd * np.asarray(w_bus, float)
        return self.allocation @ wanted
