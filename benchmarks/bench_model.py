"""Model benchmarks of ffsm-pin: everything timed side by side in one run, one table.

Run from the repository root::

    python benchmarks/bench_model.py            # about 7 s on 2 cores
    python benchmarks/bench_model.py --repeat 15 --target-ms 1   # quicker, noisier

Rows (microseconds per call, median and quartiles of ``--repeat`` samples taken
round-robin over all rows, see ``_timing.py``):

1. the reduced model bundle ``FloatingBaseState.update`` on the paper robot
   (``ffsm_planar4.urdf``), plus the Pinocchio calls it is made of;
2. every barycentric evaluation for the paper robot with the true parameters;
3. the plant step (with and without momentum projection) against a bare ``pin.aba``;
4. ``pin.aba`` on a free-floating 7-DOF arm from example-robot-data (xArm7, free-flyer
   root, zero gravity);
5. SPARTpy's forward dynamics against ``pin.aba`` on SPARTpy's own
   ``floating_7dof_manipulator.urdf``.

Correctness is checked before timing, in the same run, and shown in the ``check`` column:
the barycentric model with the true theta against Pinocchio's reduced bundle, the momentum
after one projected plant step, and SPARTpy's accelerations against Pinocchio's (after
mapping SPART's conventions, see ``SpartRig``). The exit status is 1 if a
gated check (marked ``FAIL``) fails.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.metadata as md
import io
import math
import os
import platform
import sys
import tempfile
import time
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin
from _timing import Timing, time_interleaved

from ffsm_pin.model._state_planar import base_twist_to_local
from ffsm_pin.model.planar import BarycentricModel
from ffsm_pin.model.state import State as FloatingBaseState
from ffsm_pin.robot import UrdfWarning, add_missing_limits, load_robot
from ffsm_pin.sim.plant import Plant

GATE = 1e-9  # relative tolerance of the gated checks
DT = 1e-3  # plant step [s]


# ---------------------------------------------------------------------------- table rows
@dataclass
class Row:
    label: str
    fn: object = None  # callable timed, or None for a section header
    ref: str | None = None  # key of the row the ratio is taken against
    check: str = ""
    key: str = ""
    timing: Timing | None = None


@dataclass
class Bench:
    rows: list[Row] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def section(self, title: str) -> None:
        self.rows.append(Row(title))

    def add(self, key: str, label: str, fn, ref: str | None = None, check: str = "") -> None:
        self.rows.append(Row(label, fn, ref, check, key))

    def gate(self, name: str, rel: float, tol: float = GATE) -> str:
        ok = bool(rel <= tol)
        if not ok:
            self.failures.append(f"{name}: {rel:.2e} > {tol:.0e}")
        return f"{rel:.1e} {'ok' if ok else 'FAIL'}"


def rel_err(a, b) -> float:
    """max |a - b| / max |b| (inf-norms), 0 when both vanish."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    scale = float(np.abs(b).max(initial=0.0))
    diff = float(np.abs(a - b).max(initial=0.0))
    return diff / scale if scale > 0 else diff


# ---------------------------------------------------------------------------- paper robot
def paper_state(robot):
    """Table 2 configuration (q_b = 0.18, q_m = (pi/3, -pi/3, pi/3, -pi/3)), reading A's base
    twist (inertial frame) and non-zero joint rates so that every velocity term is exercised."""
    q = robot.configuration((0.0, 0.0, 0.18), [math.pi / 3, -math.pi / 3] * 2)
    w_m = np.array([0.3, -0.2, 0.25, -0.15])
    v = np.concatenate((base_twist_to_local(q, (0.09694, 0.09657, -0.0037)), w_m))
    return q, v


