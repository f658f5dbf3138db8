"""Check the identities of docs/spatial.md with Pinocchio alone, and print the residuals.

    python docs/spatial_facts.py [--seed N] [--joints N]

A random spatial chain (free-flyer root, revolute joints with random unit axes, rotated joint
origins, off-axis CoMs, full inertia tensors, zero gravity) is built directly as a Pinocchio
model; every quantity of docs/spatial.md sections 1-5 is formed from its definition on that page
and compared with Pinocchio's CRBA, centroidal momentum, frame velocity and ABA. Section 7's
attitude-authority ratio is measured on xArm7 and Panda from example-robot-data (skipped when the
package is not installed). This script does not use ffsm_pin's spatial model
(ffsm_pin.model.spatial, ffsm_pin.model.state): it is an independent check of the page. Exit
status 1 if a residual exceeds its bound.
"""

from __future__ import annotations

import argparse
import sys
from importlib import metadata

import numpy as np
import pinocchio as pin

# (relative) bounds: exact identities are rounding (~1e-13 on entries of size ~1e2); checks
# through a central difference with h = 1e-5 or 1e-6 carry its O(h^2) truncation error.
EXACT = 1e-11
DIFFERENCED = 1e-7


def random_chain(n: int, rng: np.random.Generator) -> tuple[pin.Model, list, list, np.ndarray]:
    """Free-flyer model of a random n-joint chain; returns (model, joint axes, a_k, e)."""
    model = pin.Model()
    parent = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")
    sat = np.diag([20.0, 25.0, 30.0]) + 0.1
    model.appendBodyToJoint(parent, pin.Inertia(60.0, rng.normal(scale=0.1, size=3), sat),
                            pin.SE3.Identity())  # fmt: skip
    axes, origins = [], []
    for k in range(1, n + 1):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.5, size=3))
        parent = model.addJoint(parent, pin.JointModelRevoluteUnaligned(axis), placement, f"j{k}")
        a = rng.normal(size=(3, 3))
        inertia = pin.Inertia(
            rng.uniform(1.0, 20.0), rng.normal(scale=0.2, size=3), a @ a.T + 0.5 * np.eye(3)
        )
        model.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
        axes.append(axis)
        origins.append(placement.translation.copy())
    e = rng.normal(scale=0.3, size=3)
    model.addFrame(pin.Frame("ee", parent, 0, pin.SE3(np.eye(3), e), pin.FrameType.OP_FRAME))
    model.gravity.setZero()
    return model, axes, origins, e


def velocity_change(model, data, q) -> np.ndarray:
    """T with v = T u, u = (v_0 inertial, w_b inertial, dq_m), v Pinocchio's velocity."""
    n = model.nv - 6
    pin.computeJointJacobians(model, data, q)
    Jc = pin.jacobianCenterOfMass(model, data, q, False)
    Rt = data.oMi[1].rotation.T
    T = np.zeros((model.nv, model.nv))
    T[:3, :3] = Rt
    T[:3, 3:6] = -Rt @ Jc[:, 3:6] @ Rt
    T[:3, 6:] = -Rt @ Jc[:, 6:]
    T[3:6, 3:6] = Rt
    T[6:, 6:] = np.eye(n)
    return T


def reduced_inertia_pinocchio(model, data, q) -> np.ndarray:
    """Pinocchio's CRBA in the velocities u (the v_0 block is m E_3 and decoupled)."""
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    T = velocity_change(model, data, q)
    return T.T @ M @ T


def random_configuration(model, rng: np.random.Generator, joint_range: float) -> np.ndarray:
    """Free-flyer q: random base position and unit quaternion, joints in +-joint_range."""
    quat = rng.normal(size=4)
    joints = rng.uniform(-joint_range, joint_range, model.nq - 7)
    return np.concatenate((rng.normal(size=3), quat / np.linalg.norm(quat), joints))


def skew(x) -> np.ndarray:
    return np.array([[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]])


def mrp_from_rotation(R) -> np.ndarray:
    quat = pin.Quaternion(R)
    vec, w = np.array([quat.x, quat.y, quat.z]), quat.w
    if w < 0:
        vec, w = -vec, -w
    return vec / (1.0 + w)


def rotation_from_mrp(s) -> np.ndarray:
    ss, X = s @ s, skew(s)
    return np.eye(3) + (8 * X @ X + 4 * (1 - ss) * X) / (1 + ss) ** 2


def B(s) -> np.ndarray:
    return (1 - s @ s) * np.eye(3) + 2 * skew(s) + 2 * np.outer(s, s)


