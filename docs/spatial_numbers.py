"""Measure the spatial runs of docs/REPRODUCTION.md ("Spatial (m2 = m3 = 3)") from run folders.

    python docs/spatial_numbers.py RUN_DIR [RUN_DIR ...]

Each RUN_DIR holds ``trajectory.npz`` and ``summary.json`` written by ``python -m
ffsm_pin.sim`` (e.g. ``--case spatial``). Output: one Markdown table, one column per run. The
joint torques are compared with the Franka Emika Panda's rated torques (87 N m on joints 1-4,
12 N m on joints 5-7) when the run has 7 joints; attitudes are MRPs, converted to angles with
phi = 4 atan(|s|).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

PANDA_TAU_MAX = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0])  # [N m]
ERR_P = 0.01  # |dp_e| threshold [m]


def stays_below(t: np.ndarray, x: np.ndarray, bound: float) -> float | None:
    """First time after which x < bound until the end of the run (None if never)."""
    ok = x < bound
    if not ok[-1]:
        return None
    bad = np.flatnonzero(~ok)
    return 0.0 if bad.size == 0 else float(t[bad[-1] + 1])


def fmt(x, spec: str = "{:.2f}") -> str:
    return "never" if x is None else spec.format(x)


def angle_deg(s: np.ndarray) -> np.ndarray:
    """Rotation angle [deg] of MRPs s (rows): phi = 4 atan(|s|)."""
    return np.degrees(4.0 * np.arctan(np.linalg.norm(np.atleast_2d(s), axis=1)))


def measure(run: Path) -> dict[str, str]:
    d = np.load(run / "trajectory.npz")
    s = json.loads((run / "summary.json").read_text())
    t, u = d["t"], d["u_m"]
    n = u.shape[1]
    u_joint = np.abs(u).max(axis=0)
    i_max = int(np.argmax(np.linalg.norm(u, axis=1)))
    err_z = d["err_z"]
    pos = np.linalg.norm(err_z[:, :3], axis=1)
    att_b = angle_deg(d["err_b"])
    w_m = d["w"][:, 3:]
    row = {
        "scheme": s["scheme"],
        "joints": str(n),
        "completed": "yes" if s["completed"] else f"no, {s['stop_time']:.2f} s ({s['stop_cause']})",
        "attitude funnel kept": "yes" if s["funnel_ok_b"] else "no",
        "end-effector funnel kept": "yes" if s["funnel_ok_z"] else "no",
        "first funnel violation [s]": fmt(s["first_violation_t"]),
        "errors inside rho_inf after [s] (b / z)": (
            f"{fmt(s['settle_time_b'])} / {fmt(s['settle_time_z'])}"
        ),
        "base attitude error start -> max -> end [deg]": (
            f"{att_b[0]:.1f} -> {att_b.max():.1f} -> {att_b[-1]:.2g}"
        ),
        "final \\|dp_e\\| [m]": f"{pos[-1]:.1e}",
        "\\|dp_e\\| < 1 cm after [s]": fmt(stays_below(t, pos, ERR_P)),
        "final \\|dq_e\\| [MRP] (pose task)": (
            f"{np.linalg.norm(err_z[-1, 3:]):.1e}" if err_z.shape[1] == 6 else "-"
        ),
        "final \\|dq_b\\| [MRP]": f"{np.linalg.norm(d['err_b'][-1]):.1e}",
        "max \\|u_m\\| [N m] (norm)": f"{s['max_abs_u']:.3g} at {t[i_max]:.2f} s",
        "max \\|u_m\\| [N m] after 1 s (norm)": f"{np.linalg.norm(u[t >= 1.0], axis=1).max():.2g}",
        "max \\|u_m,i\\| per joint [N m]": ", ".join(f"{x:.2g}" for x in u_joint),
        "max \\|w_m,i\\| [rad/s]": f"{np.abs(w_m).max():.2g}",
        "max \\|F_r\\| component [N m]": f"{s['max_abs_F_r']:.2g}",
        "min sigma(J_m-hat U-hat) [m]": (
            f"{s['min_sigma']:.3g} at {t[int(np.argmin(d['sigma_min']))]:.1f} s"
        ),
        "damped share of samples": f"{s['damped_fraction']:.3f}",
        "momentum drift P / L": f"{s['drift_P']:.1e} / {s['drift_L']:.1e}",
        "\\|theta_z~\\| start -> end": (
            f"{np.linalg.norm(d['theta_z_hat'][0] - d['theta_z']):.3g} -> "
            f"{s['final_theta_z_error']:.3g}"
        ),
        "wall time [s] (steps/s)": f"{s['wall_time_s']:.1f} ({s['steps_per_s']:.0f})",
    }
    if n == len(PANDA_TAU_MAX):
        row["max \\|u_m,i\\| / Panda limit"] = f"{(u_joint / PANDA_TAU_MAX).max():.2g}"
    return row


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__, file=sys.stderr)
        return 2
    runs = [Path(a) for a in argv]
    cols = [measure(r) for r in runs]
    keys = list(dict.fromkeys(k for c in cols for k in c))
    print("| quantity | " + " | ".join(r.name for r in runs) + " |")
    print("|---|" + "---|" * len(runs))
    for k in keys:
        print(f"| {k} | " + " | ".join(c.get(k, "-") for c in cols) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