def bench_paper_robot(b: Bench) -> None:
    robot = load_robot("ffsm_planar4.urdf")
    model = robot.model
    q, v = paper_state(robot)
    st = FloatingBaseState(robot).update(q, v)
    bm = BarycentricModel(robot.geometry)
    qb, qm, w = st.base_attitude, np.array(st.joint_angles), np.array(st.w)
    theta_d = bm.theta_d
    theta_z = bm.true_theta_z(st.com_velocity)
    theta_b = bm.true_theta_b(st.angular_momentum)
    rng = np.random.default_rng(7)
    a_vec = rng.normal(size=w.size)
    s_vec = rng.normal(size=w.size)

    # ---- correctness of the barycentric model with the true theta against Pinocchio
    chk = {}
    chk["mass_matrix"] = rel_err(bm.mass_matrix(theta_d, qb, qm), st.M)
    chk["Y_M"] = rel_err(bm.Y_M(qb, qm, a_vec) @ theta_d, st.M @ a_vec)
    chk["Y_h"] = rel_err(bm.Y_h(qb, qm, w) @ theta_d, st.h)
    jb, jm = bm.jacobians(theta_z, qb, qm)
    chk["jacobians"] = rel_err(np.hstack((jb, jm)), np.hstack((st.J_b, st.J_m)))
    hbb, hbm, a0 = bm.momentum_matrices(theta_b, qb, qm)
    chk["momentum_matrices"] = max(
        rel_err(np.hstack((hbb, hbm)), np.hstack((st.H_bb, st.H_bm))),
        rel_err(a0, st.angular_momentum),
    )
    # Y_b theta_b = H w - A_0 = 0, relative to |A_0|
    chk["Y_b"] = abs(float((bm.Y_b(qb, qm, w) @ theta_b)[0])) / abs(st.angular_momentum)
    # Y_z theta_z = end-effector velocity (position rows) from Pinocchio
    data = model.createData()
    pin.forwardKinematics(model, data, q, v)
    v_ee = pin.getFrameVelocity(model, data, robot.ee_frame_id, pin.LOCAL_WORLD_ALIGNED)
    chk["Y_z"] = rel_err((bm.Y_z(qb, qm, w) @ theta_z)[:2], v_ee.linear[:2])
    # Y_Mdot against a central difference of M along w (truncation ~1e-9: looser gate)
    h = 1e-6
    q_red = np.concatenate(([qb], qm))
    m_plus = bm.mass_matrix(theta_d, q_red[0] + h * w[0], q_red[1:] + h * w[1:])
    m_minus = bm.mass_matrix(theta_d, q_red[0] - h * w[0], q_red[1:] - h * w[1:])
    chk["Y_Mdot"] = rel_err(
        bm.Y_Mdot(qb, qm, w, s_vec) @ theta_d, (m_plus - m_minus) / (2 * h) @ s_vec
    )

    def gate(name, tol=GATE, what="vs bundle"):
        return f"{what} {b.gate(f'barycentric {name}', chk[name], tol)}"

    b.section(
        f"1. Pinocchio reduced bundle: paper robot {model.name} (nq {model.nq}, nv {model.nv}), "
        "Table 2 state"
    )
    d2 = model.createData()
    fid = robot.ee_frame_id
    b.add(
        "bundle",
        "FloatingBaseState.update (M, Cw, H, J, z_e, P, L)",
        lambda: st.update(q, v),
        ref="bundle",
    )
    b.add("crba", "  of which pin.crba", lambda: pin.crba(model, d2, q), ref="bundle")
    z = np.zeros(model.nv)
    b.add(
        "rnea", "  of which pin.rnea (v, a=0)", lambda: pin.rnea(model, d2, q, v, z), ref="bundle"
    )
    b.add("ccrba", "  of which pin.ccrba", lambda: pin.ccrba(model, d2, q, v), ref="bundle")

    def jac():
        pin.computeJointJacobians(model, d2, q)
        pin.updateFramePlacements(model, d2)
        pin.getFrameJacobian(model, d2, fid, pin.LOCAL_WORLD_ALIGNED)

    b.add("jac", "  of which joint/frame Jacobians", jac, ref="bundle")
    b.add(
        "jcom",
        "  of which pin.jacobianCenterOfMass",
        lambda: pin.jacobianCenterOfMass(model, d2, q, False),
        ref="bundle",
    )

    def pin_calls():
        pin.crba(model, d2, q)
        pin.rnea(model, d2, q, v, z)
        pin.ccrba(model, d2, q, v)
        jac()
        pin.jacobianCenterOfMass(model, d2, q, False)

    b.add("pin_calls", "  the five Pinocchio calls above, in sequence", pin_calls, ref="bundle")

    b.section(
        f"2. Barycentric model, paper robot, true theta (n_z {bm.n_z}, n_d {bm.n_d}, n_b {bm.n_b})"
    )
    calls = {
        "mass_matrix": lambda: bm.mass_matrix(theta_d, qb, qm),
        "Y_M": lambda: bm.Y_M(qb, qm, a_vec),
        "Y_Mdot": lambda: bm.Y_Mdot(qb, qm, w, s_vec),
        "Y_h": lambda: bm.Y_h(qb, qm, w),
        "Y_z": lambda: bm.Y_z(qb, qm, w),
        "Y_b": lambda: bm.Y_b(qb, qm, w),
        "jacobians": lambda: bm.jacobians(theta_z, qb, qm),
        "momentum_matrices": lambda: bm.momentum_matrices(theta_b, qb, qm),
    }
    what = {
        "Y_M": "Y_M a vs M a",
        "Y_h": "Y_h th vs Cw",
        "Y_z": "Y_z th vs v_ee",
        "Y_b": "|Y_b th|/|A0|",
        "Y_Mdot": "vs central diff",
    }
    for name, fn in calls.items():
        tol = 1e-6 if name == "Y_Mdot" else GATE
        b.add(
            f"bary_{name}",
            name,
            fn,
            ref="bundle",
            check=gate(name, tol, what.get(name, "vs bundle")),
        )
    fns = list(calls.values())

    def all_eight():
        for fn in fns:
            fn()

    b.add("bary_all", "all eight in sequence", all_eight, ref="bundle")

    # ---- plant
    b.section(f"3. Plant step, paper robot (dt = {DT:g} s, semi-implicit Euler on ABA)")
    plant = Plant(robot)
    plant_np = Plant(robot, project_momentum=False)
    plant.reset(q, v)
    plant_np.reset(q, v)
    u_m = np.array([2.0, -1.0, 0.5, -0.25])
    tau = np.concatenate((np.zeros(3), u_m))
    d3 = model.createData()
    p0 = plant.momentum(q, v)
    s1 = plant.step(q, v, u_m, DT)
    s0 = plant_np.step(q, v, u_m, DT)
    drift_proj = rel_err(plant.momentum(s1.q, s1.v), p0)
    drift_plain = rel_err(plant.momentum(s0.q, s0.v), p0)
    b.add("aba", "pin.aba (bare)", lambda: pin.aba(model, d3, q, v, tau), ref="aba")
    b.add(
        "acc", "Plant.acceleration (ABA + copy)", lambda: plant.acceleration(q, v, u_m), ref="aba"
    )
    b.add(
        "step_np",
        "Plant.step, project_momentum=False",
        lambda: plant_np.step(q, v, u_m, DT),
        ref="aba",
        check=f"|dh|/|h| {drift_plain:.1e} (1 step)",
    )
    b.add(
        "step",
        "Plant.step (momentum projection)",
        lambda: plant.step(q, v, u_m, DT),
        ref="aba",
        check=f"|dh|/|h| {b.gate('plant momentum after projected step', drift_proj, 1e-12)}",
    )
    b.add("project", "  of which Plant.project", lambda: plant.project(s1.q, s1.v), ref="aba")


