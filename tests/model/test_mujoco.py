"""Pinocchio's full floating-base dynamics (FloatingBaseState.mass_matrix, .nonlinear_effects and
ABA) agree with MuJoCo's on the same URDF, with a planar base added to MuJoCo's model.

Conventions: MuJoCo's base joints are slide-x, slide-y (inertial frame) and hinge-z, so its
qvel = T(q_b) v with T = diag(R(q_b), 1, I) and v Pinocchio's velocity (base linear velocity in
the base frame). Kinetic energy and power are the same in both, hence
    M_pin = T^T M_mj T,    h_pin = T^T (M_mj dT/dt v + bias_mj),    qacc_mj = T a_pin + dT/dt v,
with dT/dt v = (w_b J R(q_b) v_lin, 0, 0) (J: 90 degree rotation).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from ffsm_pin.model.state import State as FloatingBaseState
from ffsm_pin.robot import load_robot

# MuJoCo and Pinocchio both run recursive rigid-body algorithms in double precision; they differ
# only in operation order (observed ~1e-14 relative). 1e-9 of the largest entry is the brief's
# bound: far below any modelling difference (a wrong inertia, lever or joint sign moves entries
# by 1e-3 or more) and far above rounding.
TOL = 1e-9
N_STATES = 5


def rel_err(actual, expected, floor=1.0):
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    return float(np.abs(actual - expected).max() / max(np.abs(expected).max(), floor))


def mujoco_model(robot) -> mujoco.MjModel:
    """MuJoCo model of robot's URDF with a planar floating base, zero gravity, no contacts,
    limits, armature or damping, and the URDF inertias taken as they are."""
    spec = mujoco.MjSpec.from_file(str(robot.urdf_path))
    spec.compiler.fusestatic = False  # keep the root body (it gets the base joints)
    spec.compiler.discardvisual = True
    spec.compiler.balanceinertia = False
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    base = spec.body(robot.body_names[0])
    # order matters: the slides act before the hinge, so they move along inertial axes
    base.add_joint(name="base_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
    base.add_joint(name="base_y", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 1, 0])
    base.add_joint(name="base_yaw", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.disableflags |= (
        mujoco.mjtDisableBit.mjDSBL_CONTACT
        | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
        | mujoco.mjtDisableBit.mjDSBL_LIMIT
    )
    model = spec.compile()
    names = [model.joint(i).name for i in range(model.njnt)]
    assert names == ["base_x", "base_y", "base_yaw", *robot.model.names[2:]]
    assert model.nv == robot.model.nv
    # nothing added by the compiler
    assert not model.dof_armature.any() and not model.dof_damping.any()
    assert not model.dof_frictionloss.any() and not model.jnt_stiffness.any()
    body_ids = [model.body(name).id for name in robot.body_names]
    np.testing.assert_array_equal(model.body_mass[body_ids], robot.geometry.masses)
    np.testing.assert_array_equal(model.body_inertia[body_ids, 2], robot.geometry.inertias)
    assert math.isclose(model.body_subtreemass[body_ids[0]], robot.geometry.total_mass)
    return model


@pytest.fixture(scope="module", params=["ffsm_planar4.urdf", "planar5_offaxis.urdf"])
def robots(request, data_dir):
    robot = load_robot(request.param, relative_to=data_dir)
    return robot, mujoco_model(robot)


def _velocity_map(q, v):
    """T (nv x nv) and dT/dt v for the planar base."""
    c, s = q[2], q[3]
    T = np.eye(len(v))
    T[:2, :2] = [[c, -s], [s, c]]
    v_world = T[:2, :2] @ v[:2]
    Tdot_v = np.zeros(len(v))
    Tdot_v[:2] = v[2] * np.array([-v_world[1], v_world[0]])
    return T, Tdot_v


def _mujoco_state(robot, mj, q, v, u):
    d = mujoco.MjData(mj)
    T, _ = _velocity_map(q, v)
    d.qpos[:] = np.concatenate((q[:2], [math.atan2(q[3], q[2])], q[4:]))
    d.qvel[:] = T @ v
    d.qfrc_applied[3:] = u
    mujoco.mj_forward(mj, d)
    M = np.zeros((mj.nv, mj.nv))
    mujoco.mj_fullM(mj, d, M)
    return d, M


def test_mass_matrix_bias_and_acceleration(robots, rng, random_state):
    robot, mj = robots
    fbs = FloatingBaseState(robot)
    pdata = robot.model.createData()
    for _ in range(N_STATES):
        q, v = random_state(robot, rng, speed=2.0)
        u = rng.uniform(-20, 20, robot.n_joints)
        fbs.update(q, v)
        d, M_mj = _mujoco_state(robot, mj, q, v, u)
        T, Tdot_v = _velocity_map(q, v)

        assert rel_err(T.T @ M_mj @ T, fbs.mass_matrix) < TOL
        h_mj = T.T @ (M_mj @ Tdot_v + d.qfrc_bias)
        assert rel_err(h_mj, fbs.nonlinear_effects) < TOL
        assert np.abs(fbs.nonlinear_effects).max() > 1.0  # a real test of the velocity terms

        a = pin.aba(robot.model, pdata, q, v, np.concatenate((np.zeros(3), u)))
        assert rel_err(d.qacc, T @ a + Tdot_v) < TOL

        # and the kinematics agree (slides along inertial axes): the generated URDFs put the
        # end-effector frame at the origin of the link "ee_link"
        pin.framesForwardKinematics(robot.model, pdata, q)
        ee_body = mj.body("ee_link").id
        np.testing.assert_allclose(
            d.xpos[ee_body], pdata.oMf[robot.ee_frame_id].translation, rtol=0, atol=1e-12
        )
