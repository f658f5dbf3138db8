"""A recorded run: the signals of docs/cli.md, the summary and the checks computed from them."""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..attitude import mrp
from ..control.registry import DEFAULT_TYPE
from .files import RunFolder, held_interrupt, output_error, strict_json
from .recorder import Signals, write_npz
from .relaxation import relaxation_summary
from .target_run import target_summary
from .thinned import Thinned

# Keys of trajectory.npz required by docs/cli.md (one row per recorded sample).
CONTRACT_KEYS = (
    "t", "q", "v", "w", "u_m", "z_e", "z_e_d", "err_z", "rho_z", "q_b", "err_b", "rho_b",
    "P", "L", "F_r", "w_tilde", "e", "theta_z_hat", "theta_d_hat", "theta_b_hat",
)  # fmt: skip
FIGURE_ROWS = 100_000  # figures are drawn from at most this many evenly spaced rows
# Constant arrays saved alongside (the true parameters).
TRUTH_KEYS = ("theta_z", "theta_d", "theta_b")
# Extra signals (extensions of the contract).
EXTRA_KEYS = (
    "z_e_dot",  # measured end-effector velocity [m/s, m/s, rad/s]
    "z_e_d_dot",  # reference velocity
    "w_mc",  # kinematic-level command, Eqs. (25)+(36) or (81) [rad/s]
    "w_hat",  # filter state, Eq. (46) [rad/s]
    "sigma_min",  # smallest singular value of J_m-hat U-hat (or J_m-hat) [m]
    "damping",  # lambda^2 of the damped pseudo-inverse (0 = undamped)
    "bound_b_lower", "bound_b_upper",  # funnel bounds on err_b (Eq. 16)
    "bound_z_lower", "bound_z_upper",  # funnel bounds on err_z (Eq. 17)
    "dw_b",  # base angular acceleration (inertial frame) [rad/s^2], for F_r of Eq. (7)
)  # fmt: skip


@dataclass
class _Scan:
    """Reductions over every recorded row (:meth:`RunResult._scan`)."""

    outside: dict[str, int | None]  # first row outside funnel b / z, None if none
    # the first component outside funnel b / z at that row (the lowest index if several)
    component: dict[str, int | None] = field(default_factory=lambda: {"b": None, "z": None})
    rows: int = 0
    drift_P: float = 0.0
    drift_L: float = 0.0
    max_u: float = 0.0  # largest Euclidean norm of u_m
    max_u_joint: float = 0.0  # largest |u_m[i]| of any joint
    max_u_cmd: float = 0.0
    min_sigma: float | None = None
    damped: int = 0  # rows with damping > 0
    max_F_r: float = 0.0
    effort: float = 0.0  # integral of |u_m|^2 dt [N^2 m^2 s]
    sq_err_z_late: float = 0.0  # sum of |err_z|^2 over the rows of the last half
    rows_late: int = 0
    max_excursion: float = 0.0  # largest rotation of the base from its initial attitude [rad]


def _rotation_angle(q_b: np.ndarray, q_b0: np.ndarray) -> np.ndarray:
    """Per row, the angle of the rotation from attitude ``q_b0`` to ``q_b`` [rad]: planar the
    angle difference, spatial (MRPs) :func:`~ffsm_pin.attitude.mrp.angles_from`."""
    return np.abs(q_b[:, 0] - q_b0[0]) if q_b.shape[1] == 1 else mrp.angles_from(q_b, q_b0)


def _inside(s: Mapping[str, np.ndarray], which: str) -> np.ndarray:
    """Per row: every component of err_<which> strictly inside its funnel bounds."""
    err = s[f"err_{which}"]
    return np.all((err > s[f"bound_{which}_lower"]) & (err < s[f"bound_{which}_upper"]), 1)


