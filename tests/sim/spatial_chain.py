"""A random spatial serial chain on a free-flying base, as URDF text, and its models.

``spatial_chain_urdf(n_joints, seed)``: a satellite (40-60 kg) and ``n_joints`` revolute joints
with random unit axes (not aligned with any frame axis), random joint-origin translations and
rotations, CoMs 5-20 cm off the joint axes, and full inertia tensors (random principal moments
that satisfy the triangle inequality, rotated by a random inertial-frame rotation).

``pinocchio_model(xml)``: Pinocchio's model with a ``JointModelFreeFlyer`` root, zero gravity.
``mujoco_model(xml)``: MuJoCo's model of the same URDF with a free joint on the root body, zero
gravity, no contacts, limits, damping or armature, and the URDF inertias as they are.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin


def _vec(x) -> str:
    return " ".join(repr(float(c)) for c in x)


_UPPER = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def _inertial(g: np.random.Generator, mass: float, size: float, com) -> str:
    # principal moments m s^2 (0.3..1): triangle inequality checked below, then redrawn
    while True:
        p = mass * size**2 * g.uniform(0.3, 1.0, 3)
        if 2 * p.max() < p.sum():
            break
    R = pin.rpy.rpyToMatrix(*g.uniform(-np.pi, np.pi, 3))
    I = R @ np.diag(p) @ R.T  # full tensor about the CoM, link-frame axes  # noqa: E741
    ixx, ixy, ixz, iyy, iyz, izz = (repr(float(I[i, j])) for i, j in _UPPER)
    return (
        f'<inertial><origin xyz="{_vec(com)}" rpy="0 0 0"/><mass value="{float(mass)!r}"/>'
        f'<inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" iyy="{iyy}" iyz="{iyz}" izz="{izz}"/>'
        "</inertial>"
    )


def spatial_chain_urdf(n_joints: int, seed: int) -> str:
    """URDF text of a random ``n_joints``-joint revolute chain on a free base (see module)."""
    g = np.random.default_rng(seed)
    base = _inertial(g, g.uniform(40, 60), 0.6, g.normal(0, 0.05, 3))
    links = [f'<link name="base">{base}</link>']
    joints = []
    parent = "base"
    for k in range(n_joints):
        axis = g.normal(size=3)
        axis /= np.linalg.norm(axis)
        origin = g.uniform(0.1, 0.4) * np.array([1.0, 0.0, 0.0]) + g.normal(0, 0.1, 3)
        if k == 0:
            origin = np.array([0.5, 0.0, 0.3]) + g.normal(0, 0.05, 3)
        rpy = g.uniform(-np.pi, np.pi, 3)
        com = np.array([g.uniform(0.1, 0.3), 0.0, 0.0]) + g.uniform(0.05, 0.2) * g.normal(size=3)
        name = f"link{k + 1}"
        links.append(f'<link name="{name}">{_inertial(g, g.uniform(3, 8), 0.25, com)}</link>')
        joints.append(
            f'<joint name="j{k + 1}" type="revolute"><parent link="{parent}"/>'
            f'<child link="{name}"/><origin xyz="{_vec(origin)}" rpy="{_vec(rpy)}"/>'
            f'<axis xyz="{_vec(axis)}"/>'
            '<limit lower="-1000" upper="1000" effort="1000" velocity="1000"/></joint>'
        )
        parent = name
    body = "\n".join(links + joints)
    return f'<?xml version="1.0"?>\n<robot name="spatial{n_joints}_s{seed}">\n{body}\n</robot>\n'


def pinocchio_model(xml: str) -> pin.Model:
    """Pinocchio model of the URDF text with a free-flyer root and zero gravity."""
    model = pin.buildModelFromXML(xml, pin.JointModelFreeFlyer())
    model.gravity.setZero()
    return model


def mujoco_model(xml: str, root: str = "base") -> mujoco.MjModel:
    """MuJoCo model of the URDF text: a free joint on the root link ``root``, nothing else
    added."""
    spec = mujoco.MjSpec.from_string(xml)
    spec.compiler.fusestatic = False  # keep the root body (it gets the free joint)
    spec.compiler.discardvisual = True
    spec.compiler.balanceinertia = False
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.body(root).add_freejoint()
    for joint in spec.joints:  # the URDF's <dynamics damping/friction> are not rigid-body physics
        for attr in ("damping", "stiffness", "frictionloss", "armature"):
            value = getattr(joint, attr)  # a number, or (MuJoCo 4) polynomial coefficients
            setattr(joint, attr, np.zeros_like(value) if np.ndim(value) else 0.0)
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.disableflags |= (
        mujoco.mjtDisableBit.mjDSBL_CONTACT
        | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
        | mujoco.mjtDisableBit.mjDSBL_LIMIT
    )
    model = spec.compile()
    assert not model.dof_damping.any() and not model.dof_frictionloss.any()
    assert not model.dof_armature.any() and not model.jnt_stiffness.any()
    return model


# ------------------------------------------------------------------ state conversions
# Pinocchio: q = (p, quat xyzw, q_m), v = (v_B, w_B, dq_m), v_B and w_B in the base frame.
# MuJoCo:    qpos = (p, quat wxyz, q_m), qvel = (dp/dt inertial, w_B base frame, dq_m).
def to_mujoco(q, v) -> tuple[np.ndarray, np.ndarray]:
    """Pinocchio (q, v) -> MuJoCo (qpos, qvel) of the same state."""
    R = pin.Quaternion(q[6], q[3], q[4], q[5]).normalized().matrix()
    qpos = np.concatenate((q[:3], [q[6], q[3], q[4], q[5]], q[7:]))
    qvel = np.concatenate((R @ v[:3], v[3:]))
    return qpos, qvel


def to_pinocchio(qpos, qvel) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo (qpos, qvel) -> Pinocchio (q, v) of the same state."""
    quat = np.asarray(qpos[3:7]) / np.linalg.norm(qpos[3:7])
    R = pin.Quaternion(*quat).matrix()  # (w, x, y, z) constructor
    q = np.concatenate((qpos[:3], quat[[1, 2, 3, 0]], qpos[7:]))
    v = np.concatenate((R.T @ qvel[:3], qvel[3:]))
    return q, v


