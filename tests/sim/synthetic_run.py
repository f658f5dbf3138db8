"""A synthetic RunResult with every contract key at the right shape, for output tests.

The robot moves plausibly (joints swing, the base drifts and turns slowly) so that figures and
replays have something to show; the numbers are not a closed-loop run.
"""

from __future__ import annotations

import math

import numpy as np

from ffsm_pin.sim.result import RunResult

N_JOINTS = 4


def synthetic_result(
    duration: float = 30.0,
    dt: float = 1e-3,
    *,
    scheme: str = "ppc",
    completed: bool = True,
    phase: float = 0.0,
) -> RunResult:
    """A RunResult of ``duration`` [s] sampled every ``dt`` [s] (planar 4-joint robot)."""
    t = np.arange(round(duration / dt) + 1) * dt
    n = len(t)
    m = N_JOINTS
    q_m0 = np.array([1, -1, 1, -1]) * math.pi / 3
    q_m = q_m0 + 0.3 * np.sin(0.5 * t[:, None] + phase + np.arange(m)[None, :])
    w_m = 0.15 * np.cos(0.5 * t[:, None] + phase + np.arange(m)[None, :])
    q_b = (0.18 * np.exp(-0.3 * t))[:, None]
    w_b = -0.054 * np.exp(-0.3 * t)
    xy = np.stack([-1.2 + 0.0988 * t, -0.8 + 0.0943 * t], axis=1)
    q = np.concatenate([xy, np.cos(q_b), np.sin(q_b), q_m], axis=1)
    v = np.concatenate([np.full((n, 2), 0.1), w_b[:, None], w_m], axis=1)
    w = np.concatenate([w_b[:, None], w_m], axis=1)

    rho_b = (1.0 - 0.03) * np.exp(-0.22 * t)[:, None] + 0.03
    rho_z = (np.array([1.0, 1.0, 0.2]) - [0.08, 0.08, 0.05]) * np.exp(-0.22 * t)[:, None]
    rho_z = rho_z + [0.08, 0.08, 0.05]
    err_b = q_b.copy()
    err_z = np.array([-0.228, 0.478, 0.070]) * np.exp(-0.4 * t)[:, None]
    sign_z = np.array([-1, 1, 1])
    bz_lo = np.where(sign_z > 0, -0.8, -1.0) * rho_z
    bz_hi = np.where(sign_z > 0, 1.0, 0.8) * rho_z
    z_e_d = np.stack(
        [
            3.9 + 0.1 * np.cos(0.349 * t) + 0.1 * np.cos(t / 3),
            2.3 + 0.1 * np.sin(0.349 * t) + 0.1 * np.sin(t / 3),
            0.03 + 0.03 * np.cos(0.349 * t) + 0.05 * np.cos(t / 3),
        ],
        axis=1,
    )
    z_e = z_e_d + err_z
    z_e_d_dot = np.gradient(z_e_d, dt, axis=0)
    z_e_dot = np.gradient(z_e, dt, axis=0)
    rng = np.random.default_rng(0)
    theta_z, theta_d, theta_b = rng.random(7), rng.random(15) * 10, rng.random(16) * 10
    decay = np.exp(-0.2 * t)[:, None]
    signals = {
        "t": t,
        "q": q,
        "v": v,
        "w": w,
        "u_m": 5.0 * np.sin(t[:, None] + np.arange(m)) * np.exp(-0.1 * t)[:, None],
        "z_e": z_e,
        "z_e_d": z_e_d,
        "err_z": err_z,
        "rho_z": rho_z,
        "q_b": q_b,
        "err_b": err_b,
        "rho_b": rho_b,
        "P": np.tile([6.0, 5.7], (n, 1)) + 1e-13 * rng.standard_normal((n, 2)),
        "L": -0.8 + 1e-13 * rng.standard_normal(n),
        "F_r": 3.0 * np.sin(2 * t) * np.exp(-0.3 * t),
        "w_tilde": 0.1 * np.exp(-0.5 * t)[:, None] * np.ones((n, 5)),
        "e": 0.05 * np.exp(-0.5 * t)[:, None] * np.ones((n, 5)),
        "theta_z_hat": theta_z + 0.5 * decay,
        "theta_d_hat": theta_d + 2.0 * decay,
        "theta_b_hat": theta_b + 2.0 * decay,
        "theta_z": theta_z,
        "theta_d": theta_d,
        "theta_b": theta_b,
        "z_e_dot": z_e_dot,
        "z_e_d_dot": z_e_d_dot,
        "w_mc": w_m.copy(),
        "w_hat": w.copy(),
        "sigma_min": 0.3 + 0.28 * np.cos(0.3 * t),
        "damping": np.where(0.3 + 0.28 * np.cos(0.3 * t) < 0.05, 1e-3, 0.0),
        "bound_b_lower": -0.8 * rho_b,
        "bound_b_upper": rho_b,
        "bound_z_lower": bz_lo,
        "bound_z_upper": bz_hi,
    }
    return RunResult(
        scheme=scheme,
        robot="ffsm_planar4",
        dt=dt,
        duration=duration,
        steps=n - 1,
        wall_time_s=1.0,
        completed=completed,
        stop_reason=None if completed else "funnel left (synthetic)",
        signals=signals,
        scenario_name=f"synthetic-{scheme}",
        stop_time=None if completed else float(t[-1]),
        rhoinf_b=(0.03,),
        rhoinf_z=(0.08, 0.08, 0.05),
    )