# ---------------------------------------------------------------------------- 7-DOF arm
def erd_urdf(relpath: str) -> Path:
    """Path of a URDF shipped by example-robot-data (its Python loader is optional)."""
    try:
        import example_robot_data as erd  # noqa: PLC0415

        p = Path(erd.getModelPath(relpath)) / relpath.lstrip("/")
        if p.is_file():
            return p
    except (ImportError, AttributeError, OSError, ValueError):
        pass  # example-robot-data >= 6 wheels ship the data without the Python loader
    dist = md.distribution("example-robot-data")
    p = Path(str(dist.locate_file(f"cmeel.prefix/share/example-robot-data/robots/{relpath}")))
    if not p.is_file():
        raise FileNotFoundError(f"example-robot-data has no {relpath}")
    return p


def bench_arm(b: Bench) -> None:
    rel = "xarm_description/urdf/xarm7.urdf"
    path = erd_urdf(rel)
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    model.gravity.setZero()
    arm = [model.joints[j].shortname() for j in range(2, model.njoints)]
    assert len(arm) == 7 and all(s.startswith("JointModelR") for s in arm), arm
    data = model.createData()
    rng = np.random.default_rng(3)
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    v = rng.normal(size=model.nv)
    tau = np.concatenate((np.zeros(6), rng.normal(size=model.nv - 6)))
    b.section(
        f"4. 7-DOF arm on a free-flyer, zero gravity: example-robot-data {rel.split('/')[-1]} "
        f"(nq {model.nq}, nv {model.nv})"
    )
    b.add("arm_aba", "pin.aba", lambda: pin.aba(model, data, q, v, tau), ref="aba")
    b.add("arm_crba", "pin.crba", lambda: pin.crba(model, data, q), ref="arm_aba")