def check_chain(n: int, seed: int) -> list[tuple[str, float, float]]:
    """Residuals (name, relative residual, bound) of docs/spatial.md sections 1-5."""
    rng = np.random.default_rng(seed)
    model, axes, origins, e = random_chain(n, rng)
    data = model.createData()
    nb = n + 1
    q = random_configuration(model, rng, np.pi)
    v = rng.normal(size=model.nv)
    out = []

    def small(name, residual, scale, bound):
        out.append((name, float(np.abs(residual).max()) / max(1.0, float(scale)), bound))

    def rel(name, got, expected, bound):
        small(name, np.asarray(got) - expected, np.abs(expected).max(), bound)

    # section 3: the reduced inertia from Pinocchio, decoupled from v_0, and as a Schur complement
    Mu = reduced_inertia_pinocchio(model, data, q)
    mass = sum(model.inertias[j].mass for j in range(1, model.njoints))
    v0_rows = np.hstack((Mu[:3, :3] - mass * np.eye(3), Mu[:3, 3:]))
    small("sec 3: v_0 block = m E_3, decoupled", v0_rows, np.abs(Mu).max(), EXACT)
    M_red = Mu[3:, 3:]
    T = velocity_change(model, data, q)
    T[:3, 3:] = 0.0  # translation coordinate = base linear velocity: Schur complement instead
    M = pin.crba(model, data, q)
    Mw = T.T @ (np.triu(M) + np.triu(M, 1).T) @ T
    schur = Mw[3:, 3:] - Mw[3:, :3] @ np.linalg.solve(Mw[:3, :3], Mw[:3, 3:])
    rel("sec 3: Schur complement = M_red", schur, M_red, EXACT)

    # section 2: barycentric vectors
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    R = [data.oMi[j].rotation.copy() for j in range(1, model.njoints)]
    m = np.array([model.inertias[j].mass for j in range(1, model.njoints)])
    c = [model.inertias[j].lever.copy() for j in range(1, model.njoints)]
    inertia = [model.inertias[j].inertia.copy() for j in range(1, model.njoints)]
    mu = m / m.sum()
    a = np.array([*origins, np.zeros(3)])
    G = np.zeros((nb, nb, 3))
    for i in range(nb):
        G[i, :i] = a[:i]
        G[i, i] = c[i]
    W = G - np.einsum("j,jkd->kd", mu, G)[None]
    E = np.array(a)
    E[n] = e
    V = E - np.einsum("j,jkd->kd", mu, G)
    S = np.zeros((nb, 3, nb + 2))
    for k in range(nb):
        S[k][:, :3] = np.eye(3)
        for j in range(1, k + 1):
            S[k][:, 2 + j] = R[j] @ axes[j - 1]  # joint j's axis, inertial frame
    fid = model.getFrameId("ee")
    com = pin.centerOfMass(model, data, q)
    rel("sec 2: p_e - p_com = sum R_k V_k", sum(R[k] @ V[k] for k in range(nb)),
        data.oMf[fid].translation - com, EXACT)  # fmt: skip
    rel("sec 2: c_i - p_com = sum R_k W_ik",
        np.array([sum(R[k] @ W[i, k] for k in range(nb)) for i in range(nb)]),
        np.array([data.oMi[i + 1].act(c[i]) - com for i in range(nb)]), EXACT)  # fmt: skip
    u = np.linalg.solve(velocity_change(model, data, q), v)
    w = u[3:]
    pin.forwardKinematics(model, data, q, v)
    v_ee = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear
    rel("sec 2: dp_e/dt = v_0 + sum w_k x R_k V_k",
        u[:3] + sum(np.cross(S[k] @ w, R[k] @ V[k]) for k in range(nb)), v_ee, EXACT)  # fmt: skip

    # section 3: the barycentric form of M_red
    D = np.einsum("i,ikd,ile->klde", m, W, W)
    Jbar = [inertia[k] + np.trace(D[k, k]) * np.eye(3) - D[k, k] for k in range(nb)]
    Mb = sum(S[k].T @ R[k] @ Jbar[k] @ R[k].T @ S[k] for k in range(nb))
    for k in range(nb):
        for l in range(nb):  # noqa: E741 - the page's index names
            if k != l:
                K = np.trace(R[k] @ D[k, l] @ R[l].T) * np.eye(3) - R[l] @ D[k, l].T @ R[k].T
                Mb = Mb + S[k].T @ K @ S[l]
    rel("sec 3: barycentric M = M_red", Mb, M_red, EXACT)

    # section 1: rows 1-3 of M_red w = angular momentum about the CoM, inertial frame
    pin.computeCentroidalMomentum(model, data, q, v)
    rel("sec 1: (M_red w)_b = A_0 (inertial)", M_red[:3] @ w, data.hg.angular, EXACT)
    rel("sec 1: v_0 = P / m", u[:3], data.hg.linear / mass, EXACT)

    # section 4: rows 1-3 of Eq. (8): M_b dw/dt + (dM/dt w)_b = 0 with ABA's accelerations
    tau = np.concatenate((np.zeros(6), rng.normal(scale=5.0, size=n)))
    acc = pin.aba(model, data, q, v, tau)
    w_dot = np.concatenate((data.oMi[1].rotation @ acc[3:6], acc[6:]))

    def M_along(t):
        return reduced_inertia_pinocchio(model, data, pin.integrate(model, q, t * v))[3:, 3:]

    h = 1e-5
    M_dot = (M_along(h) - M_along(-h)) / (2 * h)
    residual = M_red[:3] @ w_dot + (M_dot @ w)[:3]
    scale = max((np.abs(M_red[:3]) @ np.abs(w_dot)).max(), (np.abs(M_dot) @ np.abs(w)).max())
    small("sec 4: M_b dw/dt + (dM/dt w)_b = 0", residual, scale, DIFFERENCED)

    # section 5: MRP facts on the base attitude
    R0 = data.oMi[1].rotation
    s = mrp_from_rotation(R0)
    rel("sec 5: R(s) = R_0", rotation_from_mrp(s), R0, EXACT)
    rel("sec 5: B B^T = (1 + s.s)^2 E_3", B(s) @ B(s).T, (1 + s @ s) ** 2 * np.eye(3), EXACT)
    L_b = 0.25 * B(s) @ R0.T
    rel("sec 5: L_b L_b^T = ((1 + s.s)/4)^2 E_3", L_b @ L_b.T,
        ((1 + s @ s) / 4) ** 2 * np.eye(3), EXACT)  # fmt: skip

    def s_along(t):  # attitude under the inertial angular velocity w_b
        return mrp_from_rotation(pin.exp3(w[:3] * t) @ R0)

    rel("sec 5: ds/dt = L_b w_b", (s_along(1e-6) - s_along(-1e-6)) / 2e-6, L_b @ w[:3],
        DIFFERENCED)  # fmt: skip
    shadow = -s / (s @ s)
    rel("sec 5: shadow set, same attitude", rotation_from_mrp(shadow), R0, EXACT)
    return out


