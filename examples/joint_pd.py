"""A user's controller for ffsm-pin: joint-space PD, written against the interface alone.

It holds the arm at a joint target (the initial joints unless ``[controller.params] target``
is given) and ignores the end-effector reference: the simplest baseline to compare with. Run it
with ``python -m ffsm_pin.sim --scenario examples/joint_pd_planar.toml`` (docs/controllers.md).
"""

import numpy as np


class JointPD:
    """u_m = kp (q_target - q_m) - kd w_m   [N m], gains from [controller.params]."""

    def __init__(self, ctx):
        p = ctx.params
        self.kp = float(p.get("kp", 5.0))  # [N m/rad]
        self.kd = float(p.get("kd", 2.0))  # [N m s/rad]
        target = p.get("target", ctx.initial.q_m)  # [rad], one per joint
        self.target = np.asarray(target, dtype=float).reshape(ctx.n_joints)
        self.m3 = ctx.m3  # the joint rates are w[m3:]

    def step(self, meas):
        joint_error = self.target - meas.q_m
        u = self.kp * joint_error - self.kd * meas.w[self.m3 :]
        # extra signals are saved as ctrl_<name> in trajectory.npz
        return u, {"joint_error": joint_error}
