"""Plant benchmarks: cost of one ``Plant.step`` and open-loop accuracy per integrator and dt.

1. Paper robot (planar root, ``ffsm_planar4.urdf``), Table 2 state: ``Plant.step`` with the
   semi-implicit step (with and without the momentum projection) and with RK4, next to the
   baseline of bare ``pin.aba`` + ``pin.computeCentroidalMap`` called from Python.
2. The same rows for xArm7 (example-robot-data) on a 100 kg satellite, free-flyer root, zero
   gravity. Target: semi-implicit ``Plant.step`` <= 2x the baseline.
3. SPARTpy (optional, ``pip install ".[bench]"``): ``Plant.acceleration`` against SPART's forward
   dynamics on SPARTpy's own 7-DOF URDF (gate 1e-9), and its cost next to SPART's ODE.
4. Open-loop accuracy: 5 s replays of a recorded torque sequence (250 Hz, held) on a random
   7-joint spatial chain and on the xArm7 satellite, the plant at dt = 4 ms / N (N substeps)
   against MuJoCo's dynamics of the same URDF integrated with a classical RK4 on MuJoCo's own
   coordinates at 1/16 ms (tests/sim/spatial_chain.py, shared with the tests). Errors: base
   position [m], base attitude [rad], joints [rad]; ``--plot FILE`` draws them against dt.

    python benchmarks/bench_plant.py [--repeat N] [--target-ms T] [--no-accuracy] [--plot FILE]

Exit status 1 if a gated check fails (momentum, SPARTpy agreement, the 2x speed target).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import platform
import sys
import time
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
from _timing import time_interleaved
from bench_model import (
    Bench,
    SpartRig,
    erd_urdf,
    fold_fixed_leaves,
    paper_state,
    rel_err,
    spart_states,
)

from ffsm_pin.robot import UrdfWarning, add_missing_limits, load_robot
from ffsm_pin.sim.plant import Plant

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "sim"))
from spatial_chain import (  # noqa: E402  (the tests' chain, MuJoCo model and reference)
    held_torques,
    mujoco_acceleration,
    mujoco_model,
    pinocchio_model,
    plant_replay,
    pose_error,
    quaternion_rk4_replay,
    random_state,
    spatial_chain_urdf,
)

DT = 1e-3  # plant step for the timing rows [s]
SPEED_TARGET = 2.0  # semi-implicit Plant.step / (pin.aba + pin.computeCentroidalMap)
PERIOD, DURATION = 4e-3, 5.0  # recorded torques: one sample per 4 ms (250 Hz), 5 s
SUBSTEPS = (1, 2, 4, 8, 16)  # plant dt = PERIOD / N: 4 ms .. 0.25 ms
REF_SUBSTEPS = 64  # reference dt = PERIOD / 64 = 6.25e-5 s


# ---------------------------------------------------------------------------- robots
def xarm7_on_satellite() -> str:
    """xArm7's URDF without meshes, its massless root link ``world`` replaced by a 100 kg
    satellite (inertia diag(12, 14, 10) kg m^2) carrying the arm at its origin."""
    root = ET.fromstring(erd_urdf("xarm_description/urdf/xarm7.urdf").read_text())
    for link in root.findall("link"):
        for tag in ("visual", "collision"):
            for e in link.findall(tag):
                link.remove(e)
        if link.get("name") == "world":
            link.set("name", "satellite")
            ET.SubElement(link, "inertial").extend(
                [
                    ET.Element("origin", xyz="0 0 -0.5", rpy="0 0 0"),
                    ET.Element("mass", value="100"),
                    ET.Element("inertia", ixx="12", ixy="0", ixz="0", iyy="14", iyz="0", izz="10"),
                ]
            )
    for parent in root.iter("parent"):
        if parent.get("link") == "world":
            parent.set("link", "satellite")
    return ET.tostring(root, encoding="unicode")


def plant_rows(b: Bench, tag: str, model: pin.Model, q, v, u_m) -> None:
    """Timing rows of one robot; the baseline row is ``{tag}_base``."""
    data = model.createData()
    tau = np.zeros(model.nv)
    nb = model.nv - len(u_m)
    tau[nb:] = u_m
    semi = Plant(model)
    bare = Plant(model, project_momentum=False)
    rk4 = Plant(model, integrator="rk4")
    for p in (semi, bare, rk4):
        p.reset(q, v)
    h0 = np.abs(semi.momentum0).max()
    drift = {
        name: np.abs(p.momentum(*p.step(q, v, u_m, DT)[:2]) - p.momentum0).max() / h0
        for name, p in (("semi", semi), ("bare", bare), ("rk4", rk4))
    }

    def base():
        pin.aba(model, data, q, v, tau)
        pin.computeCentroidalMap(model, data, q)

    b.add(f"{tag}_base", "pin.aba + pin.computeCentroidalMap (Python)", base, ref=f"{tag}_base")
    b.add(f"{tag}_aba", "  pin.aba alone", lambda: pin.aba(model, data, q, v, tau), f"{tag}_base")
    b.add(
        f"{tag}_semi",
        "Plant.step semi-implicit (projection)",
        lambda: semi.step(q, v, u_m, DT),
        ref=f"{tag}_base",
        check=f"|dh|/|h| {b.gate(f'{tag}: projected step momentum', drift['semi'], 1e-12)}",
    )
    b.add(
        f"{tag}_bare",
        "Plant.step semi-implicit, no projection",
        lambda: bare.step(q, v, u_m, DT),
        ref=f"{tag}_base",
        check=f"|dh|/|h| {drift['bare']:.1e} (1 step)",
    )
    b.add(
        f"{tag}_rk4",
        "Plant.step rk4 (projection)",
        lambda: rk4.step(q, v, u_m, DT),
        ref=f"{tag}_base",
        check=f"|dh|/|h| {b.gate(f'{tag}: rk4 step momentum', drift['rk4'], 1e-12)}",
    )


def bench_paper(b: Bench) -> None:
    robot = load_robot("ffsm_planar4.urdf")
    q, v = paper_state(robot)
    b.section(
        f"1. Paper robot ffsm_planar4 (planar root, nq {robot.model.nq}, nv {robot.model.nv})"
    )
    plant_rows(b, "planar", robot.model, q, v, np.array([2.0, -1.0, 0.5, -0.25]))


def bench_xarm(b: Bench) -> None:
    model = pinocchio_model(xarm7_on_satellite())
    arm = [model.joints[j].shortname() for j in range(2, model.njoints)]
    assert len(arm) == 7 and all(s.startswith("JointModelR") for s in arm), arm
    g = np.random.default_rng(3)
    q, v = random_state(model, g)
    b.section(
        f"2. xArm7 (example-robot-data) on a 100 kg satellite, free-flyer root "
        f"(nq {model.nq}, nv {model.nv})"
    )
    plant_rows(b, "ff", model, q, v, g.normal(scale=5.0, size=7))


def bench_spart(b: Bench) -> None:
    try:
        import SPARTpy  # noqa: PLC0415
    except ImportError:
        b.section("3. SPARTpy: not installed (pip install spartpy), skipped")
        return
    urdf = Path(SPARTpy.__file__).parent / "urdf" / "floating_7dof_manipulator.urdf"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UrdfWarning)
        text = add_missing_limits(urdf.read_text(), urdf.name)
    with contextlib.redirect_stdout(io.StringIO()):  # SPARTpy may compile its C code
        shipped = SpartRig(text, "as shipped")
        rig = SpartRig(fold_fixed_leaves(text, shipped.model), "fixed EE link folded")
    plant = Plant(rig.model)
    states = spart_states(rig.model, 8, seed=11)
    err = 0.0
    for q, v, taum in states:
        a = SpartRig.to_spart_accel(q, v, plant.acceleration(q, v, taum))
        err = max(err, rel_err(a, np.concatenate(rig.spart_fd(*rig.spart_inputs(q, v), taum))))
    b.section(
        f"3. SPARTpy vs Plant.acceleration: {urdf.name}, fixed end-effector link folded "
        f"(see bench_model.py row 5), {len(states)} random states"
    )
    q, v, taum = states[0]
    inp = rig.spart_inputs(q, v)
    _, y, tau = rig.ode_inputs(*inp, taum)
    b.add(
        "sp_plant",
        "Plant.acceleration (ABA)",
        lambda: plant.acceleration(q, v, taum),
        ref="sp_plant",
        check=f"max rel |da| vs SPART FD {b.gate('Plant.acceleration vs SPARTpy FD', err)}",
    )
    b.add(
        "sp_ode",
        "SPARTpy space_robot_ode (one C call)",
        lambda: rig.sp.space_robot_ode(0.0, y, tau),
        ref="sp_plant",
    )


# ---------------------------------------------------------------------------- accuracy
def accuracy(label: str, xml: str, root: str, seed: int, peak: float, per_inertia=False) -> dict:
    """Errors of each integrator at each dt after a 5 s replay vs MuJoCo (see module).
    ``per_inertia``: torques scaled by the joint-space inertia diagonal at the start, so that
    ``peak`` is an angular acceleration [rad/s^2] for every joint (xArm7's wrist link is
    0.17 kg: equal torques would spin it at hundreds of rad/s)."""
    model, mj = pinocchio_model(xml), mujoco_model(xml, root)
    n = model.nv - 6
    q0, v0 = random_state(model, np.random.default_rng(seed), speed=0.2)
    scale = np.diag(pin.crba(model, model.createData(), q0))[6:] if per_inertia else 1.0
    torques = held_torques(n, seed=seed, duration=DURATION, period=PERIOD, peak=peak, scale=scale)
    qacc = mujoco_acceleration(mj)
    q_ref, _ = quaternion_rk4_replay(qacc, q0, v0, torques, PERIOD, REF_SUBSTEPS)
    q_half, _ = quaternion_rk4_replay(qacc, q0, v0, torques, PERIOD, REF_SUBSTEPS // 2)
    out = {"label": label, "n": n, "ref_vs_half": max(pose_error(q_half, q_ref)), "rows": []}
    for integrator in ("semi-implicit", "rk4"):
        for sub in SUBSTEPS:
            t0 = time.perf_counter()
            plant = Plant(model, integrator=integrator)
            q, _, drift = plant_replay(plant, q0, v0, torques, PERIOD, sub)
            wall = time.perf_counter() - t0
            out["rows"].append((integrator, PERIOD / sub, *pose_error(q, q_ref), drift, wall))
    out["moved"] = float(np.abs(q[7:] - q0[7:]).max())
    return out


def print_accuracy(results: list[dict]) -> None:
    print("-" * 110)
    print(
        f"4. Open-loop error after a {DURATION:g} s replay of recorded torques "
        f"({1 / PERIOD:g} Hz, held) vs MuJoCo (quaternion RK4 at {PERIOD / REF_SUBSTEPS:.3g} s)"
    )
    for r in results:
        print("-" * 110)
        print(
            f"{r['label']} ({r['n']} joints; max joint travel {r['moved']:.2f} rad; "
            f"reference vs itself at twice its step: {r['ref_vs_half']:.1e})"
        )
        print(
            f"{'integrator':<14} {'dt [s]':>10} {'base pos [m]':>13} {'attitude [rad]':>15} "
            f"{'joints [rad]':>13} {'rate':>6} {'drift |dh|/|h|':>15} {'wall [s]':>9}"
        )
        prev, prev_integ = None, None
        for integ, dt, dp, dth, dj, drift, wall in r["rows"]:
            err = max(dp, dth, dj)
            rate = f"{prev / err:.1f}" if prev is not None and integ == prev_integ else ""
            print(
                f"{integ:<14} {dt:10.3g} {dp:13.2e} {dth:15.2e} {dj:13.2e} {rate:>6} "
                f"{drift:15.1e} {wall:9.2f}"
            )
            prev, prev_integ = err, integ


def plot(results: list[dict], path: Path) -> None:
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=150)
    styles = {"semi-implicit": "o-", "rk4": "s-"}
    for r, color in zip(results, ("C0", "C1", "C2"), strict=False):
        for integ in ("semi-implicit", "rk4"):
            rows = [x for x in r["rows"] if x[0] == integ]
            dts = [x[1] for x in rows]
            err = [max(x[2:5]) for x in rows]
            ax.loglog(dts, err, styles[integ], color=color, label=f"{r['label']}, {integ}")
    dts = np.array([PERIOD / s for s in SUBSTEPS])
    ax.loglog(dts, 2e-2 * dts / dts[0], "k:", lw=0.8, label="slope 1")
    ax.loglog(dts, 3e-9 * (dts / dts[0]) ** 4, "k--", lw=0.8, label="slope 4")
    floor = max(r["ref_vs_half"] for r in results)
    ax.axhline(floor, color="0.5", lw=0.8, label="reference vs itself (half its dt)")
    ax.set_xticks(dts, [f"{dt * 1e3:g} ms" for dt in dts])
    ax.minorticks_off()
    ax.set_xlabel("plant step dt")
    ax.set_ylabel("max error after 5 s [m, rad]")
    ax.set_title("Open-loop replay vs MuJoCo: error against dt")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    print(f"plot written to {path}")


# ---------------------------------------------------------------------------- output
def print_table(b: Bench, repeat: int, target_ms: float) -> None:
    times = {r.key: r.timing for r in b.rows if r.timing is not None}
    print(
        f"ffsm-pin plant benchmarks: python {platform.python_version()}, "
        f"pinocchio {pin.__version__}, numpy {np.__version__}, {os.cpu_count()} CPU(s)"
    )
    print(
        f"us per call: median [q1-q3] of {repeat} samples of ~{target_ms:g} ms each, "
        "all rows sampled round-robin in this run; ratio = median / median of row 'vs'"
    )
    w = 46
    print("-" * 110)
    print(f"{'row':{w}} {'median':>9} {'q1-q3':>17} {'ratio':>7}  {'vs':<11} check")
    for r in b.rows:
        if r.fn is None:
            print("-" * 110)
            print(r.label)
            continue
        t = r.timing
        ratio = f"{t.median_us / times[r.ref].median_us:.2f}x" if r.ref in times else ""
        iqr = f"{t.q1_us:.2f}-{t.q3_us:.2f}"
        print(f"{r.label:{w}} {t.median_us:9.2f} {iqr:>17} {ratio:>7}  {r.ref:<11} {r.check}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=201, help="samples per row (default 201)")
    ap.add_argument("--target-ms", type=float, default=0.5, help="one sample [ms] (default 0.5)")
    ap.add_argument("--no-accuracy", action="store_true", help="timing rows only")
    ap.add_argument("--plot", type=Path, help="write the error-vs-dt plot (PNG) here")
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    b = Bench()
    bench_paper(b)
    bench_xarm(b)
    bench_spart(b)
    fns = {r.key: r.fn for r in b.rows if r.fn is not None}
    timings = time_interleaved(fns, repeat=args.repeat, target_s=args.target_ms * 1e-3)
    for r in b.rows:
        if r.fn is not None:
            r.timing = timings[r.key]
    print_table(b, args.repeat, args.target_ms)
    # the target on the median ratio; the lower-quartile ratio is printed too because on a
    # shared machine load spikes inflate medians (the quartiles of one row then spread widely)
    med = timings["ff_semi"].median_us / timings["ff_base"].median_us
    low = timings["ff_semi"].q1_us / timings["ff_base"].q1_us
    met = "met" if med <= SPEED_TARGET else "MISSED"
    print("-" * 110)
    print(
        f"xArm7 semi-implicit Plant.step / (pin.aba + pin.computeCentroidalMap): {med:.2f}x "
        f"(medians), {low:.2f}x (lower quartiles); target <= {SPEED_TARGET:g}x: {met}"
    )
    if med > SPEED_TARGET:
        b.failures.append(f"xArm7 Plant.step {med:.2f}x > {SPEED_TARGET:g}x the baseline")
    if not args.no_accuracy:
        results = [
            accuracy("random 7-joint chain", spatial_chain_urdf(7, 3), "base", 3, 2.0),
            accuracy(
                "xArm7 + satellite", xarm7_on_satellite(), "satellite", 5, 1.0, per_inertia=True
            ),
        ]
        print_accuracy(results)
        if args.plot:
            plot(results, args.plot)
    print("-" * 110)
    status = "all checks passed" if not b.failures else "FAILED: " + "; ".join(b.failures)
    print(f"{status} (total {time.perf_counter() - t_start:.1f} s)")
    return 1 if b.failures else 0


if __name__ == "__main__":
    sys.exit(main())