def authority_ratios(n_poses: int = 20) -> list[tuple[str, float, float]]:
    """sigma_max / sigma_min of H_bb^-1 H_bm over random poses (joints in [-1, 1] rad) for
    example-robot-data arms on a 300 kg satellite (docs/spatial.md section 7)."""
    try:
        files = metadata.files("example-robot-data") or []
    except metadata.PackageNotFoundError:
        return []
    robots = {"xarm7": "xarm_description/urdf/xarm7.urdf",
              "panda": "panda_description/urdf/panda.urdf"}  # fmt: skip
    out = []
    for name, tail in robots.items():
        paths = [f for f in files if str(f).endswith("robots/" + tail)]
        if not paths:
            continue
        model = pin.buildModelFromUrdf(str(paths[0].locate()), pin.JointModelFreeFlyer())
        if name == "panda":  # fingers held at zero
            fingers = [model.getJointId(f"panda_finger_joint{i}") for i in (1, 2)]
            model = pin.buildReducedModel(model, fingers, pin.neutral(model))
        model.gravity.setZero()
        model.inertias[1] = pin.Inertia(300.0, np.zeros(3), np.diag([40.0, 45.0, 50.0]))
        data = model.createData()
        ratios = []
        rng = np.random.default_rng(0)
        for _ in range(n_poses):
            q = random_configuration(model, rng, 1.0)
            q[3:7] = (0.0, 0.0, 0.0, 1.0)  # base aligned: w_b inertial = w_B
            Ag = pin.computeCentroidalMap(model, data, q)
            sv = np.linalg.svd(np.linalg.solve(Ag[3:6, 3:6], Ag[3:6, 6:]), compute_uv=False)
            ratios.append(sv[0] / sv[-1])
        out.append((name, float(np.median(ratios)), float(np.max(ratios))))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seed", type=int, default=3)
    p.add_argument("--joints", type=int, default=7)
    args = p.parse_args(argv)
    rows = check_chain(args.joints, args.seed)
    width = max(len(r[0]) for r in rows)
    print(f"random {args.joints}-joint chain, seed {args.seed}: relative residuals")
    failed = 0
    for name, res, bound in rows:
        ok = res <= bound
        failed += not ok
        print(f"  {name.ljust(width)}  {res:9.1e}  (bound {bound:.0e}) {'ok' if ok else 'FAIL'}")
    ratios = authority_ratios()
    if ratios:
        print("sigma_max / sigma_min of H_bb^-1 H_bm, 20 random poses, 300 kg satellite:")
        for name, median, worst in ratios:
            print(f"  {name}: median {median:.1f}, max {worst:.1f}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
