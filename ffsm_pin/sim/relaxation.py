"""When and how long a saturation-aware law relaxed its funnels (``controller.saturation =
"auxiliary"``, docs/saturation.md): the summary's ``funnel_relaxed_time``, ``first_relaxed_t``
and ``last_relaxed_t``, from the recorded auxiliary states ``ctrl_chi_b``, ``ctrl_chi_z``.

A recorded row is *relaxed* when some component of chi_b or chi_z exceeds
:data:`RELAXED_FRACTION` of its funnel's final width rho_inf: the law then transforms
``e - chi`` instead of the error e, and chi, which decays exponentially once the saturation
ends, counts as gone when it is that small against the narrowest funnel. Whether the errors
themselves stayed inside the prescribed funnels is judged as for every run (``funnel_ok_b``,
``funnel_ok_z``, on the recorded errors, not the relaxed ones): a relaxation that let an error
beyond its funnel is not kept.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

import numpy as np

#: The recorded auxiliary states (the controller's signals chi_b, chi_z).
CHI_SIGNALS = ("ctrl_chi_b", "ctrl_chi_z")
#: A chi component counts as a relaxation above this fraction of its funnel's rho_inf.
RELAXED_FRACTION = 0.01
#: The summary keys (None for a run without the auxiliary system).
RELAXED_KEYS = ("funnel_relaxed_time", "first_relaxed_t", "last_relaxed_t")


def relaxation_summary(
    names: Iterable[str],
    blocks: Callable[[list[str]], Iterator[dict[str, np.ndarray]]],
    rhoinf: tuple,
) -> dict[str, float | None]:
    """The relaxed time [s] (the recorded rows' spacing per relaxed row) and the first and last
    relaxed recorded times [s]; None each when the run recorded no chi; 0.0 and None, None
    when it never relaxed.

    Parameters
    ----------
    names : iterable of str
        The recorded signals' names.
    blocks : callable
        ``blocks(keys)`` yields consecutive row blocks of those signals
        (:meth:`~ffsm_pin.sim.result.RunResult.signals_blocks`).
    rhoinf : tuple
        rho_inf of the attitude and the task funnels (per component, or None: 1).

    Returns
    -------
    dict
        :data:`RELAXED_KEYS` to their values.
    """
    names = set(names)
    keys = [k for k in CHI_SIGNALS if k in names]
    tol = {k: RELAXED_FRACTION * np.asarray(1.0 if r is None else r, dtype=float)
           for k, r in zip(CHI_SIGNALS, rhoinf, strict=True)}  # fmt: skip
    out: dict[str, float | None] = dict.fromkeys(RELAXED_KEYS)
    if not keys:
        return out
    spacing, parts = 0.0, []
    for b in blocks(["t", *keys]):
        t = np.asarray(b["t"])
        if spacing == 0.0 and t.size > 1:  # the recorded rows' spacing [s]
            spacing = float(t[1] - t[0])
        parts.append(t[_relaxed(b, tol, keys)])
    relaxed = np.concatenate(parts) if parts else np.empty(0)
    out["funnel_relaxed_time"] = relaxed.size * spacing
    if relaxed.size:
        out["first_relaxed_t"], out["last_relaxed_t"] = float(relaxed[0]), float(relaxed[-1])
    return out


def _relaxed(block: dict[str, np.ndarray], tol: dict, keys: list[str]) -> np.ndarray:
    """Per row of ``block``: some chi component beyond its tolerance."""
    rows = len(block["t"])
    flags = np.zeros(rows, dtype=bool)
    for k in keys:
        flags |= np.any(np.abs(np.asarray(block[k]).reshape(rows, -1)) > tol[k], axis=1)
    return flags


__all__ = ["CHI_SIGNALS", "RELAXED_FRACTION", "RELAXED_KEYS", "relaxation_summary"]
