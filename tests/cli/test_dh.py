"""``kinematics dh2urdf`` and ``kinematics urdf2dh``."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from kinematics import compile_model, parse_urdf
from kinematics.io.catalogue import DEFAULT_PRESETS_DIR
from kinematics.cli import main
from kinematics.algorithms.dh import dh_tool_pose
from kinematics.io.dh_table import load_table

from tests.paths import FIXTURES

SCARA = DEFAULT_PRESETS_DIR / "scara.yaml"


def test_dh2urdf_to_stdout(capsys):
    assert main(["dh2urdf", str(SCARA)]) == 0
    out = capsys.readouterr().out
    model = parse_urdf(out)
    table = load_table(SCARA)
    Q = np.array([[0.3, -0.5, -0.1, 1.0]])
    np.testing.assert_allclose(compile_model(model).fk(Q, ["tool"])[:, 0], dh_tool_pose(table, Q), atol=1e-12)


def test_dh2urdf_to_file(tmp_path, capsys):
    out = tmp_path / "scara.urdf"
    assert main(["dh2urdf", str(SCARA), "-o", str(out)]) == 0
    assert parse_urdf(out.read_text()).joint_names == ("joint_1", "joint_2", "joint_3", "joint_4")
    assert capsys.readouterr().out == ""


def test_urdf2dh_human_table(capsys):
    assert main(["urdf2dh", "ur5", "--tip", "tool0", "--degrees"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    header = next(line for line in lines if line.startswith("i  joint"))
    for col in ("a [m]", "alpha [deg]", "d [m]", "theta [deg]", "limits"):
        assert col in header
    row1 = next(line for line in lines if "shoulder_pan_joint" in line)
    assert "0.089159" in row1 and "-90" in row1 and "+ q" in row1
    assert "base = T_world_frame0:" in out and "tool = T_frame6_tool:" in out
    # columns are aligned: every table row has the header's width or less, the separator matches
    sep = lines[lines.index(header) + 1]
    assert set(sep.replace(" ", "")) == {"-"} and len(sep) >= max(len(l) for l in lines[lines.index(header) + 2:][:6])


def test_urdf2dh_modified_headers(capsys):
    assert main(["urdf2dh", "panda", "--tip", "panda_link8", "--convention", "modified"]) == 0
    out = capsys.readouterr().out
    assert "a_{i-1} [m]" in out and "alpha_{i-1} [rad]" in out and "convention: modified" in out


def test_urdf2dh_json_feeds_dh2urdf(tmp_path, capsys, catalogue):
    urdf = FIXTURES / "dh" / "special_axes.urdf"
    assert main(["urdf2dh", str(urdf), "--convention", "modified", "--degrees", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["convention"] == "modified" and data["angles"] == "degrees"
    (tmp_path / "t.json").write_text(json.dumps(data))
    assert main(["dh2urdf", str(tmp_path / "t.json"), "-o", str(tmp_path / "r.urdf")]) == 0
    rebuilt = parse_urdf((tmp_path / "r.urdf").read_text())
    original = parse_urdf(urdf.read_text())
    Q = original.sample_configurations(10, np.random.default_rng(3))
    np.testing.assert_allclose(
        compile_model(rebuilt).fk(Q, ["tool"])[:, 0], compile_model(original).fk(Q, ["tcp"])[:, 0], atol=1e-9
    )


@pytest.mark.parametrize(
    "argv, message",
    [
        (["dh2urdf", str(FIXTURES / "dh" / "bad_table.yaml")], "joints[1].alpha"),
        (["dh2urdf", "no/such/table.yaml"], "cannot read"),
        (["urdf2dh", "no_such_model"], "neither a URDF file nor a catalogue id"),
        (["urdf2dh", "panda"], "choose its tip"),
        (["urdf2dh", "ur5", "--tip", "nowhere"], "nowhere"),
        (["urdf2dh", str(FIXTURES / "dh" / "bad_table.yaml")], "URDF"),
    ],
)
def test_errors_exit_2_with_a_message(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.startswith(f"kinematics {argv[0]}: error:")


def test_console_entry_point_has_no_traceback():
    proc = subprocess.run(
        [sys.executable, "-m", "kinematics", "urdf2dh", "panda"], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "tip" in proc.stderr


def test_urdf2dh_check_reports_the_deviation(capsys):
    assert main(["urdf2dh", "z1", "--check", "20", "--json"]) == 0
    captured = capsys.readouterr()
    json.loads(captured.out)  # stdout stays pure JSON
    line = captured.err.strip()
    assert line.startswith("check: standard DH vs URDF FK of 'gripperMover' at 20 random configurations")
    pos = float(line.split("max position error ")[1].split(" m")[0])
    rot = float(line.split("max rotation error ")[1])
    assert 0 <= pos < 1e-9 and 0 <= rot < 1e-9
    assert main(["urdf2dh", "z1", "--check", "0"]) == 2
