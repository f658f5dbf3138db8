"""Spatial model benchmark: a 7-DOF arm (example-robot-data Panda, fingers locked) on a free-
flying base, side by side with bare Pinocchio CRBA + RNEA on the same state.

Run from the repository root::

    python benchmarks/bench_spatial.py
    python benchmarks/bench_spatial.py --robot ur5 --repeat 15

The script puts its own checkout first on ``sys.path`` (a script's directory, not the current
one, heads ``sys.path``), so it times this checkout's ``ffsm_pin`` even when another one is
installed (e.g. editable from a different worktree); the header names the package measured.

Rows: microseconds per call, median and quartiles of ``--repeat`` samples taken round-robin
over all rows (``_timing.py``), and the ratio to ``pin.crba + pin.rnea``. The issue's target
for "everything the controller needs for one 7-DOF step" is <= 40 us; the row
``controller bundle`` is: the kinematic Jacobians (Eq. 3), Y_z (Eq. 4), Y_b (Eq. 14), Y_M a,
(Y_Mdot, Y_h) in one pass (Eq. 12) and M (Eq. 9a), all from the barycentric model, by
separate method calls; ``controller_terms`` computes the same in one compiled call. Before
timing, the model with the true parameters is checked against ``SpatialState`` (exit 1 if the
relative error exceeds 1e-9).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's ffsm_pin

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
from _timing import time_interleaved  # noqa: E402

import ffsm_pin  # noqa: E402
from ffsm_pin.attitude import mrp
from ffsm_pin.model.spatial import SpatialBarycentricModel  # noqa: E402
from ffsm_pin.model.state import State as SpatialState  # noqa: E402
from ffsm_pin.robot import load_spatial_robot  # noqa: E402

ROBOTS = {
    "panda": (
        "panda_hand",
        {"panda_finger_joint1": 0.02, "panda_finger_joint2": 0.02},
    ),
    "ur5": ("ee_link", {}),
    "xarm7": ("link7", {}),
}
GATE = 1e-9


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robot", choices=sorted(ROBOTS), default="panda")
    parser.add_argument("--repeat", type=int, default=31)
    parser.add_argument("--target-ms", type=float, default=2.0)
    args = parser.parse_args(argv)

    ee, locks = ROBOTS[args.robot]
    robot = load_spatial_robot(
        f"example-robot-data:{args.robot}",
        ee,
        locked_joints=locks,
        satellite={"mass": 500.0, "inertia": (80.0, 80.0, 80.0, 0.0, 0.0, 0.0)},
    )
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(0)
    n = robot.n_joints
    q = robot.configuration(
        np.concatenate((rng.uniform(-1, 1, 3), mrp.shadow(rng.uniform(-0.5, 0.5, 3)))),
        rng.uniform(-2, 2, n),
    )
    v = rng.normal(scale=0.5, size=model.nv)
    zero = np.zeros(model.nv)
    state = SpatialState(robot).update(q, v)
    bm = SpatialBarycentricModel(robot.geometry)
    qb, qm, w = state.base_attitude.copy(), q[7:].copy(), state.w.copy()
    th_z = bm.true_theta_z(state.com_velocity)
    th_b = bm.true_theta_b(state.angular_momentum)
    a = rng.normal(size=n + 3)
    s = rng.normal(size=n + 3)

    # ---------------------------------------------------------------- checks
    def rel(x, y):
        return float(np.abs(x - y).max() / max(1.0, np.abs(y).max()))

    checks = {
        "M": rel(bm.mass_matrix(bm.theta_d, qb, qm), state.M),
        "C w": rel(bm.velocity_product(bm.theta_d, qb, qm, w), state.h),
        "J_m": rel(bm.jacobians(th_z, qb, qm)[1], state.J_m),
        "H_bm": rel(bm.momentum_matrices(th_b, qb, qm)[1], state.H_bm),
    }
    ok = all(e < GATE for e in checks.values())

    def bundle():
        bm.jacobians(th_z, qb, qm)
        bm.Y_z(qb, qm, w)
        bm.Y_b(qb, qm, w)
        bm.Y_M(qb, qm, a)
        bm.velocity_regressors(qb, qm, w, s)
        bm.mass_matrix(bm.theta_d, qb, qm)

    def baseline():
        pin.crba(model, data, q)
        pin.rnea(model, data, q, v, zero)

    rows = {
        "pin.crba + pin.rnea (baseline)": baseline,
        "pin.aba": lambda: pin.aba(model, data, q, v, zero),
        "SpatialState.update (Pinocchio bundle)": lambda: state.update(q, v),
        "barycentric mass_matrix": lambda: bm.mass_matrix(bm.theta_d, qb, qm),
        "barycentric jacobians": lambda: bm.jacobians(th_z, qb, qm),
        "barycentric Y_z": lambda: bm.Y_z(qb, qm, w),
        "barycentric Y_b": lambda: bm.Y_b(qb, qm, w),
        "barycentric Y_M a": lambda: bm.Y_M(qb, qm, a),
        "barycentric (Y_Mdot, Y_h)": lambda: bm.velocity_regressors(qb, qm, w, s),
        "controller bundle (all of the above)": bundle,
        "controller_terms (the same, one compiled call)": lambda: bm.controller_terms(
            th_z, bm.theta_d, qb, qm, w, a, s
        ),
    }
    # the memo of the configuration would hide the rotation cost: clear it in every call
    timed = {}
    for name, fn in rows.items():
        if name.startswith(("barycentric", "controller bundle")):
            timed[name] = lambda fn=fn: (bm._memo.clear(), bm._memo_fast.clear(), fn())
        else:
            timed[name] = fn
    res = time_interleaved(timed, repeat=args.repeat, target_s=args.target_ms * 1e-3)
    base = res["pin.crba + pin.rnea (baseline)"].median_us

    print(
        f"robot: example-robot-data:{args.robot} + satellite, n = {n} joints, "
        f"n_z = {bm.n_z}, n_d = {bm.n_d}, n_b = {bm.n_b}"
    )
    print(f"package: {Path(ffsm_pin.__file__).parent}")
    print(
        "checks (relative error vs SpatialState): "
        + ", ".join(f"{k} {e:.1e}" for k, e in checks.items())
        + ("  ok" if ok else "  FAIL")
    )
    print(f"{'row':44s} {'median [us]':>12s} {'IQR [us]':>10s} {'x baseline':>11s}")
    for name, t in res.items():
        print(f"{name:44s} {t.median_us:12.1f} {t.iqr_us:10.1f} {t.median_us / base:11.1f}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
