"""Inputs taken from Lu & Jia (2019), Section 4: initial estimates (Table 2) and the scenario.

These are *inputs* of the paper's simulation, not truths: the true parameter vectors are
always derived from the URDF (:class:`ffsm_pin.model.planar.BarycentricModel`). The true
vectors the paper prints belong to a 3-link chain (docs/model.md section 2) and are kept here
only so that tests can show that.
"""

from __future__ import annotations

import math

# Table 2. theta_d-hat(0) is read with the diagonal first (D00..D44), then the upper
# triangle row by row (D01 D02 D03 D04 D12 D13 D14 D23 D24 D34): the layout of
# ParameterLayout.theta_d_names() for a collinear 4-link robot (docs/model.md section 2).
THETA_Z_HAT0 = (0.0, 0.0, 0.1, 1.9, 0.8, 1.5, 1.0)
THETA_D_HAT0 = (34, 30, 18, 14, 3.5, 17, 9, 7, 1.5, 20, 10, 4.1, 12, 4.6, 4.1)
THETA_B_HAT0 = (0.0, *THETA_D_HAT0)

Q_B0 = 0.18  # [rad]
Q_M0 = (math.pi / 3, -math.pi / 3, math.pi / 3, -math.pi / 3)  # [rad]
W_B0 = -0.0037  # [rad/s]
V_0 = (0.0988, 0.0943)  # [m/s]
A_0 = -1.6467  # [kg m^2/s] (inconsistent with W_B0 and w_m(0) = 0, see docs/model.md section 6)

# The parameter vectors printed in Section 4 (they are those of a 3-link chain).
PRINTED_THETA_Z = (0.0988, 0.0943, 0.6277, 1.1550, 1.2600, 1.3542)
PRINTED_THETA_D = (
    34.5482,
    20.0140,
    11.9952,
    3.1686,
    11.9952,
    12.6126,
    4.1234,
    6.8544,
    4.4982,
    2.2409,
)  # order D00 D11 D22 D33 D01 D12 D13 D02 D23 D03
