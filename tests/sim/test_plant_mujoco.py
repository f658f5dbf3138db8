"""The spatial plant against an independent MuJoCo model of the same URDF (free joint on the
root body, full inertias, zero gravity, no damping, armature, limits or contacts).

The reference replays the recorded torques on MuJoCo's ``mj_forward`` accelerations with a
classical RK4 on MuJoCo's own coordinates (quaternion as four numbers, renormalised), at
dt = 2.5e-4: nothing of Pinocchio's dynamics or Lie-group integration is in it."""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin
import pytest
from spatial_chain import (
    held_torques,
    mujoco_acceleration,
    mujoco_model,
    pinocchio_model,
    plant_replay,
    pose_error,
    quaternion_rk4_replay,
    random_state,
    spatial_chain_urdf,
    to_mujoco,
)

from ffsm_pin.sim.plant import Plant

CHAINS = [(4, 1), (5, 2), (7, 3)]  # (joints, seed)
PERIOD = 1e-3  # the recorded torques: one sample per millisecond, held
DURATION = 5.0
DT = 2.5e-4  # plant step: PERIOD / 4
SUBSTEPS = 4


@pytest.fixture(scope="module", params=CHAINS, ids=lambda c: f"{c[0]}joints")
def replay(request):
    n, seed = request.param
    xml = spatial_chain_urdf(n, seed)
    model, mj = pinocchio_model(xml), mujoco_model(xml)
    q0, v0 = random_state(model, np.random.default_rng(seed), speed=0.2)
    torques = held_torques(n, seed=seed, duration=DURATION, period=PERIOD, peak=2.0)
    q_ref, v_ref = quaternion_rk4_replay(mujoco_acceleration(mj), q0, v0, torques, PERIOD, SUBSTEPS)
    return model, mj, q0, v0, torques, q_ref, v_ref


def test_same_robot_in_both(replay):
    """MuJoCo's compiled model is the URDF's: masses, and accelerations equal to ABA's."""
    model, mj, q0, v0, torques, _, _ = replay
    assert mj.nv == model.nv and mj.nq == model.nq
    assert not mj.dof_armature.any() and not mj.dof_damping.any()
    assert not mj.dof_frictionloss.any() and not mj.jnt_stiffness.any()
    np.testing.assert_allclose(
        sorted(mj.body_mass[1:]), sorted(Y.mass for Y in model.inertias[1:]), rtol=1e-15
    )
    d, data = mujoco.MjData(mj), model.createData()
    d.qpos[:], d.qvel[:] = to_mujoco(q0, v0)
    d.qfrc_applied[6:] = 50 * torques[0]
    mujoco.mj_forward(mj, d)
    a = pin.aba(model, data, q0, v0, np.concatenate((np.zeros(6), 50 * torques[0])))
    R = pin.Quaternion(q0[6], q0[3], q0[4], q0[5]).matrix()
    expected = np.concatenate((R @ (a[:3] + np.cross(v0[3:6], v0[:3])), a[3:]))
    # both are recursive algorithms in double precision (observed ~1e-14 relative)
    assert np.abs(d.qacc - expected).max() <= 1e-9 * np.abs(expected).max()


@pytest.mark.parametrize(
    "integrator, tol",
    [
        # the brief's bound; observed 4e-6 .. 4.3e-4 over these chains (first order in dt)
        ("semi-implicit", 1e-3),
        # observed ~5e-13 (the reference's own error, about (2.5e-4)^4 x C, and rounding)
        ("rk4", 1e-9),
    ],
)
def test_open_loop_replay_matches_mujoco(replay, integrator, tol):
    """5 s of recorded torques (1 kHz, held), plant at 2.5e-4: base position [m], base attitude
    [rad] and every joint [rad] within ``tol`` of MuJoCo's; momentum drift <= 1e-9 relative."""
    model, _, q0, v0, torques, q_ref, _ = replay
    plant = Plant(model, integrator=integrator)
    q, _, drift = plant_replay(plant, q0, v0, torques, PERIOD, SUBSTEPS)
    assert np.abs(q[7:] - q0[7:]).max() > 0.5  # the arm really moved
    assert drift <= 1e-9
    dp, dth, dj = pose_error(q, q_ref)
    assert max(dp, dth, dj) <= tol, (dp, dth, dj)
