"""The spatial model restricted to planar motion is the planar model: the paper's planar robot
and an off-axis planar chain loaded on a free-flyer root, moving in their plane, give the
planar reduced M, C w, momentum rows and reaction torque (two independent implementations:
ffsm_pin.model._state_planar / ffsm_pin.model.planar against ffsm_pin.model._state_spatial /
ffsm_pin.model.spatial)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ffsm_pin.model.planar import BarycentricModel
from ffsm_pin.model.spatial import SpatialBarycentricModel
from ffsm_pin.model.state import State as FloatingBaseState
from ffsm_pin.model.state import State as SpatialState
from ffsm_pin.robot import load_robot, load_spatial_robot

TOL = 1e-10


def rel(a, b, floor=1.0):
    return float(np.abs(np.asarray(a) - b).max() / max(np.abs(b).max(), floor))


@pytest.fixture(scope="module", params=["paper", "planar5_offaxis.urdf"])
def robots(request, paper_robot, data_dir):
    planar = paper_robot if request.param == "paper" else load_robot(data_dir / request.param)
    spatial = load_spatial_robot(planar.urdf_path, planar.ee_frame)
    return planar, spatial


def _spatial_state(spatial, q_planar, v_planar):
    """The same state on the free-flyer: base pose (x, y, 0, MRP of a yaw), twist in the plane."""
    x, y = q_planar[:2]
    yaw = math.atan2(q_planar[3], q_planar[2])
    q = spatial.configuration([x, y, 0.0, 0.0, 0.0, math.tan(yaw / 4)], q_planar[4:])
    v = np.zeros(spatial.model.nv)
    v[:2] = v_planar[:2]
    v[5] = v_planar[2]
    v[6:] = v_planar[3:]
    return q, v


def test_planar_motion_gives_the_planar_model(robots, random_state, rng):
    planar, spatial = robots
    n = planar.n_joints
    ps, ss = FloatingBaseState(planar), SpatialState(spatial)
    pm = BarycentricModel(planar.geometry)
    sm = SpatialBarycentricModel(spatial.geometry)
    idx = [2, *range(3, 3 + n)]  # w_b about z, then the joints
    for _ in range(5):
        q, v = random_state(planar, rng)
        ps.update(q, v)
        ss.update(*_spatial_state(spatial, q, v))
        assert rel(ss.M[np.ix_(idx, idx)], ps.M) < TOL
        assert rel(ss.h[idx], ps.h) < TOL
        assert rel(ss.H_bm[2], ps.H_bm[0]) < TOL
        assert abs(ss.angular_momentum[2] - ps.angular_momentum) < TOL * max(
            1.0, abs(ps.angular_momentum)
        )
        assert rel(ss.ee_pose[:2], ps.ee_pose[:2]) < TOL
        # the reaction torque of Eq. (7): its z component is the planar F_r
        w_dot = rng.normal(size=n + 1)
        w3 = np.zeros(n + 3)
        w3[idx] = ps.w
        w3_dot = np.zeros(n + 3)
        w3_dot[idx] = w_dot
        F_planar = pm.reaction_torque(pm.theta_d, ps.base_attitude, q[4:], ps.w, w_dot)
        F_spatial = sm.reaction_torque(sm.theta_d, ss.base_attitude, ss.joint_angles, w3, w3_dot)
        assert abs(F_spatial[2] - F_planar) < TOL * max(1.0, abs(F_planar))
        assert rel(ss.reaction_torque(w3_dot)[2], F_planar) < TOL
