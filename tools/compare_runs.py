"""Record the built-in cases through the command line and compare two recordings.

Refactors and speed-ups must keep the built-in cases' trajectories: record them before the
change, record them after, compare. The runs go through ``python -m ffsm_pin.sim`` (the
user-facing contract), so the tool works across any internal restructuring.

Usage::

    python tools/compare_runs.py record /tmp/before --rev main   # a revision, exported by git
    python tools/compare_runs.py record /tmp/after               # the package this Python runs
    python tools/compare_runs.py record /tmp/after --cases case1 spatial --record-every 7
    python tools/compare_runs.py record /tmp/old --source ../old-checkout   # any source folder
    python tools/compare_runs.py compare /tmp/before /tmp/after   # bitwise; exit 1 on a difference
    python tools/compare_runs.py compare /tmp/before /tmp/after --rtol 1e-12
    python tools/compare_runs.py compare /tmp/before /tmp/after --allow-added  # new outputs
    python tools/compare_runs.py compare /tmp/before /tmp/after --normwise --rtol 1e-12 --atol 1e-14

``record`` first finds which ``ffsm_pin`` its runs will import, prints it and writes it to
``<out>/source.txt`` (``compare`` prints both), because ``python -m`` puts the current folder
first on the import path: a ``PYTHONPATH`` naming another checkout is shadowed when the
command runs from a checkout's root, and the "before" recording would silently be the
"after" one. ``--source DIR`` runs DIR's package (from DIR), ``--rev REV`` exports the
revision with ``git archive`` to a temporary folder and runs that; a ``PYTHONPATH`` whose
package is shadowed is refused (exit 2) with what to use instead, as is a ``--source`` folder
that holds no package. A ``--rev`` recording compiles its kernels into its temporary folder
(unless ``NUMBA_CACHE_DIR`` is set), so it starts from an empty cache and leaves none behind;
otherwise the runs use the package's own cache (set ``NUMBA_CACHE_DIR`` to an empty folder for
a recording from an empty cache).

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
import io
import json
import os
import subprocess
import sys
import tarfile
import tempfile
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
# what computed a run, not its result: compared apart (a note when they differ, e.g. two
# machines whose OpenBLAS kernels differ, docs/REPRODUCTION.md)
PROVENANCE = {"blas", "versions"}
ROOT = Path(__file__).resolve().parents[1]


class SourceError(Exception):
    """The package a recording would run is not the one asked for."""


def export_revision(rev: str, dest: Path, repo: Path = ROOT) -> Path:
    """``git archive`` of ``rev`` of ``repo``, extracted into ``dest``; returns ``dest``."""
    archive = subprocess.run(
        ["git", "-C", str(repo), "archive", "--format=tar", rev], capture_output=True, check=False
    )
    if archive.returncode != 0:
        raise SourceError(f"git archive {rev}: {archive.stderr.decode().strip()}")
    dest.mkdir(parents=True, exist_ok=True)
    # the "data" filter (no links out of dest, no special files) where this Python has it
    # (3.10.12, 3.11.4 and later); git's own archive needs none of what it refuses
    safe = {"filter": "data"} if hasattr(tarfile, "data_filter") else {}
    try:
        with tarfile.open(fileobj=io.BytesIO(archive.stdout)) as t:
            t.extractall(dest, **safe)
    except (OSError, tarfile.TarError) as exc:
        raise SourceError(f"extracting git archive {rev} into {dest}: {exc}") from None
    return dest


def resolve_revision(rev: str, repo: Path = ROOT) -> str:
    """The full commit hash of ``rev``."""
    found = subprocess.run(
        ["git", "-C", str(repo), "rev-parse", "--verify", f"{rev}^{{commit}}"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    if found.returncode != 0:
        raise SourceError(f"git rev-parse {rev}: {found.stderr.strip()}")
    return found.stdout.strip()


def run_environment(
    source: Path | None, extra: dict[str, str] | None = None
) -> tuple[Path, dict[str, str]]:
    """(folder, environment) the runs start from: ``source`` first on the import path, run
    from ``source`` itself; else this process's folder and environment. ``extra``: variables
    set for the runs unless this process has them (the process's own stay as they are)."""
    env = {**(extra or {}), **os.environ}
    if source is None:
        return Path.cwd(), env
    source = source.resolve()
    env["PYTHONPATH"] = os.pathsep.join(
        [str(source), *filter(None, [os.environ.get("PYTHONPATH")])]
    )
    return source, env


def imported_package(cwd: Path, env: dict[str, str]) -> Path:
    """The folder of the ``ffsm_pin`` that ``python -m ffsm_pin.sim`` would import when run
    from ``cwd`` with ``env`` (``-c``, like ``-m``, puts ``cwd`` first on the path)."""
    code = "import os, ffsm_pin; print(os.path.dirname(os.path.abspath(ffsm_pin.__file__)))"
    found = subprocess.run(
        [sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True,
        check=False,
    )  # fmt: skip
    if found.returncode != 0:
        raise SourceError(f"no ffsm_pin to import from {cwd}: {found.stderr.strip()[-300:]}")
    return Path(found.stdout.strip()).resolve()


def check_asked_for(package: Path, source: Path | None, pythonpath: str) -> None:
    """Refuse runs that would import ``package`` when another was asked for: ``source``'s
    (``--source``, ``--rev``), else the first one on ``pythonpath`` (this process's
    ``PYTHONPATH``, which the current folder shadows for ``python -m``)."""
    if source is not None:
        if package != source.resolve() / "ffsm_pin":
            raise SourceError(
                f"{source} holds no ffsm_pin package: the runs would import {package} instead"
            )
        return
    for entry in filter(None, pythonpath.split(os.pathsep)):
        wanted = (Path(entry) / "ffsm_pin").resolve()
        if (wanted / "__init__.py").exists():
            if wanted != package:
                raise SourceError(
                    f"PYTHONPATH names {wanted}, but the runs would import {package} (the "
                    f"current folder comes first for python -m); record it with --source "
                    f"{wanted.parent} (or --rev REV)"
                )
            return


def record(
    out: Path,
    cases: list[str],
    record_every: int,
    duration: float | None,
    source: Path | None = None,
    label: str = "",
    extra_env: dict[str, str] | None = None,
) -> int:
    """Run each case into ``out/<case>`` with the package of ``source`` (None: the one this
    Python's runs import, see the module docstring); ``label`` is added to its name in
    ``source.txt`` (the revision), ``extra_env`` set for the runs unless this process has
    it (:func:`run_environment`). Returns 1 if a run failed (an exit other than 0, or 3 for
    a run that stopped early), else 0; raises :class:`SourceError` when the package the runs
    would import is not the one asked for."""
    out = out.resolve()
    cwd, env = run_environment(source, extra_env)
    package = imported_package(cwd, env)
    check_asked_for(package, source, os.environ.get("PYTHONPATH", ""))
    out.mkdir(parents=True, exist_ok=True)
    what = f"{package}{label}"
    (out / "source.txt").write_text(f"{what}\n")
    print(f"recording ffsm_pin from {what}")
    for case in cases:
        dur = duration if duration is not None else DEFAULT_CASES.get(case, 1.0)
        cmd = [
            sys.executable, "-m", "ffsm_pin.sim", "--case", case, "--duration", str(dur),
            "--record-every", str(record_every), "--no-plots", "--no-html", "--quiet",
            "--out", str(out / case),
        ]  # fmt: skip
        rc = subprocess.run(cmd, cwd=cwd, env=env, check=False).returncode
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
    for folder in (a, b):
        if (folder / "source.txt").exists():
            print(f"{folder}: ffsm_pin from {(folder / 'source.txt').read_text().strip()}")
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
        notes = [f"{key}: {sa.get(key)!r} vs {sb.get(key)!r}" for key in sorted(PROVENANCE)
                 if sa.get(key) != sb.get(key)]  # fmt: skip
        for key in sorted((set(sa) | set(sb)) - WALL_CLOCK - PROVENANCE):
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
        for note in notes:  # (not a difference of results)
            print(f"{'':22s} computed with other {note}")
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
    where = r.add_mutually_exclusive_group()
    where.add_argument("--source", type=Path, help="a folder holding the ffsm_pin to run")
    where.add_argument("--rev", help="a git revision of this repository to run (git archive)")
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
        try:
            if args.rev is None:
                return record(args.out, args.cases, args.record_every, args.duration, args.source)
            commit = resolve_revision(args.rev)  # then archive that commit, whatever moves
            with tempfile.TemporaryDirectory(prefix="compare-runs-") as tmp:
                source = export_revision(commit, Path(tmp) / "source")
                # the export's kernels compile into the temporary folder, removed with it
                # (numba names cache folders by the source's path: a kept cache of a random
                # path would never be used again); a NUMBA_CACHE_DIR you set wins
                cache = {"NUMBA_CACHE_DIR": str(Path(tmp) / "numba")}
                label = f" (git {args.rev} = {commit})"
                return record(
                    args.out, args.cases, args.record_every, args.duration, source, label, cache
                )
        except SourceError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
    return compare(args.a, args.b, args.rtol, args.allow_added, args.normwise, args.atol)


if __name__ == "__main__":
    sys.exit(main())