@dataclass
class RunResult:
    """Signals of one run and what happened.

    ``signals`` maps every key of :data:`CONTRACT_KEYS`, :data:`TRUTH_KEYS` and
    :data:`EXTRA_KEYS` to an array (time along axis 0 for the per-sample keys).

    Attributes
    ----------
    scheme : str or None
        The controller's variant (its ``scheme``; the paper's: ppc, ...), or None.
    robot : str
        The robot's name.
    dt : float
        The control period [s].
    duration : float
        The requested horizon [s].
    steps : int
        Plant steps actually taken.
    wall_time_s : float
        Wall-clock time of the run [s].
    completed : bool
        The run reached its horizon.
    stop_reason : str or None
        Why it stopped early (the stop's message).
    signals : mapping of str to ndarray
        The recorded and derived signals.
    scenario_name : str
        The scenario's name.
    stop_time : float or None
        When it stopped [s].
    stop_cause : str or None
        ``"funnel"``, ``"singular"``, ``"nonfinite"``, ``"estimate"``, ...
    stop_funnel : str or None
        ``"b"`` or ``"z"`` when the run stopped at a funnel exit.
    integrator : str
        The plant integrator (``[sim] integrator``).
    substeps : int
        Plant steps per control step (``[sim] substeps``).
    events : list of str
        What happened during the run (warnings).
    rhoinf_b, rhoinf_z : tuple of float or None
        rho_inf of the two funnels, for settle times.
    damping_threshold : float or None
        sigma_min below which damped least squares is active [m].
    description : str
        The scenario's description.
    controller : str
        The controller type (``[controller] type``).
    sigma_measure : str or None
        What the controller's sigma_min is the smallest singular value of.
    saturation_fraction, saturation_per_joint : float, list of float or None
        Fraction of control periods with a joint at its torque limit, and per joint.
    estimates : dict or None
        What the initial estimates were drawn as (``estimates.json``).
    target : Target or None
        The ``[target]`` body (:mod:`.target_run`): the summary's ``target_drift_*``.
    capture, outcomes : CaptureOutcome or None, tuple
        With ``[capture]`` (:mod:`.capture_run`); more (wheels, detumble): their summary keys.
    blas, versions : str or None
        What the run computed with (:mod:`ffsm_pin._numerics`): the BLAS libraries and their
        kernels, the libraries' versions; None when not known.
    """

    scheme: str | None  # the controller's variant (its ``scheme``; the paper's: ppc, ...) or None
    robot: str
    dt: float
    duration: float  # requested horizon [s]
    steps: int  # plant steps actually taken
    wall_time_s: float
    completed: bool
    stop_reason: str | None
    signals: Mapping[str, np.ndarray]
    scenario_name: str = "scenario"
    stop_time: float | None = None
    stop_cause: str | None = None  # "funnel" | "singular" | "nonfinite" | "estimate"
    stop_funnel: str | None = None  # "b" or "z" when the run stopped at a funnel exit
    integrator: str = "semi-implicit"  # plant integrator ([sim] integrator)
    substeps: int = 1  # plant steps per control step ([sim] substeps)
    events: list[str] = field(default_factory=list)
    rhoinf_b: tuple[float, ...] | None = None  # for settle times
    rhoinf_z: tuple[float, ...] | None = None
    damping_threshold: float | None = None  # sigma_min below which DLS is active [m]
    description: str = ""
    controller: str = DEFAULT_TYPE  # the controller type ([controller] type)
    sigma_measure: str | None = None
    saturation_fraction: float = 0.0  # control periods with a joint at its torque limit
    saturation_per_joint: list[float] | None = None
    estimates: dict | None = None  # what the initial estimates were drawn as (estimates.json)
    target: Any = None  # the [target] body (sim.target.Target), None without one
    capture: Any = None  # the capture's outcome (sim.capture_run.CaptureOutcome) or None
    outcomes: tuple = ()  # objects with summary() (sim.wheels_run, sim.detumble)
    blas: str | None = None  # the BLAS libraries and kernels of the run (ffsm_pin._numerics)
    versions: str | None = None  # ffsm-pin's and its numerical libraries' versions
    _scanned: _Scan | None = field(default=None, init=False, repr=False, compare=False)

    def __getitem__(self, key: str) -> np.ndarray:
        return self.signals[key]

    def __contains__(self, key: object) -> bool:
        return key in self.signals

    @property
    def funnel_inside_b(self) -> np.ndarray:
        """Per sample: every attitude error component strictly inside Eq. (16)."""
        return _inside(self.signals, "b")

    @property
    def funnel_inside_z(self) -> np.ndarray:
        """Per sample: every end-effector error component strictly inside Eq. (17)."""
        return _inside(self.signals, "z")

    def funnel_kept(self, which: str) -> bool:
        """Funnel ``which`` ("b" or "z") held over the whole run.

        A run stopped because that funnel was left never records the sample outside it (the
        transformation (21) is undefined there), so the stop itself counts as a violation. A
        run without a recorded row kept nothing.
        """
        scan = self._scan()
        return scan.rows > 0 and scan.outside[which] is None and self.stop_funnel != which

    def first_violation_time(self) -> float | None:
        """First recorded sample outside a funnel, or the time of a funnel stop; None if
        neither happened [s]."""
        return self.first_violation()[2]

    def first_violation(self) -> tuple[str | None, int | None, float | None]:
        """(funnel, component, time) of the first departure from a funnel: the first recorded
        sample outside funnel "b" or "z" (at a tie "z"; the lowest component outside at that
        sample), or else the funnel, component and time of a funnel stop (the paper's
        controller stops before it records the sample outside; the component is the one its
        stop reason names). (None, None, None) if neither happened."""
        scan = self._scan()
        rows = {w: i for w, i in scan.outside.items() if i is not None}
        if rows:
            which = min(rows, key=lambda w: (rows[w], w == "b"))
            return which, scan.component[which], float(self.signals["t"][rows[which]])
        if self.stop_funnel is None:
            return None, None, None
        return self.stop_funnel, _stop_component(self.stop_reason), self.stop_time

    def settle_time(self, which: str, rhoinf) -> float | None:
        """Time after which ``|err|`` stays inside rho_inf (all components), None if never.

        Parameters
        ----------
        which : str
            ``"b"`` (attitude) or ``"z"`` (end effector).
        rhoinf : array_like
            rho_inf per component.

        Returns
        -------
        float or None
            The time [s].
        """
        n, last_out = 0, None  # rows seen, last row with a component outside rho_inf
        for block in self.signals_blocks([f"err_{which}"]):
            err = np.abs(block[f"err_{which}"])
            out = np.flatnonzero(~np.all(err < np.asarray(rhoinf)[None, :], axis=1))
            if out.size:
                last_out = n + int(out[-1])
            n += len(err)
        if n == 0 or last_out == n - 1:
            return None
        return 0.0 if last_out is None else float(self.signals["t"][last_out + 1])

    def _settle(self, which: str, rhoinf) -> float | None:
        return (
            None
            if rhoinf is None or not len(self.signals["t"])
            else self.settle_time(which, rhoinf)
        )

    def drift(self) -> tuple[float, float]:
        """(max ``|P - P0|``, max ``|L - L0|``) over the run [kg m/s, kg m^2/s]."""
        scan = self._scan()
        return scan.drift_P, scan.drift_L

    def signals_blocks(self, keys) -> Iterator[dict[str, np.ndarray]]:
        """Consecutive row blocks of the per-row signals ``keys`` (all rows in one block
        unless the recording was spilled to disk, ``ffsm_pin.sim.recorder``)."""
        if isinstance(self.signals, Signals):
            yield from self.signals.blocks(keys)
        else:
            yield {k: self.signals[k] for k in keys}

    def _scan(self) -> _Scan:
        """The reductions over every row the summary needs, in one pass over the blocks."""
        if self._scanned is not None:
            return self._scanned
        keys = ["err_b", "err_z", "bound_b_lower", "bound_b_upper", "bound_z_lower"]
        keys += ["bound_z_upper", "u_m", "P", "L", "F_r", "t", "q_b"]
        # absent: u_cmd in older recordings, sigma_min, damping of some controllers
        keys += [k for k in ("u_cmd", "sigma_min", "damping") if k in self.signals]
        scan = _Scan(outside={"b": None, "z": None})
        P0 = L0 = q_b0 = None
        n = 0
        t_all = self.signals["t"]
        t_half = float(t_all[-1]) / 2 if len(t_all) else 0.0
        carry = None  # (t, |u|^2) of the previous block's last row
        for b in self.signals_blocks(keys):
            rows = len(b["u_m"])
            if rows == 0:
                continue
            t = np.asarray(b["t"])
            u2 = np.sum(np.asarray(b["u_m"]) ** 2, axis=1)
            if carry is not None:  # trapezoids, across blocks
                scan.effort += 0.5 * (carry[1] + u2[0]) * (t[0] - carry[0])
            scan.effort += float(np.sum(0.5 * (u2[:-1] + u2[1:]) * np.diff(t)))
            carry = (float(t[-1]), float(u2[-1]))
            late = t >= t_half
            scan.sq_err_z_late += float(np.sum(np.asarray(b["err_z"])[late] ** 2))
            scan.rows_late += int(np.count_nonzero(late))
            q_b = np.asarray(b["q_b"]).reshape(rows, -1)
            if q_b0 is None:
                q_b0 = q_b[0]
            scan.max_excursion = _max(scan.max_excursion, _rotation_angle(q_b, q_b0))
            for which in ("b", "z"):
                bad = np.flatnonzero(~_inside(b, which))
                if bad.size and scan.outside[which] is None:
                    scan.outside[which] = n + int(bad[0])
                    scan.component[which] = _first_outside(b, which, int(bad[0]))
            if P0 is None:
                P0, L0 = b["P"][0], b["L"][0]
            # np.max / np.min, not max(): a NaN propagates as it would over the whole run
            scan.drift_P = _max(scan.drift_P, np.linalg.norm(b["P"] - P0, axis=1))
            scan.drift_L = _max(scan.drift_L, np.abs(b["L"] - L0))
            scan.max_u = _max(scan.max_u, np.linalg.norm(b["u_m"], axis=1))
            scan.max_u_joint = _max(scan.max_u_joint, np.abs(b["u_m"]))
            if "u_cmd" in b:
                scan.max_u_cmd = _max(scan.max_u_cmd, np.linalg.norm(b["u_cmd"], axis=1))
            if "sigma_min" in b:
                low = float(np.min(b["sigma_min"]))
                scan.min_sigma = (
                    low if scan.min_sigma is None else float(np.min((scan.min_sigma, low)))
                )
            if "damping" in b:
                scan.damped += int(np.count_nonzero(b["damping"] > 0))
            scan.max_F_r = _max(scan.max_F_r, np.abs(b["F_r"]))
            n += rows
        scan.rows = n
        self._scanned = scan
        return scan

    def summary(self) -> dict:
        """The summary.json content (docs/cli.md keys and a few more)."""
        s = self.signals
        scan = self._scan()
        drift_P, drift_L = scan.drift_P, scan.drift_L
        first = self.first_violation()
        n = len(s["t"])
        out = {
            "scheme": self.scheme,
            "robot": self.robot,
            "scenario": self.scenario_name,
            "description": self.description,
            "dt": self.dt,
            "duration": self.duration,
            "integrator": self.integrator,
            "substeps": self.substeps,
            "steps": self.steps,
            "simulated_time": float(s["t"][-1]) if n else 0.0,
            "wall_time_s": self.wall_time_s,
            "steps_per_s": self.steps / self.wall_time_s if self.wall_time_s > 0 else None,
            "funnel_ok_b": self.funnel_kept("b"),
            "funnel_ok_z": self.funnel_kept("z"),
            "first_violation_t": self.first_violation_time(),
            "final_err_b": s["err_b"][-1].tolist() if n else [],
            "final_err_z": s["err_z"][-1].tolist() if n else [],
            "first_violation_funnel": first[0],
            "first_violation_component": first[1],
            "max_abs_u": scan.max_u,
            "max_torque_norm": scan.max_u,
            "max_joint_torque": scan.max_u_joint,
            "max_abs_u_cmd": scan.max_u_cmd,
            "saturation_fraction": self.saturation_fraction,
            "saturation_per_joint": (
                None if self.saturation_per_joint is None else list(self.saturation_per_joint)
            ),
            "controller": self.controller,
            "drift_P": drift_P,
            "drift_L": drift_L,
            "settle_time_b": self._settle("b", self.rhoinf_b),
            "settle_time_z": self._settle("z", self.rhoinf_z),
            "completed": self.completed,
            "stop_reason": self.stop_reason,
            "stop_time": self.stop_time,
            "stop_cause": self.stop_cause,
            "stop_funnel": self.stop_funnel,
            "min_sigma": scan.min_sigma,
            "min_sigma_of": (self.sigma_measure or OWN_SIGMA)
            if scan.min_sigma is not None
            else None,
            "damping_threshold": self.damping_threshold,
            "damped_fraction": scan.damped / n if n else 0.0,
            "max_abs_F_r": scan.max_F_r,
            "rms_err_z_late": (
                float(np.sqrt(scan.sq_err_z_late / scan.rows_late)) if scan.rows_late else None
            ),
            "control_effort": scan.effort,
            "max_base_excursion": scan.max_excursion,
            "final_theta_z_error": _final_norm(s, "theta_z"),
            "final_theta_d_error": _final_norm(s, "theta_d"),
            "events": list(self.events),
            "blas": self.blas,
            "versions": self.versions,
            **relaxation_summary(self.signals, self.signals_blocks, (self.rhoinf_b, self.rhoinf_z)),
        }
        if self.target is not None and "target_pose" in s:  # (only runs with a target)
            out.update(target_summary(self.target, self.signals_blocks, self.capture))
        extras = (x.summary() for x in (self.capture, *self.outcomes) if x is not None)
        return out | {k: v for extra in extras for k, v in extra.items()}

    def thinned(self, max_rows: int) -> RunResult:
        """The result with at most about ``max_rows`` evenly spaced rows (and the last one)
        of every per-row signal, for figures and replays; ``self`` when it has no more."""
        n = len(self.signals["t"])
        if n <= max_rows:
            return self
        step = -(-(n - 1) // max(1, max_rows - 1))  # ceil: rows 0, step, ... and n - 1
        return replace(self, signals=Thinned(self.signals, step, TRUTH_KEYS))

    # ---------------------------------------------------------------- files
    def save(self, out_dir: str | Path, *, figures: bool = False, compress: bool = False) -> dict:
        """Write ``trajectory.npz`` and ``summary.json`` into ``out_dir``; return the summary.

        The files replace an earlier run's in ``out_dir`` as a whole, once both are complete
        (:class:`~ffsm_pin.sim.files.RunFolder`); ``summary.json`` is strict JSON (non-finite
        numbers as ``null``). ``python -m ffsm_pin.sim`` writes its folder the same way,
        with the scenario and the replay (:func:`ffsm_pin.sim.outputs.write_outputs`).

        Parameters
        ----------
        out_dir : str or Path
            Output folder (created if needed).
        figures : bool
            Also draw the figures (``fig_*.png``, as ``python -m ffsm_pin.sim`` does, from at
            most 100,000 evenly spaced rows).
        compress : bool
            Deflate ``trajectory.npz`` (``numpy.savez_compressed``); off by default: floats
            deflate by about a tenth for 20 times the writing time (docs/cli.md).

        Raises
        ------
        OutputError
            A file could not be written; ``out_dir`` keeps what it held.

        Returns
        -------
        dict
            The summary (``summary.json``).
        """
        with held_interrupt(), RunFolder(out_dir) as out:
            try:
                summary = self.write_data(out, compress=compress)
                if figures:
                    from .figures import write_figures  # matplotlib only when asked for

                    write_figures(self.thinned(FIGURE_ROWS), out.staging)
            except OSError as exc:
                raise output_error(exc, Path(out_dir)) from None
            out.commit()
        return summary

    def write_data(self, out: RunFolder, *, compress: bool = False) -> dict:
        """Write the recording into a staged run folder ``out``: ``trajectory.npz``,
        ``summary.json`` and, when the estimates were drawn, ``estimates.json``; return the
        summary; :meth:`save` and :func:`ffsm_pin.sim.outputs.write_outputs` commit it.

        Parameters
        ----------
        out : RunFolder
            The staged folder.
        compress : bool
            Deflate ``trajectory.npz``.

        Returns
        -------
        dict
            The summary.
        """
        write_npz(out.path("trajectory.npz"), self.signals, compress=compress)
        summary = self.summary()
        out.path("summary.json").write_text(strict_json(summary), encoding="utf-8")
        if self.estimates is not None:
            out.path("estimates.json").write_text(strict_json(self.estimates), encoding="utf-8")
        return summary


def _max(so_far: float, values: np.ndarray) -> float:
    """max(so_far, max(values)), NaN-propagating as ``np.max``."""
    return float(np.max((so_far, np.max(values))))


def _first_outside(b: Mapping[str, np.ndarray], which: str, row: int) -> int:
    """The lowest component of err_<which> outside its funnel at ``row`` of block ``b``."""
    err = b[f"err_{which}"][row]
    ok = (err > b[f"bound_{which}_lower"][row]) & (err < b[f"bound_{which}_upper"][row])
    return int(np.flatnonzero(~ok)[0])


def _stop_component(reason: str | None) -> int | None:
    """The component a funnel stop's reason names ("... error component 1 (y) = ..."; a
    planar attitude error has one, 0)."""
    if not reason:
        return None
    found = re.search(r"error component (\d+)", reason)
    if found:
        return int(found.group(1))
    return 0 if "base attitude error =" in reason else None


#: ``min_sigma_of`` of a controller that reports ``sigma_min`` without saying of what
#: (its ``sigma_measure``, docs/controllers.md).
OWN_SIGMA = "sigma_min (the controller's own)"


def _final_norm(s: Mapping[str, np.ndarray], name: str) -> float | None:
    """|estimate - truth| at the last row; None when the controller reports no estimate."""
    if f"{name}_hat" not in s or len(s[f"{name}_hat"]) == 0:
        return None
    return float(np.linalg.norm(s[f"{name}_hat"][-1] - s[name]))
