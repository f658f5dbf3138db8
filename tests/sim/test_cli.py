"""End-to-end tests of ``python -m ffsm_pin.sim`` on short runs (subprocess, as a user runs it)."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ffsm_pin.robot import urdf_dir
from ffsm_pin.robot.writer import chain_from_table, chain_to_urdf
from ffsm_pin.scenario.file import builtin_path, load_scenario
from ffsm_pin.sim import compile_note
from ffsm_pin.sim.result import CONTRACT_KEYS, EXTRA_KEYS, TRUTH_KEYS

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("ffsm_pin.sim.run") is None,
    reason="ffsm_pin.sim.run (prepare/simulate) is not written yet",
)

CASE1_TEXT = builtin_path("case1").read_text()
SUMMARY_KEYS = (
    "scheme", "robot", "dt", "duration", "steps", "wall_time_s", "steps_per_s", "funnel_ok_b",
    "funnel_ok_z", "first_violation_t", "final_err_b", "final_err_z", "max_abs_u", "drift_P",
    "drift_L", "settle_time_b", "settle_time_z", "completed", "stop_reason",
)  # fmt: skip
FIGURES = ("fig_errors.png", "fig_velocities.png", "fig_estimation.png", "fig_torque.png")
SCHEME = {"1": "ppc", "2": "no-ppc", "3": "no-attitude"}


def sim(*args: str, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess:
    proc = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", *args], cwd=cwd, capture_output=True, timeout=timeout
    )
    # decoded by hand: text mode would turn the progress bar's "\r" into newlines
    proc.stdout, proc.stderr = proc.stdout.decode(), proc.stderr.decode()
    return proc


def scenario_file(tmp_path: Path, filename: str = "s.toml", **replace: str) -> Path:
    """case1.toml with whole lines replaced: key -> new line (e.g. k_z='k_z = 1e6')."""
    text = CASE1_TEXT
    for key, line in replace.items():
        text, n = re.subn(rf"(?m)^{re.escape(key)} = .*$", line, text)
        assert n == 1, key
    path = tmp_path / filename
    path.write_text(text)
    return path


def expected_shapes(n: int) -> dict[str, tuple[int, ...]]:
    per_sample = {
        "t": (), "q": (8,), "v": (7,), "w": (5,), "u_m": (4,), "z_e": (3,), "z_e_d": (3,),
        "err_z": (3,), "rho_z": (3,), "q_b": (1,), "err_b": (1,), "rho_b": (1,), "P": (2,),
        "L": (), "F_r": (), "w_tilde": (5,), "e": (5,), "theta_z_hat": (7,),
        "theta_d_hat": (15,), "theta_b_hat": (16,), "z_e_dot": (3,), "z_e_d_dot": (3,),
        "w_mc": (4,), "w_hat": (5,), "sigma_min": (), "damping": (), "bound_b_lower": (1,),
        "bound_b_upper": (1,), "bound_z_lower": (3,), "bound_z_upper": (3,), "dw_b": (),
    }  # fmt: skip
    shapes = {k: (n, *s) for k, s in per_sample.items()}
    shapes.update(theta_z=(7,), theta_d=(15,), theta_b=(16,))
    return shapes


def check_consistent(folder: Path, *, duration: float, dt: float, scheme: str) -> dict:
    """Every contract key with the right shape; summary.json recomputed from the arrays."""
    with np.load(folder / "trajectory.npz") as npz:
        data = {k: npz[k] for k in npz.files}
    for key in (*CONTRACT_KEYS, *TRUTH_KEYS, *EXTRA_KEYS):
        assert key in data, f"{key} missing from trajectory.npz"
    n = len(data["t"])
    for key, shape in expected_shapes(n).items():
        assert data[key].shape == shape, (key, data[key].shape, shape)
    summary = json.loads((folder / "summary.json").read_text())
    for key in SUMMARY_KEYS:
        assert key in summary, f"{key} missing from summary.json"
    assert summary["scheme"] == scheme and summary["robot"] == "ffsm_planar4"
    assert summary["dt"] == dt and summary["duration"] == duration

    def inside(x):  # strictly inside Eqs. (16)/(17), every component
        e, lo, hi = data[f"err_{x}"], data[f"bound_{x}_lower"], data[f"bound_{x}_upper"]
        return np.all((e > lo) & (e < hi), axis=1)

    inside_b, inside_z = inside("b"), inside("z")
    # a run stopped at a funnel exit never records the sample outside (the transformation
    # (21) is undefined there): the stop itself is the violation
    stop_funnel = summary["stop_funnel"]
    assert stop_funnel in (None, "b", "z")
    assert (stop_funnel is not None) == (summary["stop_cause"] == "funnel")
    assert summary["funnel_ok_b"] == (bool(inside_b.all()) and stop_funnel != "b")
    assert summary["funnel_ok_z"] == (bool(inside_z.all()) and stop_funnel != "z")
    bad = ~(inside_b & inside_z)
    first = float(data["t"][np.argmax(bad)]) if bad.any() else None
    if first is None and stop_funnel is not None:
        first = summary["stop_time"]
    assert summary["first_violation_t"] == first
    # the bounds are those of Eqs. (16)-(18): rho(t) with sides fixed by the sign at t = 0
    assert np.all(data["bound_b_upper"] > data["bound_b_lower"])
    assert np.allclose(np.maximum(-data["bound_z_lower"], data["bound_z_upper"]), data["rho_z"])
    assert summary["final_err_b"] == pytest.approx(data["err_b"][-1].tolist())
    assert summary["final_err_z"] == pytest.approx(data["err_z"][-1].tolist())
    assert summary["max_abs_u"] == pytest.approx(np.linalg.norm(data["u_m"], axis=1).max())
    drift_P = np.linalg.norm(data["P"] - data["P"][0], axis=1).max()
    drift_L = np.abs(data["L"] - data["L"][0]).max()
    assert summary["drift_P"] == pytest.approx(drift_P, abs=1e-15)
    assert summary["drift_L"] == pytest.approx(drift_L, abs=1e-15)
    # the truths and the time axis
    assert n >= 1 and data["t"][0] == 0.0
    if n > 1:
        assert np.allclose(np.diff(data["t"]), np.diff(data["t"])[0])
    return summary


# ------------------------------------------------------------------------------ the cases
@pytest.fixture(scope="module")
def case_runs(tmp_path_factory):
    """Run the three cases once (2.5 s each) and keep what they wrote."""
    runs = {}
    for case in ("1", "2", "3"):
        cwd = tmp_path_factory.mktemp(f"case{case}")
        proc = sim("--case", case, "--duration", "2.5", "--out", "out", cwd=cwd)
        runs[case] = (proc, cwd / "out")
    return runs


@pytest.mark.parametrize("case", ["1", "2", "3"])
def test_case_runs_and_writes_the_contract(case_runs, case):
    proc, out = case_runs[case]
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    summary = check_consistent(out, duration=2.5, dt=1e-3, scheme=SCHEME[case])
    assert summary["completed"] is True and summary["stop_reason"] is None
    assert summary["steps"] == 2500
    for name in (*FIGURES, "replay.html", "scenario.toml"):
        assert (out / name).is_file() and (out / name).stat().st_size > 1000, name
    # the result table
    table = proc.stdout
    for row in ("completed", "funnel b / z", "final err_z", "max |u_m|", "drift P", "drift L"):
        assert row in table
    assert re.search(r"completed\s+yes", table)
    assert re.search(r"wall time \[s\]\s+\d", table) and "steps per second" in table
    # the scenario as run can be run again
    again = load_scenario(out / "scenario.toml")
    assert again.duration == 2.5 and again.controller.scheme == SCHEME[case]


def test_progress_bar_on_stderr(case_runs):
    proc, _ = case_runs["1"]
    assert "\r" in proc.stderr and "steps/s" in proc.stderr
    # only the progress bar (erased at the end), warnings and, on a cold numba cache, the
    # one compile note (ffsm_pin/sim/compile_note.py): no other text
    lines = [seg for seg in re.split(r"[\r\n]", proc.stderr) if seg.strip()]
    allowed = ("warning: ", compile_note.MESSAGE)
    assert all("[" in s and "steps/s" in s or s.startswith(allowed) for s in lines), lines
    assert sum(s == compile_note.MESSAGE for s in lines) <= 1


def test_record_every_and_quiet(tmp_path):
    proc = sim(
        "--duration", "1", "--record-every", "10", "--no-plots", "--no-html", "--quiet",
        "--out", "r", cwd=tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert proc.stdout.strip() == "r"
    with np.load(tmp_path / "r" / "trajectory.npz") as npz:
        t = npz["t"]
    assert len(t) == 101 and t[-1] == pytest.approx(1.0)
    assert (
        not list((tmp_path / "r").glob("*.png")) and not (tmp_path / "r" / "replay.html").exists()
    )


def test_default_output_folder_is_timestamped_and_never_reused(tmp_path):
    folders = []
    for _ in range(2):
        proc = sim("--duration", "0.05", "--no-plots", "--no-html", "--quiet", cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        folders.append(proc.stdout.strip())
    assert folders[0] != folders[1]
    for f in folders:
        assert re.fullmatch(r"runs/\d{8}-\d{6}(-\d+)?", f), f
        assert (tmp_path / f / "summary.json").is_file()


def test_compare_overlays(tmp_path):
    proc = sim("--compare", "--duration", "0.5", "--no-html", "--out", "cmp", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    for case in ("case1", "case2", "case3"):
        assert (tmp_path / "cmp" / case / "summary.json").is_file()
        assert (tmp_path / "cmp" / case / "fig_errors.png").is_file()
    for name in FIGURES:
        assert (tmp_path / "cmp" / name).is_file()
    assert re.search(r"scenario\s+case1\s+case2\s+case3", proc.stdout)


def test_compare_takes_files_and_cases_and_controllers(tmp_path):
    """--compare with a built-in case and a scenario file; --controllers runs each scenario
    once per controller type, a user's class labelled by its name (issue 41)."""
    pd = Path(__file__).resolve().parents[2] / "examples" / "joint_pd_planar.toml"
    proc = sim("--compare", "2", str(pd), "--duration", "0.1", "--no-html", "--no-plots",
               "--out", "a", cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert {p.name for p in (tmp_path / "a").iterdir()} == {"case2", "joint-pd-planar"}
    user = f"{pd.parent / 'joint_pd.py'}:JointPD"
    proc = sim("--case", "1", "--controllers", f"lu-jia,gjm-ct,{user}", "--duration", "0.1",
               "--no-html", "--out", "b", cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    runs = {"case1-lu-jia", "case1-gjm-ct", "case1-JointPD"}
    assert runs <= {p.name for p in (tmp_path / "b").iterdir()}
    for run in runs:
        summary = json.loads((tmp_path / "b" / run / "summary.json").read_text())
        assert summary["controller"] == {"case1-lu-jia": "lu-jia", "case1-gjm-ct": "gjm-ct"}.get(
            run, user
        )
    for name in FIGURES:
        assert (tmp_path / "b" / name).is_file()  # overlaid
    assert re.search(r"controller\s+lu-jia \(ppc\)\s+gjm-ct\s+JointPD\s", proc.stdout)
    bad = sim("--compare", "nothing-like-this", cwd=tmp_path)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "--compare" in bad.stderr


def test_scenario_option_and_overrides(tmp_path):
    path = scenario_file(tmp_path, "mine.toml", name='name = "mine"', dt="dt = 0.002")
    proc = sim(
        "--scenario", str(path), "--duration", "0.5", "--no-plots", "--no-html", "--out", "o",
        cwd=tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    summary = check_consistent(tmp_path / "o", duration=0.5, dt=0.002, scheme="ppc")
    assert summary["steps"] == 250
    proc = sim(
        "--scenario", str(path), "--duration", "0.2", "--dt", "0.001", "--no-plots",
        "--no-html", "--quiet", "--out", "o2", cwd=tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    check_consistent(tmp_path / "o2", duration=0.2, dt=0.001, scheme="ppc")


def test_package_warnings_are_single_lines(tmp_path):
    urdf = (urdf_dir() / "ffsm_planar4.urdf").read_text()
    joint4 = urdf.index('<joint name="joint4"')
    limit = urdf.index("<limit", joint4)
    urdf = urdf[:limit] + urdf[urdf.index("/>", limit) + 2 :]
    (tmp_path / "sloppy.urdf").write_text(urdf)
    path = scenario_file(tmp_path, urdf='urdf = "sloppy.urdf"')
    args = ("--scenario", str(path), "--duration", "0.1", "--no-plots", "--no-html")
    proc = sim(*args, "--out", "o", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    lines = [s for s in re.split(r"[\r\n]", proc.stderr) if s.strip() and "steps/s" not in s]
    assert lines and all(s.startswith("warning: ") for s in lines), lines
    assert any("joint4" in s and "<limit>" in s for s in lines)
    assert "UrdfWarning" not in proc.stderr and "warnings.warn" not in proc.stderr
    quiet = sim(*args, "--quiet", "--out", "q", cwd=tmp_path)
    assert quiet.returncode == 0 and quiet.stderr == ""


# ------------------------------------------------------------------------------ bad input
def three_link_urdf(tmp_path: Path) -> Path:
    table = tomllib.loads((urdf_dir() / "ffsm_planar4.toml").read_text())
    table["name"] = "ffsm_planar3"
    table["links"] = table["links"][:3]
    path = tmp_path / "planar3.urdf"
    path.write_text(chain_to_urdf(chain_from_table(table)))
    return path


BAD_INPUTS = {
    "missing scenario file": (lambda p: ["--scenario", str(p / "nope.toml")], "nope.toml"),
    "bad TOML": (
        lambda p: ["--scenario", str(_write(p / "bad.toml", "name = 'x'\n[robot\n"))],
        "line 2",
    ),
    "unknown key": (
        lambda p: ["--scenario", str(scenario_file(p, k_z="k_zz = 0.04"))],
        "did you mean 'k_z'?",
    ),
    "unknown frame": (
        lambda p: ["--scenario", str(scenario_file(p, end_effector='end_effector = "tip"'))],
        "'tip'",
    ),
    "initial error outside the funnel": (
        lambda p: [
            "--scenario",
            str(
                scenario_file(
                    p, rho_z0="rho_z0 = [0.1, 0.1, 0.1]", rho_zinf="rho_zinf = [0.02, 0.02, 0.02]"
                )
            ),
        ],
        "funnel",
    ),
    "infeasible robot": (
        lambda p: [
            "--scenario",
            str(
                scenario_file(
                    p,
                    urdf=f'urdf = "{three_link_urdf(p).name}"',
                    joints="joints = [1.0, -1.0, 1.0]",
                    joint_rates="joint_rates = [0.0, 0.0, 0.0]",
                )
            ),  # fmt: skip
        ],
        "needs at least 4",
    ),
    "range": (
        lambda p: ["--scenario", str(scenario_file(p, sigma_b="sigma_b = [1.5]"))],
        "sigma_b",
    ),
    "missing URDF": (
        lambda p: ["--scenario", str(scenario_file(p, urdf='urdf = "nowhere.urdf"'))],
        "nowhere.urdf",
    ),
    "unknown case": (lambda p: ["--case", "7"], "--case"),
    "bad number": (lambda p: ["--dt", "fast"], "--dt"),
    "negative duration": (lambda p: ["--duration", "-1"], "--duration"),
    "unknown option": (lambda p: ["--plots"], "unrecognized arguments"),
    "two scenarios": (lambda p: ["--case", "2", "--compare"], "not allowed"),
    "dt above duration": (lambda p: ["--duration", "0.01", "--dt", "0.1"], "dt"),
}


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


@pytest.mark.parametrize("what", list(BAD_INPUTS))
def test_bad_input_is_one_line_and_status_2(tmp_path, what):
    make_args, fragment = BAD_INPUTS[what]
    proc = sim(*make_args(tmp_path), "--no-plots", "--no-html", "--out", "o", cwd=tmp_path)
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("error: ") and fragment in lines[0], lines[0]
    assert proc.stdout == ""
    assert not (tmp_path / "o" / "summary.json").exists()


# ------------------------------------------------------------------------------ divergence
def test_divergent_run_stops_and_writes_what_it_has(tmp_path):
    path = scenario_file(tmp_path, "diverge.toml", k_z="k_z = 1e6", dt="dt = 0.01")
    proc = sim("--scenario", str(path), "--duration", "3", "--quiet", "--out", "d", cwd=tmp_path)
    assert proc.returncode == 3, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and "stopped early" in lines[0] and re.search(r"t = [\d.]+ s", lines[0])
    out = tmp_path / "d"
    summary = check_consistent(out, duration=3.0, dt=0.01, scheme="ppc")
    assert summary["completed"] is False and summary["stop_reason"]
    assert summary["steps"] < 300
    for name in (*FIGURES, "replay.html"):
        assert (out / name).is_file(), name

    # without --quiet: the table says so too, the last stderr line is the stop line
    proc = sim("--scenario", str(path), "--duration", "3", "--no-html", "--out", "d2", cwd=tmp_path)
    assert proc.returncode == 3
    assert re.search(r"completed\s+no, stopped at", proc.stdout)
    last = [s for s in re.split(r"[\r\n]", proc.stderr) if s.strip()][-1]
    assert "stopped early" in last


def test_help_names_every_builtin_case():
    """--case's help is made from the built-in scenarios, so a new one cannot be left out."""
    from ffsm_pin.scenario.file import BUILTIN
    from ffsm_pin.sim.cli import _CASE_ALIASES, build_parser

    text = " ".join(build_parser().format_help().split())
    aliases = {v: k for k, v in _CASE_ALIASES.items()}
    for name in BUILTIN:
        assert aliases.get(name, name) in text.replace("- ", "-"), name


@pytest.mark.parametrize("what", ["initial error outside the funnel", "infeasible robot"])
def test_bad_input_found_while_preparing_is_one_line_from_a_cold_cache(tmp_path, what):
    """From an empty numba cache the "compiling" note comes right before the controller is
    built, after every check that does not need it, so bad input found while the run is
    prepared is still one line."""
    make_args, fragment = BAD_INPUTS[what]
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "empty-cache")}
    proc = subprocess.run(
        [sys.executable, "-m", "ffsm_pin.sim", *make_args(tmp_path), "--out", "o"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines() == [proc.stderr.strip()], proc.stderr
    assert proc.stderr.startswith("error: ") and fragment in proc.stderr
