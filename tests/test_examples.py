"""Every script of ``examples/`` runs to completion and prints what it claims.

Each runs in its own process (``python examples/NN_*.py``, as a reader runs it) with the
repository first on ``PYTHONPATH``; the one that talks to the service gets a live server
started here, named by ``KIN_BASE_URL``. The documentation site includes these files, so the
code shown there is the code tested here.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest
from tests.live import LiveServer
from tests.paths import REPO

EXAMPLES = REPO / "examples"
#: a generous bound for one script (numba compiles kernels on a cold cache; the machine may be busy)
TIMEOUT = 600


def run_example(name: str, env: dict[str, str] | None = None) -> str:
    environment = {k: v for k, v in os.environ.items() if not k.startswith("KIN_")}
    environment["PYTHONPATH"] = os.pathsep.join([str(REPO), environment.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    environment.update(env or {})
    proc = subprocess.run([sys.executable, str(EXAMPLES / name)], cwd=REPO, env=environment, capture_output=True,
                          text=True, timeout=TIMEOUT)
    assert proc.returncode == 0, f"{name} exited with {proc.returncode}:\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


def deviation(output: str, label: str) -> float:
    """The number printed after ``label`` (e.g. ``FK deviation from Pinocchio: 1.1e-16``)."""
    match = re.search(re.escape(label) + r"\s*([0-9.]+e[-+][0-9]+)", output)
    assert match, f"no {label!r} in:\n{output}"
    return float(match.group(1))


def test_every_example_is_tested_and_sized():
    scripts = sorted(p.name for p in EXAMPLES.glob("[0-9][0-9]_*.py"))
    tested = {name for name in globals() if name.startswith("test_example_")}
    assert len(scripts) >= 8
    for script in scripts:
        assert any(t.startswith(f"test_example_{script[:2]}_") for t in tested), f"{script} has no test"
        lines = (EXAMPLES / script).read_text().count("\n")
        assert 20 <= lines <= 80, f"{script}: {lines} lines (an example is 20-80 lines)"


def test_every_example_is_shown_in_the_documentation():
    pages = "".join(p.read_text() for p in (REPO / "docs").rglob("*.md"))
    for script in sorted(EXAMPLES.glob("[0-9][0-9]_*.py")):
        assert f'--8<-- "examples/{script.name}"' in pages, f"no page includes {script.name}"


def test_example_01_ur5_fk_and_jacobian():
    out = run_example("01_ur5_fk_jacobian.py")
    assert "tool0 position (m): [0.474548 0.10915  0.419509]" in out
    assert deviation(out, "FK deviation from Pinocchio:") < 1e-9
    for reference in ("world", "local", "local_world_aligned"):
        line = next(line for line in out.splitlines() if line.startswith(f"J[{reference}]"))
        assert float(line.rsplit("Pinocchio", 1)[1].strip(" )")) < 1e-9
    assert "batch: (1000, 6, 6)" in out
    assert "finite difference agrees: True" in out


def test_example_02_ik():
    out = run_example("02_ik.py")
    assert re.search(r"success True: position error [0-9.e-]+ m", out)
    assert deviation(out, "Pinocchio's FK of the answer is") < 1e-6
    assert "batch: solved 200/200" in out
    assert "successful answers on target: True" in out
    assert "panda reachable: success True" in out
    assert "panda 3 m away: success False" in out


def test_example_03_floating_base():
    out = run_example("03_floating_base.py")
    assert "nq = 19, nv = 18" in out
    assert deviation(out, "FK deviation from Pinocchio:") < 1e-9
    assert "base pose moves every foot rigidly: True" in out
    assert "J shape (6, 18)" in out and deviation(out, "vs Pinocchio") < 1e-9
    assert "foot velocities (m/s): [[0.0, 0.0, 0.2], [0.0, 0.0, 0.2], [0.0, 0.0, 0.2], [0.0, 0.0, 0.2]]" in out
    assert deviation(out, "velocities vs Pinocchio") < 1e-9
    assert "refused: joint 'root_joint'" in out and "normalized:" in out


def test_example_04_closed_forms_of_a_dh_table():
    pytest.importorskip("sympy", reason="the closed forms need sympy")
    out = run_example("04_closed_forms_dh.py")
    assert "parameters: ['a1', 'a2', 'd1', 'd4']" in out
    assert "a1*cos(q1) + a2*cos(q1 + q2)" in out and "d1 + d4 + q3" in out
    assert "q1 + q2 + q4" in out  # alpha_z of the SCARA
    assert deviation(out, "closed form vs compiled FK over 100 configurations:") < 1e-12


def test_example_05_parquet_log_through_fk():
    pytest.importorskip("pyarrow", reason="the logs extra")
    out = run_example("05_parquet_log_fk.py")
    assert "100000 rows, columns: ['time', 'tool0.x'" in out
    assert "matches FK: True" in out
    assert "time column carried: True" in out
    assert "command line output identical: True" in out


def run_with_service(name: str, tmp_path) -> str:
    """``run_example(name)`` talking to a live service started for it (``KIN_BASE_URL``)."""
    with LiveServer(tmp_path / "data", tmp_path / "uvicorn.log") as live:
        return run_example(name, {"KIN_BASE_URL": live.url})


def test_example_06_rest_client(tmp_path):
    out = run_with_service("06_rest_client.py", tmp_path)
    assert "service: ok" in out
    assert "FK: (1000, 1, 4, 4) links ['tool0'] verified: pinocchio" in out
    assert "Jacobians: (1000, 6, 6)" in out
    assert "IK: solved 1000/1000" in out and deviation(out, "worst position error of the solved") < 1e-5
    assert "uploaded: dh-" in out
    assert "2R tip at q = (0, 90 deg): [0.5 0.4 0. ]" in out
    assert "velocity references: ['local', 'local_world_aligned', 'world'] (2, 1, 6)" in out
    assert "refused: 422" in out


def test_example_07_workspace():
    out = run_example("07_workspace.py")
    area = float(re.search(r"area ([0-9.]+) m\^2, exact 2.5133", out).group(1))
    assert abs(area / (3.141592653589793 * 0.8) - 1) < 0.01  # the annulus between 0.1 m and 0.9 m
    top = float(re.search(r"manipulability [0-9.]+ \.\. ([0-9.]+) \(at most 0.2\)", out).group(1))
    assert 0.19 < top <= 0.2
    reach = float(re.search(r"ur5: reach ([0-9.]+) m", out).group(1))
    assert 0.95 < reach < 1.1
    volumes = re.search(r"volume \(m\^3\) over N/4, N/2, N samples: \[(.*)\]", out).group(1).split(",")
    assert len(volumes) == 3 and all(float(v) > 0 for v in volumes)
    assert "FK of other samples within the sampled reach + 1 cm: True" in out


def test_example_08_task_vectors_and_analytic_jacobians():
    out = run_example("08_task_jacobian.py")
    for representation in ("rpy", "zyz", "quaternion", "rotvec"):
        line = next(line for line in out.splitlines() if line.startswith(representation + " "))
        assert float(line.rsplit("finite differences", 1)[1]) < 1e-8, line
    assert "quaternion r = " in out and "J_r (7, 6)" in out
    assert "planar 2R: r = [0.5      0.4      1.570796] J_r = [[-0.4, -0.4], [0.5, 0.0], [1.0, 1.0]]" in out
    assert "rows ('px', 'py', 'pz', 'yaw')" in out
    assert "refused: RepresentationSingularityError - the zyz representation is singular at configuration 0" in out


def test_example_09_calibration():
    out = run_example("09_calibration.py")
    chosen, random = map(float, re.search(r"log det ([0-9.]+) \(random ([0-9.]+)\)", out).groups())
    assert chosen > random
    assert "identifiable: 27 (4R + 3 = 27)" in out and "absorbed by the base frame" in out
    before, after = map(float, re.search(r"RMS before ([0-9.]+) mm, after ([0-9.]+) um", out).groups())
    assert before > 2 and after < 40  # millimetres before, the 35 um of the noise after
    nominal, calibrated = map(float, re.search(r"nominal model ([0-9.]+) mm off, calibrated ([0-9.]+) um off",
                                                out).groups())
    assert nominal > 2 and calibrated < 30


def test_example_17_calibration_compliance():
    out = run_example("17_calibration_compliance.py")
    assert "identifiable: 39" in out
    rows = re.findall(r"plain ([0-9.]+) mm, compliance \+ prior ([0-9.]+) mm \(FIGAROH ([0-9.]+)\)", out)
    assert len(rows) == 3
    for plain, ours, figaroh in (map(float, r) for r in rows):
        assert ours <= figaroh < plain  # the held-out sessions: FIGAROH's published full_params beaten


def test_example_10_ik_all():
    out = run_example("10_ik_all.py")
    assert "ur5 family: three_parallel" in out
    assert "8 solutions (analytic); first = seed: True" in out
    assert deviation(out, "worst Pinocchio deviation:") < 1e-9
    assert "within the limits, copies included: 256" in out
    assert "panda, q7 locked: spherical_shoulder_intersecting_12, 8 solutions" in out
    assert "3 m away: 0 solutions" in out
    assert re.search(r"path: \d+ rows, complete True", out)


def test_example_11_self_collision():
    out = run_example("11_self_collision.py")
    assert "colliding: [False, True]" in out
    assert "same pairs as Pinocchio: 100.0%" in out
    assert deviation(out, "distance deviation from Pinocchio:") < 1e-6


def test_example_14_collision_pairs():
    out = run_example("14_collision_pairs.py")
    assert "colliding pairs: [('base_link', 'upper_arm_link')]" in out
    assert "Pinocchio with coal agrees the pair collides: True" in out
    assert "still in collision: False | pairs checked: 18 -> 18" in out
    assert '<enable_collisions link1="wrist_1_link" link2="ee_link" reason="User"/>' in out


def test_example_12_collision_free():
    out = run_example("12_collision_free.py")
    assert "solutions: 8, free of self-collision: 4 (4 left out)" in out
    assert "Pinocchio finds the listed ones free: True" in out
    assert "plain answer free: False" in out and "with avoid_collisions: success True free True" in out
    assert "stopped {'index': 43, 'reason': 'collision'}" in out
    assert re.search(r"workspace: \d+ free samples kept, [1-9]\d* in self-collision dropped", out)


def test_example_13_client_every_operation(tmp_path):
    out = run_with_service("13_client_every_operation.py", tmp_path)
    lines = ["family: three_parallel solutions: 256", "path: (11, 6) complete: True", "calibrated: u-...",
             "panda colliding: [False False] pairs checked: 23", "never checked: ",
             "workspace: area 2.519 m^2 converged True cloud (20000, 3)",
             "T(q) of planar_2r, x: cos(q1)/2 + 2*cos(q1 + q2)/5", "task: ['px', 'py', 'pz', 'phi', 'theta', 'psi'] (6, 6)"]
    assert [line for line in lines if line not in out] == [], out
    assert deviation(out, "rmse") < 1e-9  # the device's offset frame, found exactly (no noise)


def test_example_15_redundancy():
    out = run_example("15_redundancy.py")
    assert "redundant: True default parameter: {'joint': 'panda_joint7'}" in out
    assert "generating configuration listed: True" in out
    assert deviation(out, "worst error:") < 1e-9
    assert re.search(r"best margin at q7 = 0\.69", out)
    assert "q7 locked: {'index': 5, 'reason': 'joint_jump'}" in out  # the path jumps with q7 held
    assert "self-motion: complete True" in out and deviation(out, "worst error") < 1e-9  # and not along it


def test_example_16_trajectory():
    out = run_example("16_trajectory.py")
    for label in ("time-optimal:", "jerk-limited:"):
        ratio = float(re.search(r"largest limit ratio at 1 kHz, " + re.escape(label) + r"\s*([0-9.]+)", out).group(1))
        assert 0.9 < ratio <= 1.0
    assert "at rest at both ends: True" in out
