"""`kinematics fk/jacobian/ik --xacro FILE [--arg k=v] [--package-path DIR]` and `--mjcf FILE`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kinematics import compile_model
from kinematics.cli import main
from kinematics.io.xacro import load_xacro
from tests.paths import FIXTURES

XACRO = FIXTURES / "descriptions" / "two_link.urdf.xacro"
RTB = Path(np.__file__).resolve().parents[1] / "rtbdata" / "xacro"


def _run(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


def test_fk_of_a_xacro_file_with_an_argument(tmp_path, capsys):
    q = tmp_path / "q.csv"
    q.write_text("0.1,0.2\n-0.3,0.4\n")
    out = tmp_path / "T.npy"
    code, _, err = _run(["fk", "--xacro", XACRO, "--arg", "length=0.8", "--links", "lower", q, "-o", out], capsys)
    assert code == 0, err
    model = load_xacro(XACRO, args={"length": 0.8})
    np.testing.assert_allclose(np.load(out)[:, 0], compile_model(model).fk(np.array([[0.1, 0.2], [-0.3, 0.4]]), ["lower"])[:, 0],
                               atol=1e-12)


@pytest.mark.skipif(not RTB.is_dir(), reason="rtb-data is not installed")
def test_jacobian_of_a_xacro_with_find_resolved_by_package_path(tmp_path, capsys):
    q = tmp_path / "q.csv"
    q.write_text("0,0.1,0.2,0.3,0.4,0.5\n")
    entry = RTB / "kuka_description" / "kuka_kr6" / "urdf" / "kr6r700sixx.xacro"
    code, out, err = _run(["jacobian", "--xacro", entry, "--package-path", RTB, q], capsys)
    assert code == 0, err
    assert len(out.strip().splitlines()) == 2  # header + one row
    code, _, err = _run(["jacobian", "--xacro", entry, q], capsys)
    assert code == 3 and "package 'kuka_kr6_support' is not in the description" in err


def test_ik_takes_the_same_options(tmp_path, capsys):
    target = tmp_path / "t.csv"
    target.write_text("0.1,0,0.8,1,0,0,0\n")
    code, _, err = _run(["ik", "--xacro", XACRO, "--arg", "length=0.5", "--link", "lower", "--mode", "position",
                         target], capsys)
    assert code in (0, 1), err  # solved or not, the model loaded


def test_mjcf_file(tmp_path, capsys):
    mjcf = tmp_path / "arm.xml"
    mjcf.write_text('<mujoco><worldbody><body name="a"><joint name="j" axis="0 0 1" range="-90 90"/>'
                    '<body name="tip" pos="1 0 0"/></body></worldbody></mujoco>')
    q = tmp_path / "q.csv"
    q.write_text(f"{np.pi / 2}\n")
    code, out, err = _run(["fk", "--mjcf", mjcf, "--links", "tip", q], capsys)
    assert code == 0, err
    row = [float(v) for v in out.strip().splitlines()[1].split(",")]
    np.testing.assert_allclose(row[:3], [0, 1, 0], atol=1e-12)


@pytest.mark.parametrize("argv, message", [
    (["--urdf", XACRO], "this is a xacro file"),
    (["--xacro", XACRO, "--arg", "length"], "is not NAME=VALUE"),
    (["--urdf", FIXTURES / "planar_2r.urdf", "--arg", "a=1"], "apply to a xacro file"),
    (["--xacro", FIXTURES / "no_such.xacro"], "cannot read"),
])
def test_errors_exit_3_naming_the_problem(argv, message, tmp_path, capsys):
    q = tmp_path / "q.csv"
    q.write_text("0,0\n")
    code, _, err = _run(["fk", *argv, q], capsys)
    assert code == 3 and message in err, err
