"""The torque-free target (``ffsm_pin.sim.target.torque_free_step``: its numpy reference and
its compiled kernel, ``ffsm_pin.sim._target_kernels``) against MuJoCo: a free body of the same
mass and full inertia tensor, the same initial pose and twist, no gravity, integrated by
MuJoCo's RK4 at a step ten times smaller; after 3 s the attitudes, body rates and CoM
positions agree to the two integrators' truncation errors (besides the closed form and DOP853
checks of tests/sim/test_target.py). Skipped without ``mujoco`` (a dev extra)."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.sim.target import Target, TargetState, torque_free_step

mujoco = pytest.importorskip("mujoco")

INERTIA = np.array([[2.0, 0.1, 0.05], [0.1, 1.5, 0.02], [0.05, 0.02, 1.1]])
MASS = 30.0


def _mujoco_model(dt: float):
    full = " ".join(str(x) for x in (INERTIA[0, 0], INERTIA[1, 1], INERTIA[2, 2],
                                     INERTIA[0, 1], INERTIA[0, 2], INERTIA[1, 2]))  # fmt: skip
    xml = f"""<mujoco><option timestep="{dt}" gravity="0 0 0" integrator="RK4"/>
      <worldbody><body name="box"><freejoint/>
        <inertial pos="0 0 0" mass="{MASS}" fullinertia="{full}"/>
      </body></worldbody></mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


@pytest.mark.parametrize("compiled", [False, True], ids=["numpy", "numba"])
def test_torque_free_target_agrees_with_mujoco(compiled):
    """The same free body in both: pose, body rate and CoM after 3 s (3000 steps of 1 ms
    here, 30000 RK4 steps of 0.1 ms in MuJoCo)."""
    target = Target(MASS, INERTIA)
    state = TargetState.from_rpy([0.5, -0.2, 0.1], [0.3, -0.2, 1.0], [0.02, -0.01, 0.03],
                                 [0.4, -0.9, 0.7])  # fmt: skip
    dt, steps, fine = 1e-3, 3000, 10
    model = _mujoco_model(dt / fine)
    data = mujoco.MjData(model)
    q, v = state.to_pinocchio(target)  # (position, quaternion x y z w), body-frame twist
    data.qpos[:3] = q[:3]
    data.qpos[3:] = q[[6, 3, 4, 5]]  # MuJoCo's quaternion is w x y z
    data.qvel[:3] = state.velocity  # MuJoCo's free joint: world linear, body angular velocity
    data.qvel[3:] = state.angular_velocity
    for _ in range(steps * fine):
        mujoco.mj_step(model, data)
    got = state
    for _ in range(steps):
        got = torque_free_step(target, got, dt, compiled=compiled)
    R_mj = np.empty(9)
    mujoco.mju_quat2Mat(R_mj, data.qpos[3:])
    R_mj = R_mj.reshape(3, 3)
    assert np.abs(got.pose.rotation - R_mj).max() < 1e-11  # (measured 5e-14, 9e-14)
    np.testing.assert_allclose(got.angular_velocity, data.qvel[3:], rtol=0, atol=1e-11)
    # (MuJoCo adds v h 30000 times: roundings up to ~30000 eps |p| / 2)
    np.testing.assert_allclose(got.pose.translation, data.qpos[:3], rtol=0, atol=1e-11)
    # the turn is not small: the check is not one of a body at rest
    assert np.abs(R_mj - state.pose.rotation).max() > 0.5
