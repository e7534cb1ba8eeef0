"""`kinematics ik --all` on a 7-joint arm: --redundancy, --values (a parameter column), --intervals,
--select, and malformed options."""

from __future__ import annotations

import csv
import json

import numpy as np

from kinematics import compile_model, default_catalogue
from kinematics.algorithms.ik import pose_errors
from tests.helpers import run_cli as run

Q = np.array([0.1, -0.4, 0.2, -2.0, 0.3, 1.5, 0.7, 0.02])


def _target(tmp_path):
    panda = default_catalogue().get("panda")
    T = compile_model(panda).fk(Q[None], ["panda_link8"])[:, 0]
    np.save(tmp_path / "p.npy", T)
    return panda, T


def test_values_give_a_parameter_column(tmp_path, capsys):
    panda, T = _target(tmp_path)
    code, _, err = run(["ik", "--model", "panda", "--link", "panda_link8", "--all", "--redundancy", "joint:panda_joint7",
                        "--values", "0.7,1.1", tmp_path / "p.npy", "-o", tmp_path / "a.csv"], capsys)
    assert code == 0, err
    rows = list(csv.reader(open(tmp_path / "a.csv")))
    assert rows[0][-1] == "parameter"
    body = rows[1:]
    assert {float(r[-1]) for r in body} == {0.7, 1.1}
    q = np.array([[float(v) for v in r[1:9]] for r in body])
    assert np.all(q[:, 6] == np.array([float(r[-1]) for r in body]))
    p, rot = pose_errors(compile_model(panda).fk(q, ["panda_link8"])[:, 0], np.repeat(T, len(q), 0))
    assert p.max() < 1e-9 and rot.max() < 1e-9


def test_select_margin_with_intervals(tmp_path, capsys):
    panda, T = _target(tmp_path)
    code, _, err = run(["ik", "--model", "panda", "--link", "panda_link8", "--all", "--intervals", "--select", "margin",
                        tmp_path / "p.npy", "-o", tmp_path / "a.jsonl"], capsys)
    assert code == 0, err
    recs = [json.loads(line) for line in open(tmp_path / "a.jsonl")]
    assert len(recs) == 1 and recs[0]["within_limits"]
    ranges = json.loads(next(line for line in err.splitlines() if line.startswith("{")))["intervals"]
    assert any(r["from"] <= recs[0]["parameter"] <= r["to"] for r in ranges)


def test_malformed_redundancy_options(tmp_path, capsys):
    _target(tmp_path)
    code, _, err = run(["ik", "--model", "panda", "--link", "panda_link8", "--all", "--redundancy", "panda_joint7",
                        "--values", "0.1", tmp_path / "p.npy", "-o", tmp_path / "a.csv"], capsys)
    assert code == 2 and "joint:NAME" in err
    code, _, err = run(["ik", "--model", "panda", "--link", "panda_link8", "--values", "0.1", tmp_path / "p.npy",
                        "-o", tmp_path / "a.csv"], capsys)
    assert code == 2 and "need --all" in err
