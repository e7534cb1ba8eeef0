"""``kinematics symbolic``, ``kinematics poe2urdf`` and ``kinematics axes2urdf``."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from kinematics import compile_model, parse_urdf
from kinematics.cli import main
from tests.paths import FIXTURES

DESCRIPTIONS = FIXTURES / "poe_axes"


def test_symbolic_of_a_preset_in_latex(capsys):
    assert main(["symbolic", "scara", "--what", "transforms,task", "--representation", "scara"]) == 0
    out = capsys.readouterr().out
    assert "joint variables: q1 = joint_1, q2 = joint_2, q3 = joint_3, q4 = joint_4" in out
    assert r"T (world -> tool) =" in out and r"\begin{bmatrix}c_{124} & s_{124}" in out
    assert "task vector (scara): px, py, pz, alpha_z" in out and "q_{1} + q_{2} + q_{4}" in out


def test_symbolic_dh_file_with_parameters_as_json(tmp_path, capsys):
    table = tmp_path / "rpr.yaml"
    table.write_text(yaml.safe_dump({"angles": "degrees", "joints": [
        {"type": "R", "a": 0, "alpha": 90, "d": "d1", "theta": 0},
        {"type": "P", "a": 0, "alpha": 0, "d": 0, "theta": 0},
        {"type": "R", "a": 0, "alpha": 0, "d": "d3", "theta": 0}]}))
    assert main(["symbolic", str(table), "--format", "text", "--json"]) == 0
    body = json.loads(capsys.readouterr().out)
    assert body["T"][0] == ["cos(q1)*cos(q3)", "-sin(q3)*cos(q1)", "sin(q1)", "(d3 + q2)*sin(q1)"]
    assert body["parameters"] == ["d1", "d3"]


def test_symbolic_c_code_to_a_file(tmp_path, capsys):
    out = tmp_path / "ur5.c"
    assert main(["symbolic", "ur5", "--tip", "tool0", "--format", "c", "--prefix", "ur5_", "--no-simplify",
                 "-o", str(out)]) == 0
    assert "void ur5_fk(const double *q, double *T)" in out.read_text()
    assert "wrote" in capsys.readouterr().err


def test_symbolic_of_poe_and_axes_files(capsys):
    assert main(["symbolic", str(DESCRIPTIONS / "mr_3r_spatial.yaml"), "--format", "text"]) == 0
    assert "q1 = j1, q2 = j2, q3 = j3" in capsys.readouterr().out
    assert main(["symbolic", str(DESCRIPTIONS / "wen_scara.yaml"), "--format", "python"]) == 0
    assert "def fk(q):" in capsys.readouterr().out


@pytest.mark.parametrize("kind, name, dof", [("poe", "mr_3r_spatial", 3), ("axes", "wen_rhino", 6)])
def test_description_to_urdf(kind, name, dof, tmp_path, capsys):
    assert main([f"{kind}2urdf", str(DESCRIPTIONS / f"{name}.yaml")]) == 0
    model = parse_urdf(capsys.readouterr().out)
    assert model.name == name and model.dof == dof and model.leaf_links == ("tool",)
    out = tmp_path / "robot.urdf"
    assert main([f"{kind}2urdf", str(DESCRIPTIONS / f"{name}.yaml"), "-o", str(out)]) == 0
    np.testing.assert_allclose(compile_model(parse_urdf(out.read_text())).M, compile_model(model).M)


@pytest.mark.parametrize("argv, message", [
    (["symbolic", "ur5"], "choose the tip"),
    (["symbolic", "nowhere.txt"], "neither a catalogue id"),
    (["symbolic", "scara", "--what", "task", "--representation", "rpy", "--components", "theta"], "not a component"),
    (["poe2urdf", "missing.yaml"], "cannot read"),
    (["axes2urdf", str(DESCRIPTIONS / "mr_3r_spatial.yaml")], "unknown field"),
])
def test_errors_exit_2(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"kinematics {argv[0]}: error:") and message in err