def random_state(model: pin.Model, g: np.random.Generator, speed: float = 1.0):
    """A random free-flyer state: base pose within a metre, any attitude, joint angles in
    (-pi, pi), base twist ~ 0.3 speed [m/s, rad/s], joint rates ~ speed [rad/s]."""
    q = np.empty(model.nq)
    q[:3] = g.uniform(-1, 1, 3)
    quat = g.normal(size=4)
    q[3:7] = quat / np.linalg.norm(quat)
    q[7:] = g.uniform(-np.pi, np.pi, model.nq - 7)
    v = np.concatenate((0.3 * speed * g.normal(size=6), speed * g.normal(size=model.nv - 6)))
    return q, v


def pose_error(q, q_ref) -> tuple[float, float, float]:
    """(base position [m], base attitude angle [rad], max joint angle [rad]) between two
    Pinocchio free-flyer configurations."""
    dp = float(np.linalg.norm(q[:3] - q_ref[:3]))
    R = pin.Quaternion(q[6], q[3], q[4], q[5]).normalized().matrix()
    R_ref = pin.Quaternion(q_ref[6], q_ref[3], q_ref[4], q_ref[5]).normalized().matrix()
    dth = float(np.linalg.norm(pin.log3(R_ref.T @ R)))
    dj = float(np.abs(q[7:] - q_ref[7:]).max())
    return dp, dth, dj


# ------------------------------------------------------------------ reference integration
def held_torques(n_joints: int, seed: int, duration: float, period: float, peak: float, scale=1.0):
    """A recorded torque sequence: per joint a seeded sum of three sinusoids (peak |u_j|
    between peak/4 and peak [N m], times ``scale[j]``) sampled every ``period`` [s], shape
    (steps, n_joints). ``scale`` = the joint-space inertia diagonal makes ``peak`` an angular
    acceleration [rad/s^2] for every joint, light wrists included."""
    g = np.random.default_rng(seed)
    w = g.uniform(0.5, 1.0, (n_joints, 3))
    amp = w / w.sum(axis=1, keepdims=True) * g.uniform(peak / 4, peak, n_joints)[:, None]
    omega = g.uniform(2.0, 6.0, (n_joints, 3))  # [rad/s]
    phase = g.uniform(0, 2 * np.pi, (n_joints, 3))
    t = np.arange(int(round(duration / period))) * period
    return (amp * np.sin(omega * t[:, None, None] + phase)).sum(axis=2) * scale


