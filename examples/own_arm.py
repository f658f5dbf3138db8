"""Your own arm on a satellite: an example-robot-data arm by name in a shipped scenario.

The built-in 'spatial-realistic' scenario gives its end-effector reference relative to where
the hand starts ([reference] origin = "initial"), so another arm needs only its [robot] table
and its joints. Check the run before simulating it, then compare two controllers.

    python examples/own_arm.py                     # a UR5, 10 s
    python examples/own_arm.py --arm xarm7 --duration 40
"""

import argparse
import dataclasses
import re
import warnings

from ffsm_pin import prepare, simulate
from ffsm_pin.scenario.file import builtin_path, scenario_from_toml
from ffsm_pin.sim.check import check

ARMS = {  # example-robot-data name -> (end-effector frame, a bent start pose [rad])
    "ur5": ("ee_link", [1.49, -0.11, 1.65, 1.06, 1.66, -1.49]),
    "xarm7": ("link7", [-0.45, -1.34, 1.51, 1.58, -1.81, -1.21, 0.55]),
    "kinova": ("j2s6s200_end_effector", [1.58, -0.16, 1.02, -0.06, 0.83, -0.73]),
}
parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--arm", choices=sorted(ARMS), default="ur5")
parser.add_argument("--duration", type=float, default=10.0, help="simulated time [s]")
args = parser.parse_args()

# the shipped file with [robot] and the joints changed (a copy of it is yours to edit)
ee, joints = ARMS[args.arm]
text = builtin_path("spatial-realistic").read_text()
text = text.replace('"example-robot-data:panda"', f'"example-robot-data:{args.arm}"')
text = text.replace('end_effector = "panda_hand"', f'end_effector = "{ee}"')
text = re.sub(r"^locked_joints = .*\n", "", text, count=1, flags=re.M)
text = re.sub(r"^joints = .*$", f"joints = {joints}", text, count=1, flags=re.M)
text = re.sub(r"^joint_rates = .*$", f"joint_rates = {[0.0] * len(joints)}", text, count=1,
              flags=re.M)  # fmt: skip
warnings.simplefilter("ignore")  # e.g. the Kinova's continuous joints are announced
scenario = dataclasses.replace(scenario_from_toml(text), duration=args.duration)

report = check(scenario)  # what `python -m ffsm_pin.sim --check` prints, without simulating
print(f"check: sigma_min(0) = {report.sigma_min:.3f} m, attitude error "
      f"{report.attitude_error:.4f} rad of {report.authority:.2f} rad the arm can buy, "
      f"problems: {report.problems or 'none'}")  # fmt: skip

for kind in ("lu-jia", "gjm-ct"):  # the paper's controller (Panda-tuned gains), a baseline
    ctrl = dataclasses.replace(scenario.controller, type=kind)
    s = simulate(prepare(dataclasses.replace(scenario, controller=ctrl))).summary()
    print(f"{kind:8s} completed {s['completed']}, funnels b / z {s['funnel_ok_b']} / "
          f"{s['funnel_ok_z']}, RMS e_z (last half) {s['rms_err_z_late']:.2e} m"
          + (f", stopped: {s['stop_reason']}" if not s["completed"] else ""))  # fmt: skip
