"""``kinematics velocity``: files of joint values and velocities in, link twists out."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from kinematics import api
from tests.helpers import run_cli as run

N = 30


@pytest.fixture(scope="module")
def states(ur5):
    rng = np.random.default_rng(5)
    Q = ur5.sample_configurations(N, rng)
    return Q, rng.uniform(-1, 1, Q.shape)


def test_npy_in_csv_out_with_verify(tmp_path, capsys, ur5, states):
    Q, Qd = states
    np.save(tmp_path / "s.npy", np.hstack([Q, Qd]))
    code, _, err = run(["velocity", "--model", "ur5", "--links", "tool0,wrist_2_link", tmp_path / "s.npy",
                        "-o", tmp_path / "v.csv", "--verify=10"], capsys)
    assert code == 0, err
    assert "max twist error" in err
    with open(tmp_path / "v.csv") as fh:
        rows = list(csv.reader(fh))
    assert rows[0][:7] == ["tool0.vx", "tool0.vy", "tool0.vz", "tool0.wx", "tool0.wy", "tool0.wz", "wrist_2_link.vx"]
    got = np.array(rows[1:], dtype=float).reshape(N, 2, 6)
    expected = api.velocity(ur5, Q, Qd, links=["tool0", "wrist_2_link"]).twists["local_world_aligned"]
    np.testing.assert_array_equal(got, expected)  # shortest round-trip reprs


def test_csv_header_in_any_order_to_npy_every_link(tmp_path, capsys, ur5, states):
    Q, Qd = states
    names = list(ur5.joint_names)
    header = [n + ".qdot" for n in names][::-1] + names
    with open(tmp_path / "s.csv", "w") as fh:
        fh.write(",".join(header) + "\n")
        for q, qd in zip(Q, Qd):
            fh.write(",".join(map(repr, qd[::-1].tolist() + q.tolist())) + "\n")
    code, _, err = run(["velocity", "--model", "ur5", "--reference", "world", tmp_path / "s.csv", "-o",
                        tmp_path / "v.npy"], capsys)
    assert code == 0, err
    V = np.load(tmp_path / "v.npy")
    assert V.shape == (N, len(ur5.links), 6)
    np.testing.assert_array_equal(V, api.velocity(ur5, Q, Qd).twists["world"])


def test_jsonl_forms_and_a_point(tmp_path, capsys, ur5, states):
    Q, Qd = states
    names = list(ur5.joint_names)
    with open(tmp_path / "s.jsonl", "w") as fh:
        fh.write(json.dumps(list(Q[0]) + list(Qd[0])) + "\n\n")
        fh.write(json.dumps({"q": dict(zip(names, Q[1])), "qdot": list(Qd[1])}) + "\n")
    code, _, err = run(["velocity", "--model", "ur5", "--links", "tool0", "--point", "0,0,0.1", "--reference", "local",
                        tmp_path / "s.jsonl", "-o", tmp_path / "v.jsonl"], capsys)
    assert code == 0, err
    lines = [json.loads(l) for l in open(tmp_path / "v.jsonl")]
    expected = api.velocity(ur5, Q[:2], Qd[:2], links=["tool0"], point=[0, 0, 0.1]).twists["local"]
    np.testing.assert_array_equal([l["twists"]["tool0"] for l in lines], expected[:, 0])


@pytest.mark.parametrize("content, fragment", [
    ("a,b\n", "line 1 (header), column 1: unknown column 'a'"),
    ("1,2,3\n", "line 1: expected 12 columns"),
    ("0,0,0,0,0,0,0,0,0,0,0,0\n0,0,0,0,0,0,0,0,0,0,0,x\n", "line 2, column 12 (velocity of joint 'wrist_3_joint'): 'x' is not a number"),
    ("0,0,0,0,0,0,0,0,0,0,0,nan\n", "line 1, column 12 (velocity of joint 'wrist_3_joint'): value nan is not finite"),
])
def test_bad_csv_is_named(tmp_path, capsys, content, fragment):
    (tmp_path / "s.csv").write_text(content)
    code, _, err = run(["velocity", "--model", "ur5", tmp_path / "s.csv"], capsys)
    assert code == 2
    assert fragment in err


def test_bad_options_and_files(tmp_path, capsys):
    np.save(tmp_path / "s.npy", np.zeros((3, 6)))
    code, _, err = run(["velocity", "--model", "ur5", tmp_path / "s.npy"], capsys)
    assert code == 2 and "expected an array of shape (N, 12)" in err
    (tmp_path / "s.jsonl").write_text('{"q": [0, 0, 0, 0, 0, 0]}\n')
    code, _, err = run(["velocity", "--model", "ur5", tmp_path / "s.jsonl"], capsys)
    assert code == 2 and "line 1" in err
    code, _, err = run(["velocity", "--model", "ur5", "--point", "0,1", tmp_path / "s.npy"], capsys)
    assert code == 2 and "--point" in err
    code, _, err = run(["velocity", "--model", "ur5", "--links", "nope", tmp_path / "s.npy"], capsys)
    assert code == 2 and "nope" in err
    code, _, err = run(["velocity", "--model", "nope", tmp_path / "s.npy"], capsys)
    assert code == 3
