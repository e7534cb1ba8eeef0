"""`kinematics ik --all` (one row per solution with its target index) and `kinematics ik-path`."""

from __future__ import annotations

import csv
import json

import numpy as np

from kinematics import compile_model, default_catalogue
from kinematics.algorithms.ik import pose_errors
from tests.helpers import run_cli as run

Q0 = np.array([[0.3, -1.0, 1.2, -0.5, 0.8, 0.2], [0.1, -1.5, 1.0, 0.2, 1.1, -0.4]])


def _targets(tmp_path):
    ur5 = default_catalogue().get("ur5")
    T = compile_model(ur5).fk(Q0, ["tool0"])[:, 0]
    path = tmp_path / "T.npy"
    np.save(path, T)
    return ur5, T, path


def test_ik_all_rows(tmp_path, capsys):
    ur5, T, path = _targets(tmp_path)
    out = tmp_path / "all.csv"
    code, _, err = run(["ik", "--model", "ur5", "--link", "tool0", "--all", "--limits", "ignore", path, "-o", out], capsys)
    assert code == 0, err
    rows = list(csv.reader(open(out)))
    assert rows[0] == ["target", *ur5.joint_names, "position_error", "rotation_error", "within_limits", "singular"]
    body = rows[1:]
    assert [int(r[0]) for r in body] == [0] * 8 + [1] * 8
    q = np.array([[float(v) for v in r[1:7]] for r in body])
    p, r = pose_errors(compile_model(ur5).fk(q, ["tool0"])[:, 0], T[[int(r[0]) for r in body]])
    assert p.max() < 1e-9 and r.max() < 1e-9
    assert "16 solutions of 2 targets (three_parallel, analytic)" in err


def test_ik_all_locked_jsonl_and_bad_locked(tmp_path, capsys):
    panda = default_catalogue().get("panda")
    q = np.array([0.1, -0.4, 0.2, -2.0, 0.3, 1.5, 0.7, 0.02])
    np.save(tmp_path / "p.npy", compile_model(panda).fk(q[None], ["panda_link8"])[:, 0])
    out = tmp_path / "p.jsonl"
    code, _, err = run(["ik", "--model", "panda", "--link", "panda_link8", "--locked", "panda_joint7:0.7", "--all",
                        tmp_path / "p.npy", "-o", out], capsys)
    assert code == 0, err
    recs = [json.loads(line) for line in open(out)]
    assert recs and all(r["q"]["panda_joint7"] == 0.7 and r["within_limits"] for r in recs)
    code, out_text, err = run(["ik", "--model", "panda", "--link", "panda_link8", "--locked", "panda_joint9:0", "--all",
                               tmp_path / "p.npy"], capsys)
    assert code == 2 and "panda_joint9" in err and out_text == ""
    code, _, err = run(["ik", "--model", "panda", "--locked", "oops", "--all", tmp_path / "p.npy"], capsys)
    assert code == 2 and "JOINT:VALUE" in err


def test_ik_path(tmp_path, capsys):
    ur5, T, _ = _targets(tmp_path)
    W = np.array([T[0], T[0].copy()])
    W[1, :3, 3] += [0.04, 0.0, -0.03]
    np.save(tmp_path / "w.npy", W)
    out = tmp_path / "path.csv"
    code, _, err = run(["ik-path", "--model", "ur5", "--link", "tool0", "--seed=" + ",".join(map(str, Q0[0])),
                        tmp_path / "w.npy", "-o", out], capsys)
    assert code == 0, err
    rows = list(csv.reader(open(out)))
    assert rows[0] == list(ur5.joint_names) and len(rows) - 1 == 6
    np.testing.assert_allclose([float(v) for v in rows[1]], Q0[0], atol=1e-9)
    assert "fraction 1" in err
    W[1, :3, 3] = [3.0, 0.0, 0.0]
    np.save(tmp_path / "w.npy", W)
    code, _, err = run(["ik-path", "--model", "ur5", "--link", "tool0", tmp_path / "w.npy", "-o", out], capsys)
    assert code == 1 and "unreachable" in err