# ---------------------------------------------------------------------------- SPARTpy
def fold_fixed_leaves(text: str, model: pin.Model) -> str:
    """URDF text where each leaf link hanging on a 'fixed' joint is folded into its parent.

    The parent link's <inertial> becomes Pinocchio's merged body inertia (Pinocchio does the
    same merge when it parses the original file), so the rigid-body physics is unchanged.
    """
    root = ET.fromstring(text)
    links = {el.get("name"): el for el in root.findall("link")}
    parents = {j.get("name"): j.find("parent").get("link") for j in root.findall("joint")}
    for joint in list(root.findall("joint")):
        if joint.get("type") != "fixed":
            continue
        parent = joint.find("parent").get("link")
        child = joint.find("child").get("link")
        if child in parents.values():
            raise ValueError(f"fixed joint {joint.get('name')!r}: child {child!r} is not a leaf")
        jid = next(
            f.parentJoint for f in model.frames if f.name == parent and f.type == pin.FrameType.BODY
        )
        body = model.inertias[jid]
        # the parent link frame must be the joint frame for model.inertias[jid] to apply
        pframe = model.frames[model.getFrameId(parent, pin.FrameType.BODY)].placement
        if not pframe.isIdentity(1e-12):
            raise ValueError(f"link {parent!r} is not at its joint frame")
        inertial = links[parent].find("inertial")
        if inertial is None:
            inertial = ET.SubElement(links[parent], "inertial")
        for tag in ("origin", "mass", "inertia"):
            for el in inertial.findall(tag):
                inertial.remove(el)
        fmt = repr
        ET.SubElement(
            inertial, "origin", xyz=" ".join(fmt(float(x)) for x in body.lever), rpy="0 0 0"
        )
        ET.SubElement(inertial, "mass", value=fmt(float(body.mass)))
        inn = body.inertia
        ET.SubElement(
            inertial,
            "inertia",
            ixx=fmt(float(inn[0, 0])),
            ixy=fmt(float(inn[0, 1])),
            ixz=fmt(float(inn[0, 2])),
            iyy=fmt(float(inn[1, 1])),
            iyz=fmt(float(inn[1, 2])),
            izz=fmt(float(inn[2, 2])),
        )
        root.remove(joint)
        root.remove(links[child])
    return ET.tostring(root, encoding="unicode")


