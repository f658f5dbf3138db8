"""Record the built-in cases through the command line and compare two recordings.

Refactors and speed-ups must keep the built-in cases' trajectories: record them before the
change, record them after, compare. The runs go through ``python -m ffsm_pin.sim`` (the
user-facing contract), so the tool works across any internal restructuring.

Usage::

    python tools/compare_runs.py record /tmp/before              # every built-in case, short runs
    python tools/compare_runs.py record /tmp/after --cases case1 spatial --record-every 7
    python tools/compare_runs.py compare /tmp/before /tmp/after   # bitwise; exit 1 on a difference
    python tools/compare_runs.py compare /tmp/before /tmp/after --rtol 1e-12
    python tools/compare_runs.py compare /tmp/before /tmp/after --allow-added  # new outputs
    python tools/compare_runs.py compare /tmp/before /tmp/after --normwise --rtol 1e-12 --atol 1e-14

``compare`` checks every key of every ``trajectory.npz`` (same keys, shapes, dtypes; the same
bytes: equal values that differ only in a zero's sign or a NaN's payload are reported apart)
and every ``summary.json`` value except the wall-clock ones. ``--rtol`` is elementwise by
default (each entry against the larger of its two values); with ``--normwise`` each signal's
largest difference is taken against its largest magnitude (an entry crossing zero is then no
failure) and ``--atol`` [the signal's unit] is allowed besides (for signals that are rounding
noise around zero, as the conserved momentum P, L of a run that starts at rest). What tolerance
a case can be held to at all: ``tools/rounding_sensitivity.py``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

# short runs that still cover every scheme, both geometries, the null space and the stops
DEFAULT_CASES = {
    "1": 3.0,
    "1-paper": 3.0,
    "2": 3.0,
    "3": 3.0,
    "known-model": 3.0,
    "planar5": 3.0,
    "spatial": 1.0,
    "spatial-known-model": 1.0,
    "spatial-no-ppc": 1.0,
    "spatial-no-attitude": 1.0,
    "spatial-pose": 1.0,
    "spatial-realistic": 1.0,
}
WALL_CLOCK = {"wall_time_s", "steps_per_s"}


def record(out: Path, cases: list[str], record_every: int, duration: float | None) -> int:
    """Run each case into ``out/<case>``; return the number of runs that exited with 3 or less."""
    out.mkdir(parents=True, exist_ok=True)
    for case in cases:
        dur = duration if duration is not None else DEFAULT_CASES.get(case, 1.0)
        cmd = [
            sys.executable, "-m", "ffsm_pin.sim", "--case", case, "--duration", str(dur),
            "--record-every", str(record_every), "--no-plots", "--no-html", "--quiet",
            "--out", str(out / case),
        ]  # fmt: skip
        rc = subprocess.run(cmd, check=False).returncode
        print(f"{case:22s} {dur:5.1f} s  exit {rc}")
        if rc not in (0, 3):  # 3: a run that stops early is a result too
            return 1
    return 0


def _diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a - b| entrywise: 0 where both are NaN, inf where only one is (a NaN against a number
    is a difference, which nanmax would otherwise skip)."""
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    diff = np.where(nan_a & nan_b, 0.0, np.abs(a - b))
    return np.where(nan_a ^ nan_b, np.inf, diff)


def _max_rel(a: np.ndarray, b: np.ndarray) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    diff = _diff(a, b)
    scale = np.maximum(np.abs(a), np.abs(b))
    scale = np.where(scale > 0, scale, 1.0)
    return float(np.nanmax(diff / scale)) if diff.size else 0.0


