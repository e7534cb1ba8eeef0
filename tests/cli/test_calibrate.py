"""``kinematics calibrate`` and ``kinematics calibration-poses``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from kinematics import default_catalogue
from kinematics.algorithms.calibration.synthetic import experiment
from kinematics.cli import main
from kinematics.engine.poe import compile_model
from kinematics.io.urdf import load_urdf


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    model = default_catalogue().get("ur5")
    rng = np.random.default_rng(21)
    truth, Q, P = experiment(model, "tool0", "position", 60, rng, outliers=[7])
    path = tmp_path_factory.mktemp("cal") / "measurements.csv"
    rows = [",".join(model.joint_names) + ",x,y,z"] + [",".join(repr(float(v)) for v in [*q, *p]) for q, p in zip(Q, P)]
    path.write_text("\n".join(rows) + "\n")
    return model, truth, Q, path


def test_calibrate_writes_a_urdf_table_and_plot(tmp_path, capsys, measured):
    model, truth, Q, csv = measured
    out, js, png = tmp_path / "ur5_calibrated.urdf", tmp_path / "r.json", tmp_path / "r.png"
    code = main(["calibrate", "--model", "ur5", "--link", "tool0", str(csv), "-o", str(out), "--loss", "huber",
                 "--json", str(js), "--plot", str(png)])
    assert code == 0
    text = capsys.readouterr().out
    assert "27 identifiable" in text and "elbow_joint.offset" in text and "absorbed by the base frame" in text
    assert "outliers: 7" in text and "RMS before" in text
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    result = json.loads(js.read_text())
    calibrated = load_urdf(out)
    T = np.eye(4)
    T[:3, 3] = result["point"]
    pos, quat = np.array(result["base"]["position"]), result["base"]["quaternion"]
    from kinematics.spatial.rotations import quaternion_to_matrix

    B = np.eye(4)
    B[:3, :3] = quaternion_to_matrix(quat["w"], quat["x"], quat["y"], quat["z"])
    B[:3, 3] = pos
    pred = B @ compile_model(calibrated).fk(Q, ["tool0"], tool=T)[:, 0]
    assert np.abs(pred[:, :3, 3] - truth.predict(Q)[:, :3, 3]).max() < 1e-4


def test_calibration_poses_writes_a_csv(tmp_path, capsys):
    out = tmp_path / "poses.csv"
    assert main(["calibration-poses", "--model", "ur5", "--link", "tool0", "-n", "10", "-o", str(out)]) == 0
    lines = out.read_text().splitlines()
    assert lines[0].startswith("shoulder_pan_joint,") and len(lines) == 11
    assert "D-optimal" in capsys.readouterr().err


def test_bad_measurements_exit_2_naming_the_problem(tmp_path, capsys, measured):
    model, truth, Q, csv = measured
    bad = tmp_path / "few.csv"
    bad.write_text("\n".join(csv.read_text().splitlines()[:6]) + "\n")
    assert main(["calibrate", "--model", "ur5", "--link", "tool0", str(bad)]) == 2
    assert "equations" in capsys.readouterr().err


def test_calibrate_with_compliance_and_prior(tmp_path, capsys):
    """FIGAROH's TIAGo training session as a CSV: --compliance JOINTS and --prior reach the fit."""
    from bench.figaroh_tiago import FIXTURES, LINK, SESSIONS, read_session
    from kinematics import default_catalogue

    tiago = default_catalogue().get("tiago")
    Q, points = read_session(FIXTURES / SESSIONS[0][2], tiago)
    csv = tmp_path / "tiago.csv"
    csv.write_text("\n".join([",".join([*tiago.joint_names, "x", "y", "z"])]
                             + [",".join(repr(float(v)) for v in [*q, *p]) for q, p in zip(Q, points[:, 0])]) + "\n")
    assert main(["calibrate", "--model", "tiago", "--link", LINK, str(csv), "--compliance", "arm_2_joint,arm_4_joint",
                 "--prior"]) == 0
    out = capsys.readouterr().out
    assert "arm_2_joint.compliance" in out and "mrad/Nm" in out and "arm_3_joint.compliance" not in out