def _quat_rate(quat, w_body) -> np.ndarray:
    """d quat / dt = 1/2 quat (x) (0, w_body), quat as (w, x, y, z)."""
    qw, qx, qy, qz = quat
    wx, wy, wz = w_body
    return 0.5 * np.array(
        [
            -qx * wx - qy * wy - qz * wz,
            qw * wx + qy * wz - qz * wy,
            qw * wy - qx * wz + qz * wx,
            qw * wz + qx * wy - qy * wx,
        ]
    )


def mujoco_acceleration(mj: mujoco.MjModel):
    """qacc(qpos, qvel, u_m) from MuJoCo's ``mj_forward`` (unit quaternion in qpos)."""
    d = mujoco.MjData(mj)

    def qacc(qpos, qvel, u_m):
        d.qpos[:], d.qvel[:] = qpos, qvel
        d.qfrc_applied[6:] = u_m
        mujoco.mj_forward(mj, d)
        return d.qacc.copy()

    return qacc


def pinocchio_acceleration(model: pin.Model):
    """The same qacc from Pinocchio's ABA: d/dt (R v_B) = R (dv_B/dt + w_B x v_B)."""
    data = model.createData()
    tau = np.zeros(model.nv)

    def qacc(qpos, qvel, u_m):
        q, v = to_pinocchio(qpos, qvel)
        tau[6:] = u_m
        a = pin.aba(model, data, q, v, tau)
        R = pin.Quaternion(*qpos[3:7]).matrix()
        return np.concatenate((R @ (a[:3] + np.cross(v[3:6], v[:3])), a[3:]))

    return qacc


def quaternion_rk4_replay(qacc, q0, v0, torques, period: float, substeps: int):
    """Open-loop replay of ``torques`` (each held for ``period`` [s]) with classical RK4 of
    step ``period / substeps`` on MuJoCo's coordinates (qpos, qvel), the quaternion as four
    plain numbers (d quat/dt = quat (x) (0, w_B) / 2) renormalised after each step, and the
    accelerations ``qacc(qpos, qvel, u_m)``. Independent of Pinocchio's Lie-group integration.
    Returns Pinocchio's final (q, v)."""
    qpos, qvel = to_mujoco(q0, v0)
    nq = qpos.size
    x = np.concatenate((qpos, qvel))
    h = period / substeps

    def f(x, u):
        qpos = x[:nq].copy()
        qpos[3:7] /= np.linalg.norm(qpos[3:7])
        qvel = x[nq:]
        return np.concatenate(
            (qvel[:3], _quat_rate(qpos[3:7], qvel[3:6]), qvel[6:], qacc(qpos, qvel, u))
        )

    for u in torques:
        for _ in range(substeps):
            k1 = f(x, u)
            k2 = f(x + h / 2 * k1, u)
            k3 = f(x + h / 2 * k2, u)
            k4 = f(x + h * k3, u)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            x[3:7] /= np.linalg.norm(x[3:7])
    return to_pinocchio(x[:nq], x[nq:])


def plant_replay(plant, q0, v0, torques, period: float, substeps: int):
    """The plant on the same replay; returns the final (q, v) and the max relative momentum
    drift max_k |h_k - h_0| / |h_0| over every control step."""
    plant.reset(q0, v0)
    h0 = plant.momentum0
    q, v = q0, v0
    drift = 0.0
    for u in torques:
        q, v, _ = plant.advance(q, v, u, period, substeps)
        drift = max(drift, float(np.abs(plant.momentum(q, v) - h0).max()))
    return q, v, drift / float(np.abs(h0).max())