def _normwise(a: np.ndarray, b: np.ndarray, atol: float) -> float:
    """max |a - b| beyond ``atol`` over max |a|, NaN equal to NaN."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    both_nan = np.isnan(a) & np.isnan(b)
    diff = _diff(a, b)
    if not diff.size:
        return 0.0
    excess = max(float(np.nanmax(diff)) - atol, 0.0)
    scale = float(np.nanmax(np.where(both_nan, 0.0, np.abs(a))))
    return excess / scale if scale > 0 else (0.0 if excess == 0 else float("inf"))


def compare(
    a: Path,
    b: Path,
    rtol: float,
    allow_added: bool = False,
    normwise: bool = False,
    atol: float = 0.0,
) -> int:
    """Print one line per case; return 1 when anything differs beyond ``rtol``.

    With ``allow_added``, keys (trajectory or summary) only in ``b`` are listed, not failures:
    a change that adds outputs keeps every existing one.
    """
    bad = 0
    cases = sorted(p.name for p in a.iterdir() if (p / "trajectory.npz").exists())
    for case in cases:
        if not (b / case / "trajectory.npz").exists():
            print(f"{case:22s} MISSING in {b}")
            bad = 1
            continue
        ta, tb = np.load(a / case / "trajectory.npz"), np.load(b / case / "trajectory.npz")
        problems, worst, added, identical, zeros = [], 0.0, [], True, []
        if allow_added:
            added = sorted(set(tb.files) - set(ta.files))
        if set(ta.files) | set(added) != set(tb.files):
            problems.append(f"keys differ: {sorted(set(ta.files) ^ set(tb.files))}")
        for key in sorted(set(ta.files) & set(tb.files)):
            x, y = ta[key], tb[key]
            if x.shape != y.shape or x.dtype != y.dtype:
                problems.append(f"{key}: {x.shape} {x.dtype} vs {y.shape} {y.dtype}")
            elif not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
                identical = False
                rel = _normwise(x, y, atol) if normwise else _max_rel(x, y)
                worst = max(worst, rel)
                if rel > rtol:
                    problems.append(f"{key}: max rel diff {rel:.3g}")
            elif x.tobytes() != y.tobytes():  # equal values, other bits: -0.0, NaN payloads
                identical = False
                zeros.append(key)
        sa = json.loads((a / case / "summary.json").read_text())
        sb = json.loads((b / case / "summary.json").read_text())
        for key in sorted((set(sa) | set(sb)) - WALL_CLOCK):
            if allow_added and key not in sa:
                added.append(f"summary.{key}")
            elif key not in sa or key not in sb:
                problems.append(f"summary.{key} only in one")
            elif sa[key] != sb[key]:
                identical = False
                if not _close(sa[key], sb[key], rtol, normwise, atol):
                    problems.append(f"summary.{key}: {sa[key]!r} vs {sb[key]!r}")
        verdict = "bitwise equal" if identical else f"within tolerance, max rel {worst:.3g}"
        if not identical and worst == 0.0 and zeros:
            verdict = f"equal values; bits differ only in signed zeros / NaN payloads of {zeros}"
        verdict += f" (added: {', '.join(added)})" if added else ""
        print(f"{case:22s} {'DIFFERS: ' + '; '.join(problems) if problems else verdict}")
        bad |= bool(problems)
    return int(bad)


def _close(x, y, rtol: float, normwise: bool = False, atol: float = 0.0) -> bool:
    try:
        x, y = np.asarray(x, float), np.asarray(y, float)
        rel = _normwise(x, y, atol) if normwise else _max_rel(x, y)
        return (rtol > 0 or atol > 0) and rel <= rtol
    except (TypeError, ValueError):
        return False


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record", help="run the built-in cases into a folder")
    r.add_argument("out", type=Path)
    r.add_argument("--cases", nargs="+", default=list(DEFAULT_CASES))
    r.add_argument("--record-every", type=int, default=1)
    r.add_argument("--duration", type=float, help="one duration for every case [s]")
    c = sub.add_parser("compare", help="compare two recordings")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    c.add_argument("--rtol", type=float, default=0.0, help="0 = bitwise (default)")
    c.add_argument("--allow-added", action="store_true", help="keys only in b are no failure")
    c.add_argument(
        "--normwise",
        action="store_true",
        help="each signal's largest difference against its largest magnitude",
    )
    c.add_argument("--atol", type=float, default=0.0,
                   help="with --normwise: an absolute difference allowed besides")  # fmt: skip
    args = p.parse_args(argv)
    if args.cmd == "record":
        return record(args.out, args.cases, args.record_every, args.duration)
    return compare(args.a, args.b, args.rtol, args.allow_added, args.normwise, args.atol)


if __name__ == "__main__":
    sys.exit(main())
