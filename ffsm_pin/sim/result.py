"""A recorded run: the signals of docs/cli.md, the summary and the checks computed from them."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# Keys of trajectory.npz required by docs/cli.md (one row per recorded sample).
CONTRACT_KEYS = (
    "t", "q", "v", "w", "u_m", "z_e", "z_e_d", "err_z", "rho_z", "q_b", "err_b", "rho_b",
    "P", "L", "F_r", "w_tilde", "e", "theta_z_hat", "theta_d_hat", "theta_b_hat",
)  # fmt: skip
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
)  # fmt: skip


@dataclass
class RunResult:
    """Signals of one run and what happened.

    ``signals`` maps every key of :data:`CONTRACT_KEYS`, :data:`TRUTH_KEYS` and
    :data:`EXTRA_KEYS` to an array (time along axis 0 for the per-sample keys).
    """

    scheme: str
    robot: str
    dt: float
    duration: float  # requested horizon [s]
    steps: int  # plant steps actually taken
    wall_time_s: float
    completed: bool
    stop_reason: str | None
    signals: dict[str, np.ndarray]
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

    def __getitem__(self, key: str) -> np.ndarray:
        return self.signals[key]

    # ---------------------------------------------------------------- checks
    @property
    def funnel_inside_b(self) -> np.ndarray:
        """Per sample: every attitude error component strictly inside Eq. (16)."""
        s = self.signals
        return np.all((s["err_b"] > s["bound_b_lower"]) & (s["err_b"] < s["bound_b_upper"]), 1)

    @property
    def funnel_inside_z(self) -> np.ndarray:
        """Per sample: every end-effector error component strictly inside Eq. (17)."""
        s = self.signals
        return np.all((s["err_z"] > s["bound_z_lower"]) & (s["err_z"] < s["bound_z_upper"]), 1)

    def funnel_kept(self, which: str) -> bool:
        """Funnel ``which`` ("b" or "z") held over the whole run.

        A run stopped because that funnel was left never records the sample outside it (the
        transformation (21) is undefined there), so the stop itself counts as a violation.
        """
        inside = self.funnel_inside_b if which == "b" else self.funnel_inside_z
        return bool(inside.all()) and self.stop_funnel != which

    def first_violation_time(self) -> float | None:
        """First recorded sample outside a funnel, or the time of a funnel stop; None if
        neither happened [s]."""
        bad = ~(self.funnel_inside_b & self.funnel_inside_z)
        if bad.any():
            return float(self.signals["t"][np.argmax(bad)])
        return self.stop_time if self.stop_funnel is not None else None

    def settle_time(self, which: str, rhoinf) -> float | None:
        """Time after which |err| stays inside rho_inf (all components), None if never."""
        err = np.abs(self.signals[f"err_{which}"])
        inside = np.all(err < np.asarray(rhoinf)[None, :], axis=1)
        if inside.size == 0 or not inside[-1]:
            return None
        outside = np.flatnonzero(~inside)
        return 0.0 if outside.size == 0 else float(self.signals["t"][outside[-1] + 1])

    def _settle(self, which: str, rhoinf) -> float | None:
        return (
            None
            if rhoinf is None or not len(self.signals["t"])
            else self.settle_time(which, rhoinf)
        )

    def drift(self) -> tuple[float, float]:
        """(max |P - P0|, max |L - L0|) over the run [kg m/s, kg m^2/s]."""
        P, L = self.signals["P"], self.signals["L"]
        return (
            float(np.max(np.linalg.norm(P - P[0], axis=1))) if len(P) else 0.0,
            float(np.max(np.abs(L - L[0]))) if len(L) else 0.0,
        )

    def summary(self) -> dict:
        """The summary.json content (docs/cli.md keys and a few more)."""
        s = self.signals
        drift_P, drift_L = self.drift()
        n = len(s["t"])
        u_norm = np.linalg.norm(s["u_m"], axis=1) if n else np.zeros(0)
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
            "max_abs_u": float(u_norm.max()) if n else 0.0,
            "drift_P": drift_P,
            "drift_L": drift_L,
            "settle_time_b": self._settle("b", self.rhoinf_b),
            "settle_time_z": self._settle("z", self.rhoinf_z),
            "completed": self.completed,
            "stop_reason": self.stop_reason,
            "stop_time": self.stop_time,
            "stop_cause": self.stop_cause,
            "stop_funnel": self.stop_funnel,
            "min_sigma": float(np.min(s["sigma_min"])) if n else None,
            "damping_threshold": self.damping_threshold,
            "damped_fraction": float(np.mean(s["damping"] > 0)) if n else 0.0,
            "max_abs_F_r": float(np.max(np.abs(s["F_r"]))) if n else 0.0,
            "final_theta_z_error": _final_norm(s["theta_z_hat"], s["theta_z"]),
            "final_theta_d_error": _final_norm(s["theta_d_hat"], s["theta_d"]),
            "events": list(self.events),
        }
        return out

    # ---------------------------------------------------------------- files
    def save(self, out_dir: str | Path) -> dict:
        """Write ``trajectory.npz`` and ``summary.json`` into ``out_dir``; return the summary."""
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(out_dir / "trajectory.npz", **self.signals)
        summary = self.summary()
        (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        return summary


def _final_norm(hat: np.ndarray, truth: np.ndarray) -> float | None:
    if len(hat) == 0:
        return None
    return float(np.linalg.norm(hat[-1] - truth))