def urdf_link_inertia(text: str, link: str) -> pin.Inertia:
    """Spatial inertia of a URDF link in its own link frame."""
    el = next(x for x in ET.fromstring(text).findall("link") if x.get("name") == link)
    inertial = el.find("inertial")
    origin = inertial.find("origin")
    xyz = np.array([float(x) for x in origin.get("xyz", "0 0 0").split()])
    rpy = np.array([float(x) for x in origin.get("rpy", "0 0 0").split()])
    i = {k: float(inertial.find("inertia").get(k, 0)) for k in "ixx ixy ixz iyy iyz izz".split()}
    inn = np.array(
        [
            [i["ixx"], i["ixy"], i["ixz"]],
            [i["ixy"], i["iyy"], i["iyz"]],
            [i["ixz"], i["iyz"], i["izz"]],
        ]
    )
    mass = float(inertial.find("mass").get("value"))
    local = pin.Inertia(mass, np.zeros(3), inn)
    return pin.SE3(pin.rpy.rpyToMatrix(rpy), xyz).act(local)


class SpartRig:
    """One SPARTpy robot next to the Pinocchio model of the same URDF text.

    Conventions mapped (SPART docs and src/kinematics_dynamics/*.m, SPARTpy's C port):

    * SPART base pose: R0 (base-link body -> inertial) and r0 (base-link CoM, inertial);
      here the base link's inertial origin is its link frame, so R0, r0 are Pinocchio's
      free-flyer rotation and translation (checked).
    * u0 = [w0; r0dot] with w0 in the *base body* frame (P0 = [R0 0; 0 I3]) and r0dot in the
      inertial frame; Pinocchio's v_base = [v; w] both in the base (LOCAL) frame:
      u0 = [w; R v].
    * FD returns u0dot = d/dt u0 = [dw/dt (body); r0ddot (inertial)]; with Pinocchio's
      a_base = [dv/dt; dw/dt] (LOCAL), r0ddot = R (dv/dt + w x v).
    """

    def __init__(self, text: str, label: str):
        from SPARTpy import SPART  # noqa: PLC0415
        from SPARTpy.urdf2robot import urdf2robot  # noqa: PLC0415

        self.label = label
        self.text = text
        self.model = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
        self.model.gravity.setZero()
        self.data = self.model.createData()
        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
            f.write(text)
            self.path = f.name
        try:
            self.sp = SPART(self.path)
            _, keys = urdf2robot(self.path)
        finally:
            os.unlink(self.path)
        self.robot = self.sp.robot
        self.n = self.robot.n_links_joints
        self.nq = self.robot.n_q
        base = next(k for k, i in keys["link_id"].items() if i == 0)
        self.links_by_id = {i: k for k, i in keys["link_id"].items()}
        base_origin = (
            next(x for x in ET.fromstring(text).findall("link") if x.get("name") == base)
            .find("inertial")
            .find("origin")
        )
        for attr in ("xyz", "rpy"):
            vals = [float(x) for x in base_origin.get(attr, "0 0 0").split()]
            if any(vals):
                raise ValueError(f"base link {base!r} inertial {attr}={vals}: frames differ")
        if self.model.nv != 6 + self.nq:
            raise ValueError("Pinocchio and SPART disagree on the number of joints")
        self.wF0 = np.zeros(6)
        self.wFm = np.zeros((6, self.n))
        self.tau0 = np.zeros(6)

    def spart_inputs(self, q, v):
        R = pin.Quaternion(q[3:7]).normalized().toRotationMatrix()
        r0 = q[:3].copy()
        u0 = np.concatenate((v[3:6], R @ v[:3]))
        return R, r0, np.array(q[7:]), u0, np.array(v[6:])

    def spart_fd(self, R, r0, qm, u0, um, taum):
        """SPART's forward-dynamics pipeline: Kinematics, DiffKinematics, Velocities, I_I, FD."""
        sp = self.sp
        _, RL, _, rL, e, g = sp.kinematics(R, r0, qm)
        Bij, Bi0, P0, pm = sp.diff_kinematics(R, r0, rL, e, g)
        t0, tL = sp.velocities(Bij, Bi0, P0, pm, u0, um)
        I0, Im = sp.i_i(R, RL)
        return sp.forward_dynamics(
            self.tau0, taum, self.wF0, self.wFm, t0, tL, P0, pm, I0, Im, Bij, Bi0, u0, um
        )

    def ode_inputs(self, R, r0, qm, u0, um, taum):
        return self.sp.space_robot_ode_input(0.0, R.T, r0, u0, qm, um, self.tau0, taum)

    def ode_accel(self, R, r0, qm, u0, um, taum):
        _, y, tau = self.ode_inputs(R, r0, qm, u0, um, taum)
        dy = self.sp.space_robot_ode(0.0, y, tau)
        return np.concatenate((dy[12:18], dy[18 + self.nq :]))

    @staticmethod
    def to_spart_accel(q, v, a):
        """Pinocchio (q, v, a) -> SPART [u0dot; umdot]."""
        R = pin.Quaternion(q[3:7]).normalized().toRotationMatrix()
        lin, ang = v[:3], v[3:6]
        r0ddot = R @ (a[:3] + np.cross(ang, lin))
        return np.concatenate((a[3:6], r0ddot, a[6:]))

    def pin_accel(self, q, v, taum):
        tau = np.concatenate((np.zeros(6), taum))
        return self.to_spart_accel(q, v, pin.aba(self.model, self.data, q, v, tau))

    def dropped_bias_accel(self, q, v, taum):
        """Pinocchio's FD with SPART's ID_C/ID.m quirk reproduced: the Newton-Euler wrench of
        links with SPART index > n_q (``for i=1:n_active``) is left out of the bias terms."""
        dropped = [self.links_by_id[i] for i in range(self.nq + 1, self.n + 1)]
        m_ee = self.model.copy()
        for j in range(m_ee.njoints):
            m_ee.inertias[j] = pin.Inertia.Zero()
        for name in dropped:
            frame = self.model.frames[self.model.getFrameId(name, pin.FrameType.BODY)]
            y = frame.placement.act(urdf_link_inertia(self.text, name))
            m_ee.inertias[frame.parentJoint] = m_ee.inertias[frame.parentJoint] + y
        d_ee = m_ee.createData()
        zero = np.zeros(self.model.nv)
        # SPART evaluates its bias at u0dot = 0, i.e. r0ddot = 0: Pinocchio's dv/dt = -w x v
        a_sp0 = zero.copy()
        a_sp0[:3] = -np.cross(v[3:6], v[:3])
        bias = pin.rnea(self.model, self.data, q, v, zero) - pin.rnea(m_ee, d_ee, q, v, a_sp0)
        M = pin.crba(self.model, self.data, q)
        M = np.triu(M) + np.triu(M, 1).T
        tau = np.concatenate((np.zeros(6), taum))
        return self.to_spart_accel(q, v, np.linalg.solve(M, tau - bias)), dropped


