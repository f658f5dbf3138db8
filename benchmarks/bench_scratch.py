"""Whether a controller's compiled period computes with uninitialised scratch memory.

A compiled kernel's ``np.empty`` scratch holds whatever the allocator hands back: the bytes of
an array freed before. Arithmetic on entries it never writes does not change a result when
those entries are dead (computed, then not used), but it costs time when the leftover bytes are
subnormal numbers: each operation on a subnormal takes a microcode assist of about a hundred
cycles on x86. The cost then depends on what the process freed before, so it differs from
run to run (on this machine the spatial period cost 57 to 120 us in different processes
until the velocity regressors stopped computing terms of a vector they were not asked for;
benchmarks/README.md, "Uninitialised scratch").

This benchmark makes that visible on purpose. It compiles a small C shim of ``malloc`` (with
the system's C compiler, ``cc``; without one it says so and stops) that fills every block it
hands out with either zeros or the smallest subnormal number (``5e-324``), and runs itself in
child processes with the shim preloaded (``LD_PRELOAD``, Linux): each child replays the exact
measurements of a built-in case's run through a controller prepared afresh (as
``bench_period_call.py``) and prints the us per period. Children of the two fills alternate,
round after round, so a change of machine load hits both; they compile into a numba cache of
their own (the first child, without the shim, fills it; the folder is removed at the end).
Printed per case and controller: the median us per period of each fill and their ratio with
the per-round quartiles. A ratio near 1 says no period computes with scratch it did not write;
well above 1 names a case and controller to look at (the fill itself costs both rows the
same).

Usage::

    python benchmarks/bench_scratch.py                       # case1, spatial-realistic x 3
    python benchmarks/bench_scratch.py --cases spatial --controllers lu-jia --repeat 9
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import checkout  # noqa: E402

import ffsm_pin  # noqa: E402
from ffsm_pin.control.interface import split_reply  # noqa: E402
from ffsm_pin.scenario.file import builtin_scenario  # noqa: E402
from ffsm_pin.sim.loop import simulate  # noqa: E402
from ffsm_pin.sim.measurement import Sensor  # noqa: E402
from ffsm_pin.sim.setup import prepare  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: FILL_MODE of the shim per row: 2 fills every allocation with zeros, 1 with 5e-324
FILLS = {"zeros": "2", "subnormal": "1"}
SHIM = r"""
#define _GNU_SOURCE
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
extern void *__libc_malloc(size_t);
static int mode = -1;
void *malloc(size_t n) {
    void *p = __libc_malloc(n);
    if (mode < 0) { char *e = getenv("FILL_MODE"); mode = e ? atoi(e) : 0; }
    if (p && mode && n >= 64 && n < (1 << 20)) {
        uint64_t v = mode == 1 ? 1ULL : 0ULL;
        uint64_t *q = (uint64_t *)p;
        for (size_t i = 0; i < n / 8; i++) q[i] = v;
    }
    return p;
}
"""


def build_shim(folder: Path) -> Path | None:
    """The shim compiled into ``folder`` (a shared library), or None without a C compiler."""
    source, library = folder / "fill.c", folder / "fill.so"
    source.write_text(SHIM)
    try:
        subprocess.run(["cc", "-O2", "-shared", "-fPIC", "-o", str(library), str(source)],
                       check=True, capture_output=True)  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return None
    return library


def measurements(scenario) -> list:
    """The exact measurement of every state of a run of ``scenario`` (copies)."""
    setup = prepare(scenario)
    signals = simulate(setup).signals
    full_model = bool(getattr(setup.controller, "needs_dynamics", False))  # (as the loop)
    sensor = Sensor(setup.robot, setup.model, full_model=full_model)
    q, v, t = signals["q"], signals["v"], signals["t"]
    return [sensor.measure(float(t[k]), q[k].copy(), v[k].copy()) for k in range(len(t))]


def replay(scenario, metas: list) -> float:
    """Seconds per period of one replay of ``metas`` through a fresh controller."""
    controller = prepare(scenario).controller
    t0 = time.perf_counter()
    for meas in metas:
        split_reply(controller.step(meas))
    return (time.perf_counter() - t0) / len(metas)


def scenario_of(case: str, kind: str, duration: float):
    """Built-in ``case`` run by controller type ``kind`` for ``duration`` [s]."""
    base = builtin_scenario(case)
    controller = dataclasses.replace(base.controller, type=kind)
    return dataclasses.replace(base, duration=duration, controller=controller)


def child(pairs: list[str], duration: float) -> None:
    """Print the seconds per period of each ``case:controller`` in ``pairs`` (one line each),
    after an untimed warm-up replay."""
    for pair in pairs:
        case, kind = pair.split(":")
        scenario = scenario_of(case, kind, duration)
        metas = measurements(scenario)
        replay(scenario, metas[:20])
        print(pair, replay(scenario, metas), flush=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=["case1", "spatial-realistic"])
    parser.add_argument("--controllers", nargs="+", default=["lu-jia", "gjm-ct", "adaptive-ct"])
    parser.add_argument("--duration", type=float, default=1.0, help="replayed seconds")
    parser.add_argument("--repeat", type=int, default=3, help="timed rounds (default 3)")
    parser.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.duration)
        return 0
    package = Path(ffsm_pin.__file__).resolve().parent
    here = f"{checkout(ROOT)}, " if package.parent == ROOT else ""
    print(f"ffsm-pin scratch benchmark: {here}ffsm_pin from {package}, "
          f"python {sys.version.split()[0]}")  # fmt: skip
    pairs = [f"{case}:{kind}" for case in args.cases for kind in args.controllers]
    with tempfile.TemporaryDirectory() as folder:
        shim = build_shim(Path(folder))
        if shim is None:
            print("no C compiler (cc): the shim cannot be built; nothing measured")
            return 1
        print("us per period (controller.step): median over rounds, each row a child process "
              "per round; ratio = subnormal / zeros (per-round q1 .. q3)")  # fmt: skip
        times: dict[str, dict[str, list[float]]] = {p: {row: [] for row in FILLS} for p in pairs}
        cmd = [sys.executable, __file__, "--duration", str(args.duration), "--child", *pairs]
        # the children compile into a cache of their own, first without the shim: a compiler
        # run under the shim could write its filled memory into cache files, and the user's
        # cache must not hold anything this benchmark made
        cache = {**os.environ, "NUMBA_CACHE_DIR": str(Path(folder) / "numba")}
        subprocess.run(cmd, env=cache, check=True, capture_output=True, text=True)
        for _ in range(args.repeat):
            for row, mode in FILLS.items():
                env = {**cache, "LD_PRELOAD": str(shim), "FILL_MODE": mode}
                out = subprocess.run(cmd, env=env, check=True, capture_output=True, text=True)
                for line in out.stdout.splitlines():
                    pair, seconds = line.split()
                    times[pair][row].append(float(seconds))
    for pair in pairs:
        zeros, sub = (statistics.median(times[pair][row]) for row in FILLS)
        ratios = [
            b / a for a, b in zip(times[pair]["zeros"], times[pair]["subnormal"], strict=True)
        ]
        q = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else [ratios[0]] * 3
        print(f"{pair:32s} zeros {zeros * 1e6:7.2f}  subnormal {sub * 1e6:7.2f}  "
              f"ratio {sub / zeros:.3f} ({q[0]:.3f} .. {q[2]:.3f})", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
