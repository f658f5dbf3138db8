"""What a campaign case adds to its row beyond the run's summary, so that the report can say
why and how a run failed (docs/campaigns.md, "Output folder").

* ``saturation_per_joint``: per joint, the share of control periods at its torque limit (the
  summary's list, which :func:`~ffsm_pin.sweep.engine.summary_scalars` leaves out);
* ``joint_torque_limits``: the applied torque limit of each joint [N m] (null: none);
* ``min_sigma_gjm``: the smallest singular value of the generalized Jacobian's task rows,
  ``J* = J_m - J_b H_bb^-1 H_bm`` (Umetani & Yoshida 1989) of the **true** model at the
  recorded joint angles, the same measure for every controller (each controller's own
  ``min_sigma`` is of the matrix it inverts, with its estimates: ``min_sigma_of``). It is
  evaluated on the rows kept for ``signals.parquet`` (at most :data:`MAX_ROWS`, evenly spaced,
  first and last included), not on every recorded row, which keeps it cheap: the minimum
  over those rows is an upper bound of the minimum over the run;
* the decimated signals of :data:`SIGNAL_KEYS` on those rows (``signals.parquet``);
* ``impact_impulse``: a run with ``[capture]``: the summary's six values (docs/capture.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._docstrings import fill_doc
from ._docs import SWEEP_DOC

__all__ = [
    "MAX_ROWS", "SIGNALS", "SIGNAL_KEYS", "case_extras", "generalized_jacobian_sigmas",
    "kept_rows", "min_sigma_gjm", "sigmas_gjm",
]  # fmt: skip

#: Rows of a case kept in ``signals.parquet`` (at most).
MAX_ROWS = 500
#: The per-row signals kept (besides ``t``): errors, funnel widths and bounds, torques.
SIGNAL_KEYS = (
    "err_b", "err_z", "rho_b", "rho_z", "bound_b_lower", "bound_b_upper", "bound_z_lower",
    "bound_z_upper", "u_m", "u_cmd",
)  # fmt: skip
#: The key of a case outcome that holds its decimated signals (a dict of arrays), taken out of
#: the row by :class:`~ffsm_pin.sweep.table.ResultsTable` into ``signals.parquet``.
SIGNALS = "signals"


def kept_rows(n: int, max_rows: int = MAX_ROWS) -> np.ndarray:
    """At most ``max_rows`` evenly spaced row indices of ``n`` rows, the first and the last
    included (all of them when ``n <= max_rows``).

    Parameters
    ----------
    n : int
        Rows.
    max_rows : int
        Most rows kept.

    Returns
    -------
    ndarray of int
        The indices.
    """
    if n <= max_rows:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_rows)).astype(np.int64))


def generalized_jacobian_sigmas(J_b, J_m, H_bb, H_bm) -> np.ndarray:
    """sigma_min of ``J* = J_m - J_b H_bb^-1 H_bm`` for a stack of states at once: the numbers
    :meth:`~ffsm_pin.model.state.State.generalized_jacobian` and an SVD give state by state,
    bit for bit (numpy's stacked ``solve``, ``matmul`` and ``svd`` run the same LAPACK/BLAS
    call per matrix).

    Parameters
    ----------
    J_b : ndarray, shape (r, n_task, m3)
        The task rows of ``State.J_b``, per state.
    J_m : ndarray, shape (r, n_task, n)
        The task rows of ``State.J_m``.
    H_bb : ndarray, shape (r, m3, m3)
        ``State.H_bb``.
    H_bm : ndarray, shape (r, m3, n)
        ``State.H_bm``.

    Returns
    -------
    ndarray, shape (r,)
        sigma_min per state [m].
    """
    J_star = J_m - J_b @ np.linalg.solve(H_bb, H_bm)
    return np.linalg.svd(J_star, compute_uv=False)[:, -1]


@fill_doc(SWEEP_DOC)
def sigmas_gjm(setup, signals, rows: np.ndarray) -> np.ndarray:
    """sigma_min of the true model's generalized Jacobian (task rows, ``setup.robot``) at each
    of the recorded ``rows`` (at least one) of ``signals`` (q, v), bit for bit: the states'
    kinematics only (:meth:`~ffsm_pin.model.state.State.update_kinematics`), their sigmas at
    once (:func:`generalized_jacobian_sigmas`).

    %(params_case_rows)s

    Returns
    -------
    ndarray, shape (len(rows),)
        sigma_min per row [m].
    """
    from ..model.state import State

    state, n = State(setup.robot), setup.n_task
    q, v = np.asarray(signals["q"][rows]), np.asarray(signals["v"][rows])
    blocks: tuple[list[np.ndarray], ...] = ([], [], [], [])
    for a, b in zip(q, v, strict=True):
        st = state.update_kinematics(a, b)
        for block, x in zip(blocks, (st.J_b[:n], st.J_m[:n], st.H_bb, st.H_bm), strict=True):
            block.append(x)
    return generalized_jacobian_sigmas(*(np.stack(b) for b in blocks))


@fill_doc(SWEEP_DOC)
def min_sigma_gjm(setup, signals, rows: np.ndarray) -> float | None:
    """The smallest singular value of the true model's generalized Jacobian (task rows,
    ``setup.robot``) over the recorded ``rows`` of ``signals`` (q, v) (:func:`sigmas_gjm`);
    None without rows.

    %(params_case_rows)s

    Returns
    -------
    float or None
        The smallest sigma_min [m].
    """
    if len(rows) == 0:
        return None
    return min(sigmas_gjm(setup, signals, rows).tolist())  # min() row by row: NaN as before


def case_extras(setup, result, summary: dict[str, Any]) -> dict[str, Any]:
    """The entries a case adds to its outcome (module docstring); ``SIGNALS`` holds the
    decimated signals ``{"t": (r,), key: (r, ...)}``.

    Parameters
    ----------
    setup : Setup
        The case's setup.
    result : RunResult
        Its run.
    summary : dict
        The run's summary.

    Returns
    -------
    dict
        The entries added to the outcome.
    """
    s = result.signals
    rows = kept_rows(len(s["t"]))
    kept = {"t": np.asarray(s["t"][rows], dtype=float)}
    for key in SIGNAL_KEYS:
        source = key if key in s else "u_m" if key == "u_cmd" else None  # (older recordings)
        if source is not None:
            kept[key] = np.asarray(s[source][rows], dtype=float).reshape(len(rows), -1)
    limits = None
    if setup.actuators is not None and np.any(np.isfinite(setup.actuators.limit)):
        limits = [float(x) if np.isfinite(x) else None for x in setup.actuators.limit]
    return {
        "saturation_per_joint": summary.get("saturation_per_joint"),
        "joint_torque_limits": limits,
        "min_sigma_gjm": min_sigma_gjm(setup, s, rows),
        SIGNALS: kept,
        **(
            {} if "impact_impulse" not in summary else {"impact_impulse": summary["impact_impulse"]}
        ),
    }