def spart_states(model: pin.Model, count: int, seed: int):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        q[7:] = rng.uniform(-math.pi, math.pi, model.nq - 7)
        v = np.concatenate((0.3 * rng.normal(size=6), rng.normal(size=model.nv - 6)))
        taum = 10.0 * rng.normal(size=model.nv - 6)
        out.append((q, v, taum))
    return out


def bench_spart(b: Bench) -> None:
    try:
        import SPARTpy  # noqa: PLC0415
    except ImportError:
        b.section("5. SPARTpy: not installed (pip install spartpy), skipped")
        return
    urdf = Path(SPARTpy.__file__).parent / "urdf" / "floating_7dof_manipulator.urdf"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UrdfWarning)
        text = add_missing_limits(urdf.read_text(), urdf.name)
    repaired = sum(issubclass(w.category, UrdfWarning) for w in caught)
    b.notes.append(
        f"SPARTpy URDF: add_missing_limits repaired {repaired} revolute joint(s) without <limit>"
    )
    out = io.StringIO()
    with contextlib.redirect_stdout(out):  # SPARTpy may compile SPART_C.so on first use
        shipped = SpartRig(text, "as shipped")
        folded = SpartRig(fold_fixed_leaves(text, shipped.model), "fixed EE link folded")
        states = spart_states(shipped.model, 8, seed=11)
        for rig in (shipped, folded):
            rig.spart_fd(*rig.spart_inputs(*states[0][:2]), states[0][2])
    if out.getvalue().strip():
        b.notes.append("SPARTpy said: " + " | ".join(out.getvalue().split("\n")[:3]))

    # the folded model is the same rigid-body system for Pinocchio
    same = max(
        np.abs(
            folded.model.inertias[j].toDynamicParameters()
            - shipped.model.inertias[j].toDynamicParameters()
        ).max()
        for j in range(1, shipped.model.njoints)
    )
    if same > 1e-12:
        b.failures.append(f"folded URDF changes Pinocchio's inertias by {same:.1e}")

    # ---- accelerations: gated on the folded model, explained on the shipped one
    err_fd = err_ode = err_shipped = err_quirk = 0.0
    dropped = []
    for q, v, taum in states:
        a_pin = folded.pin_accel(q, v, taum)
        inp = folded.spart_inputs(q, v)
        u0dot, umdot = folded.spart_fd(*inp, taum)
        err_fd = max(err_fd, rel_err(np.concatenate((u0dot, umdot)), a_pin))
        err_ode = max(err_ode, rel_err(folded.ode_accel(*inp, taum), a_pin))
        inp = shipped.spart_inputs(q, v)
        a_sp = np.concatenate(shipped.spart_fd(*inp, taum))
        err_shipped = max(err_shipped, rel_err(a_sp, shipped.pin_accel(q, v, taum)))
        a_quirk, dropped = shipped.dropped_bias_accel(q, v, taum)
        err_quirk = max(err_quirk, rel_err(a_sp, a_quirk))

    m = shipped.model
    b.section(
        f"5. SPARTpy {SPARTpy_version()} vs Pinocchio: {urdf.name} "
        f"(nq {m.nq}, nv {m.nv}; SPART: {shipped.n} links, {shipped.nq} joints)"
    )
    q, v, taum = states[0]
    tau = np.concatenate((np.zeros(6), taum))
    d = m.createData()
    R, r0, qm, u0, um = shipped.spart_inputs(q, v)
    _, y_ode, tau_ode = shipped.ode_inputs(R, r0, qm, u0, um, taum)
    sp = shipped.sp
    b.add("sp_aba", "pin.aba, same robot and state", lambda: pin.aba(m, d, q, v, tau), ref="sp_aba")
    b.add(
        "sp_fd",
        "SPARTpy FD pipeline (Kinematics..FD, 5 calls)",
        lambda: shipped.spart_fd(R, r0, qm, u0, um, taum),
        ref="sp_aba",
        check=f"max rel |da| {b.gate('SPARTpy FD vs pin.aba (fixed EE link folded)', err_fd)}",
    )
    _, RL, _, rL, e, g = sp.kinematics(R, r0, qm)
    Bij, Bi0, P0, pm = sp.diff_kinematics(R, r0, rL, e, g)
    t0, tL = sp.velocities(Bij, Bi0, P0, pm, u0, um)
    I0, Im = sp.i_i(R, RL)
    z0, zm = shipped.wF0, shipped.wFm
    b.add(
        "sp_fd_only",
        "  of which SPARTpy forward_dynamics",
        lambda: sp.forward_dynamics(z0, taum, z0, zm, t0, tL, P0, pm, I0, Im, Bij, Bi0, u0, um),
        ref="sp_aba",
    )
    b.add(
        "sp_ode",
        "SPARTpy space_robot_ode (one C call)",
        lambda: sp.space_robot_ode(0.0, y_ode, tau_ode),
        ref="sp_aba",
        check=f"max rel |da| {b.gate('SPARTpy ODE vs pin.aba (fixed EE link folded)', err_ode)}",
    )
    quirk_ok = err_quirk <= GATE
    shipped_ok = err_shipped <= GATE
    b.add(
        "sp_shipped",
        "  (shipped URDF, no fold: accelerations only)",
        None,
        check=(
            f"max rel |da| {err_shipped:.1e}: "
            + (
                "equal"
                if shipped_ok
                else f"= SPART bias without {', '.join(dropped)} ({err_quirk:.0e})"
                if quirk_ok
                else "UNEXPLAINED"
            )
        ),
    )
    b.notes.append(
        f"SPARTpy check: {len(states)} random states; gated rows use the URDF with the fixed "
        f"leaf link ({', '.join(dropped) or '-'}) folded into its parent (same physics: "
        f"Pinocchio inertias equal to {same:.0e}). With the shipped URDF SPART differs by "
        f"{err_shipped:.1e} because its ID (ID.m / ID_C.m: `for i=1:n_active`) drops the "
        f"Newton-Euler wrench of links numbered above n_q from the bias terms; Pinocchio "
        f"with that wrench removed reproduces SPART to {err_quirk:.1e}."
    )
    if not (shipped_ok or quirk_ok):
        b.notes.append("WARNING: the shipped-URDF difference is not explained by the known quirk")


