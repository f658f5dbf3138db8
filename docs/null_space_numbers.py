"""Numbers of docs/null_space.md: the null-space option on the shipped 5-link planar robot.

Runs the built-in scenario ``planar5`` (``ffsm_pin/scenario/builtin/planar5.toml``: perturbed
estimates, spread 0.3) for every seed and every objective, and prints one table row per
(objective, gain, seed; seed -1 = the true parameters): whether the run completed with both
funnels kept, max |u_m| [N m] (Euclidean norm of the joint torques, as in ``summary.json``),
the smallest sigma_min of the estimated J_m-hat U-hat the controller used [m], the smallest
singular value of the *true* J_m U along the same trajectory [m], and the time spent with
damping active [s]. Then a summary per objective and gain (median and worst over seeds 0-7).

    python docs/null_space_numbers.py                       # true + 8 seeds, 30 s, all objectives
    python docs/null_space_numbers.py --seeds 0 1 --duration 10 --objectives none manipulability
    python docs/null_space_numbers.py --gain 1 10 30 --objectives manipulability joint-centering
    python docs/null_space_numbers.py --joints 0.8 -0.8 0.8 -0.8 0.8   # another initial shape

Runs in parallel processes (``--workers``, default 2).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from ffsm_pin.control.null_space import NullSpace  # noqa: E402
from ffsm_pin.model.state import State as FloatingBaseState  # noqa: E402
from ffsm_pin.robot import load_robot  # noqa: E402
from ffsm_pin.scenario.file import builtin_path, load_scenario  # noqa: E402
from ffsm_pin.scenario.spec import Estimates, Reference  # noqa: E402
from ffsm_pin.sim.run import initial_state, prepare, simulate  # noqa: E402

# Gains k_s chosen in docs/null_space.md (section "Gain").
DEFAULT_GAINS = {"none": 0.0, "manipulability": 1.0, "joint-centering": 1.0}


def planar5(joints=None):
    """The built-in scenario, with the repository's urdf/ folder (so that the script also
    runs from a checkout in which ``ffsm_pin.urdf`` is installed from elsewhere).

    ``joints``: another initial arm shape [rad]; the reference circle is then re-centred on
    the end effector's initial pose, as in the shipped file."""
    sc = load_scenario(builtin_path("planar5"))
    urdf = REPO / "urdf" / "ffsm_planar5.urdf"
    if urdf.is_file():
        sc = dataclasses.replace(sc, robot=dataclasses.replace(sc.robot, urdf=str(urdf)))
    if joints is not None:
        init = dataclasses.replace(sc.initial, joints=tuple(joints))
        robot = load_robot(sc.robot.urdf, relative_to=sc.robot.relative_to)
        z0 = FloatingBaseState(robot).update(*initial_state(robot, init)).ee_pose
        ee = tuple(
            dataclasses.replace(comp, c=float(z0[i])) for i, comp in enumerate(sc.reference.ee)
        )
        ref = Reference(ee=ee, base_attitude=sc.reference.base_attitude)
        sc = dataclasses.replace(sc, initial=init, reference=ref)
    return sc


def one_run(job):
    objective, gain, seed, duration, every, joints = job
    sc = planar5(joints)
    c = sc.controller
    c = dataclasses.replace(
        c,
        estimates=(
            Estimates(initial="true") if seed < 0 else dataclasses.replace(c.estimates, seed=seed)
        ),
        lu_jia=dataclasses.replace(c.lu_jia, null_space=NullSpace(objective=objective, gain=gain)),
    )
    sc = dataclasses.replace(sc, controller=c, duration=duration)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare(sc)
        res = simulate(setup)
    wall = time.perf_counter() - t0
    m = setup.model
    sig_true = []
    for q_b, q_m in zip(res["q_b"][::every, 0], res["q"][::every, 4:], strict=True):
        A = m.jacobians(setup.theta_z, float(q_b), q_m)[1]
        H_bm = m.momentum_matrices(setup.theta_b, float(q_b), q_m)[1]
        U = np.eye(m.n_joints) - H_bm.T @ H_bm / (H_bm @ H_bm.T)[0, 0]
        sig_true.append(np.linalg.svd(A @ U, compute_uv=False)[-1])
    dt = sc.dt
    return {
        "objective": objective,
        "gain": gain,
        "seed": seed,
        "kept": bool(res.completed and res.funnel_inside_b.all() and res.funnel_inside_z.all()),
        "t_end": float(res["t"][-1]),
        "stop": res.stop_reason or "",
        "max_u": float(np.max(np.linalg.norm(res["u_m"], axis=1))),  # as in summary.json
        "min_sigma_hat": float(np.min(res["sigma_min"])),
        "min_sigma_true": float(np.min(sig_true)),
        "damped_s": float(np.count_nonzero(res["damping"] > 0) * dt),
        "wall_s": wall,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--seeds", type=int, nargs="+", default=list(range(-1, 8)), help="-1: true parameters"
    )
    ap.add_argument("--duration", type=float, default=30.0)
    ap.add_argument(
        "--objectives", nargs="+", default=["none", "manipulability", "joint-centering"]
    )
    ap.add_argument(
        "--gain", type=float, nargs="+", default=None, help="k_s values (each objective, each)"
    )
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument(
        "--joints", type=float, nargs=5, default=None, help="another initial shape [rad]"
    )
    args = ap.parse_args(argv)
    jobs = [
        (obj, g, s, args.duration, 10, args.joints)
        for obj in args.objectives
        for g in ([DEFAULT_GAINS[obj]] if args.gain is None or obj == "none" else args.gain)
        for s in args.seeds
    ]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(one_run, jobs))
    head = (
        f"{'objective':16s} {'k_s':>6s} {'seed':>4s} {'funnels':>8s} {'max|u_m|':>9s} "
        f"{'min sig^':>9s} {'min sig':>9s} {'damped':>7s}"
    )
    print("seed -1 = the true parameters (not counted in the summary below the table)")
    print(head)
    print("-" * len(head))
    for r in rows:
        kept = "kept" if r["kept"] else f"{r['t_end']:.1f}s"
        print(
            f"{r['objective']:16s} {r['gain']:6.3g} {r['seed']:4d} {kept:>8s} "
            f"{r['max_u']:9.2f} {r['min_sigma_hat']:9.2e} {r['min_sigma_true']:9.2e} "
            f"{r['damped_s']:7.2f}"
        )
    for r in rows:
        if r["stop"]:
            print(f"{r['objective']} k_s = {r['gain']:g} seed {r['seed']}: {r['stop']}")
    print()
    print(f"{'objective':16s} {'k_s':>6s} {'kept':>5s} {'median max|u_m|':>16s} "
          f"{'worst max|u_m|':>15s} {'worst min sig^':>15s}")  # fmt: skip
    for obj, g in dict.fromkeys((r["objective"], r["gain"]) for r in rows):
        rs = [r for r in rows if (r["objective"], r["gain"]) == (obj, g) and r["seed"] >= 0]
        if not rs:
            continue
        us = [r["max_u"] for r in rs]
        print(
            f"{obj:16s} {g:6.3g} {sum(r['kept'] for r in rs):2d}/{len(rs):<2d} "
            f"{np.median(us):16.2f} {max(us):15.2f} {min(r['min_sigma_hat'] for r in rs):15.2e}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