def SPARTpy_version() -> str:  # noqa: N802
    try:
        return md.version("spartpy")
    except md.PackageNotFoundError:
        return "?"


# ---------------------------------------------------------------------------- output
def print_table(b: Bench, repeat: int, target_ms: float, elapsed: float) -> None:
    times = {r.key: r.timing for r in b.rows if r.timing is not None}
    head = (
        f"ffsm-pin model benchmarks: python {platform.python_version()}, "
        f"pinocchio {pin.__version__}, numpy {np.__version__}, {os.cpu_count()} CPU(s)"
    )
    print(head)
    print(
        f"us per call: median [q1-q3] of {repeat} samples of ~{target_ms:g} ms each, "
        "all rows sampled round-robin in this run; ratio = median / median of row 'vs'"
    )
    w = 52
    line = f"{'row':{w}} {'median':>9} {'q1-q3':>17} {'ratio':>7}  {'vs':<10} check"
    print("-" * 130)
    print(line)
    for r in b.rows:
        if r.fn is None and not r.check:
            print("-" * 130)
            print(r.label)
            continue
        t = r.timing
        if t is None:
            print(f"{r.label:{w}} {'':>9} {'':>17} {'':>7}  {'':<10} {r.check}")
            continue
        ratio = ""
        if r.ref and r.ref != r.key and r.ref in times:
            ratio = f"{t.median_us / times[r.ref].median_us:.2f}x"
        elif r.ref == r.key:
            ratio = "1.00x"
        ref = r.ref or ""
        iqr = f"{t.q1_us:.2f}-{t.q3_us:.2f}"
        print(
            f"{r.label:{w}} {t.median_us:9.2f} {iqr:>17} {ratio:>7}  {ref:<10} {r.check}".rstrip()
        )
    print("-" * 130)
    for note in b.notes:
        print(f"note: {note}")
    status = "all checks passed" if not b.failures else "FAILED: " + "; ".join(b.failures)
    print(f"{status} (total {elapsed:.1f} s)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=41, help="samples per row (default 41)")
    ap.add_argument(
        "--target-ms", type=float, default=4.0, help="duration of one sample [ms] (default 4)"
    )
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    b = Bench()
    bench_paper_robot(b)
    bench_arm(b)
    bench_spart(b)
    fns = {r.key: r.fn for r in b.rows if r.fn is not None}
    timings = time_interleaved(fns, repeat=args.repeat, target_s=args.target_ms * 1e-3)
    for r in b.rows:
        if r.fn is not None:
            r.timing = timings[r.key]
    print_table(b, args.repeat, args.target_ms, time.perf_counter() - t_start)
    return 1 if b.failures else 0


if __name__ == "__main__":
    sys.exit(main())
