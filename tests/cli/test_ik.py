"""IK CLI: ``kinematics ik`` over files of target poses.

Targets are the FK of random UR5 configurations (so each is reachable); every answer is checked
by FK of its joint values (within 1e-6 of its target). Bad files must give exit code 2 and a
message naming the line and column, never a traceback; an unreachable target exit code 1.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import re

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue
from tests.helpers import run_cli as run
from kinematics.io.catalogue import DEFAULT_PRESETS_DIR
from kinematics.io.result_files import IK_STATUS_COLUMNS
from kinematics.io.trajectory import open_target_rows, pose_rows
from kinematics.spatial.rotations import matrix_to_rpy, rotation_angle

TOL = 1e-6
N = 20
SUMMARY = re.compile(r"^ik: solved (\d+)/(\d+) targets \(([\d.]+)%\); worst position error (\S+) m, "
                     r"worst rotation error (\S+) rad \(of the solved\); median iterations (\S+)$")


@pytest.fixture(scope="module")
def targets(ur5):
    """(N, 4, 4) poses of tool0 at random configurations."""
    Q = ur5.sample_configurations(N, np.random.default_rng(11))
    return compile_model(ur5).fk(Q, ["tool0"])[:, 0]


def read_csv(path) -> tuple[list[str], list[list[str]]]:
    with open(path) as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def ik_csv(path, model):
    """q (N, dof), success (N,), errors (N, 2), iterations (N,) of an IK CSV output."""
    header, rows = read_csv(path)
    assert header == list(model.joint_names) + list(IK_STATUS_COLUMNS)
    dof = model.dof
    q = np.array([r[:dof] for r in rows], dtype=float)
    success = np.array([{"true": True, "false": False}[r[dof]] for r in rows])
    errors = np.array([r[dof + 1 : dof + 3] for r in rows], dtype=float)
    iterations = np.array([int(r[dof + 3]) for r in rows])
    return q, success, errors, iterations


def assert_reaches(model, q, T, link="tool0"):
    """FK of every answer within TOL of its target (position and rotation)."""
    mine = compile_model(model).fk(q, [link])[:, 0]
    assert np.abs(mine[:, :3, 3] - T[:, :3, 3]).max() <= TOL
    assert rotation_angle(np.swapaxes(T[:, :3, :3], 1, 2) @ mine[:, :3, :3]).max() <= TOL


def summary(err: str) -> re.Match:
    m = SUMMARY.match(err.strip().splitlines()[-1])
    assert m, err
    return m


def write_rows(path, rows, header=None):
    with open(path, "w") as fh:
        if header:
            fh.write(",".join(header) + "\n")
        for r in rows:
            fh.write(",".join(map(repr, map(float, r))) + "\n")


# ============================================================================ round trips
@pytest.mark.parametrize("header", [None, ["x", "y", "z", "qw", "qx", "qy", "qz"], ["qz", "x", "qy", "y", "qx", "z", "qw"]])
def test_csv_targets_are_reached(tmp_path, ur5, targets, header, capsys):
    rows = pose_rows(targets)
    if header is not None:
        order = [["x", "y", "z", "qw", "qx", "qy", "qz"].index(h) for h in header]
        rows = rows[:, order]
    write_rows(tmp_path / "t.csv", rows, header)
    code, out, err = run(["ik", "--model", "ur5", "--link", "tool0", tmp_path / "t.csv", "-o", tmp_path / "q.csv"], capsys)
    assert code == 0, err
    q, success, errors, iterations = ik_csv(tmp_path / "q.csv", ur5)
    assert q.shape == (N, 6) and success.all() and (errors <= TOL).all() and (iterations >= 1).all()
    assert_reaches(ur5, q, targets)
    m = summary(err)
    assert m.group(1, 2, 3) == (str(N), str(N), "100")
    assert float(m.group(4)) <= TOL and float(m.group(5)) <= TOL
    assert float(m.group(6)) == np.median(iterations)


@pytest.mark.parametrize("shape", ["matrices", "rows"])
def test_npy_targets_to_npy_answers(tmp_path, ur5, targets, shape, capsys):
    np.save(tmp_path / "t.npy", targets if shape == "matrices" else pose_rows(targets))
    code, out, err = run(["ik", "--model", "ur5", "--link", "tool0", tmp_path / "t.npy", "-o", tmp_path / "q.npy"], capsys)
    assert code == 0, err
    q = np.load(tmp_path / "q.npy")
    assert q.shape == (N, 6) and q.dtype == np.float64
    assert_reaches(ur5, q, targets)


def test_jsonl_targets_in_every_pose_form_to_jsonl_answers(tmp_path, ur5, targets, capsys):
    lines = []
    for i, T in enumerate(targets):
        x, y, z, qw, qx, qy, qz = pose_rows(T[None])[0].tolist()
        lines.append([
            [x, y, z, qw, qx, qy, qz],
            T.tolist(),
            {"position": [x, y, z], "quaternion": {"w": qw, "x": qx, "y": qy, "z": qz}},
            {"xyz": [x, y, z], "rpy": matrix_to_rpy(T[:3, :3]).tolist()},
        ][i % 4])
    (tmp_path / "t.jsonl").write_text("\n".join(map(json.dumps, lines)) + "\n\n")
    code, out, err = run(["ik", "--model", "ur5", "--link", "tool0", tmp_path / "t.jsonl", "-o", tmp_path / "q.jsonl"], capsys)
    assert code == 0, err
    records = [json.loads(l) for l in (tmp_path / "q.jsonl").read_text().splitlines()]
    assert len(records) == N
    assert set(records[0]) == {"q", *IK_STATUS_COLUMNS}
    assert all(r["success"] is True and isinstance(r["iterations"], int) for r in records)
    q = np.array([[r["q"][j] for j in ur5.joint_names] for r in records])
    assert_reaches(ur5, q, targets)


def test_fk_output_of_one_link_reads_as_targets_and_stdout_is_csv(tmp_path, ur5, targets, capsys):
    Q = ur5.sample_configurations(5, np.random.default_rng(3))
    np.save(tmp_path / "q.npy", Q)
    assert run(["fk", "--model", "ur5", "--links", "tool0", tmp_path / "q.npy", "-o", tmp_path / "poses.csv"], capsys)[0] == 0
    code, out, err = run(["ik", "--model", "ur5", "--link", "tool0", tmp_path / "poses.csv"], capsys)
    assert code == 0, err
    (tmp_path / "answers.csv").write_text(out)
    q, success, _, _ = ik_csv(tmp_path / "answers.csv", ur5)
    assert success.all()
    assert_reaches(ur5, q, compile_model(ur5).fk(Q, ["tool0"])[:, 0])


def test_matrix_columns_csv(tmp_path, targets):
    flat = targets.reshape(N, 16)
    write_rows(tmp_path / "m.csv", flat)
    write_rows(tmp_path / "mh.csv", flat[:, ::-1], [f"T{r}{c}" for r in range(4) for c in range(4)][::-1])
    for name in ("m.csv", "mh.csv"):
        with open_target_rows(tmp_path / name, chunk_rows=7) as rows:
            chunks = list(rows)
        assert [s for s, _ in chunks] == [0, 7, 14]
        np.testing.assert_array_equal(np.concatenate([T for _, T in chunks]), targets)


# ============================================================================ failures
def test_unreachable_target_exits_1_with_its_row_marked(tmp_path, ur5, targets, capsys):
    rows = pose_rows(targets[:5])
    rows = np.insert(rows, 2, [5.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], axis=0)
    write_rows(tmp_path / "t.csv", rows)
    code, out, err = run(["ik", "--model", "ur5", "--link", "tool0", "--restarts", "3", tmp_path / "t.csv",
                          "-o", tmp_path / "q.csv"], capsys)
    assert code == 1
    q, success, errors, iterations = ik_csv(tmp_path / "q.csv", ur5)
    assert success.tolist() == [True, True, False, True, True, True]
    assert np.isfinite(q).all() and np.isfinite(errors).all()
    assert errors[2, 0] > 3.0 and 0 < iterations[2] <= 4 * 100
    assert "not solved (0-based rows): 2" in err
    m = summary(err)
    assert m.group(1, 2, 3) == ("5", "6", "83.3")


def test_nothing_solved_and_empty_input(tmp_path, capsys):
    write_rows(tmp_path / "far.csv", [[5.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]])
    code, _, err = run(["ik", "--model", "ur5", "--restarts", "0", tmp_path / "far.csv", "-o", tmp_path / "q.csv"], capsys)
    assert code == 1 and "ik: solved 0/1 targets (0%); no error to report (none solved); median iterations " in err
    (tmp_path / "empty.csv").write_text("x,y,z,qw,qx,qy,qz\n")
    code, _, err = run(["ik", "--model", "ur5", tmp_path / "empty.csv", "-o", tmp_path / "q.npy"], capsys)
    assert code == 0 and "solved 0/0 targets" in err
    assert np.load(tmp_path / "q.npy").shape == (0, 6)


GOOD = "0.4,0.1,0.3,1,0,0,0\n"


@pytest.mark.parametrize("name, text, expected", [
    ("quat.csv", GOOD + "0.4,0.1,0.3,1,0.1,0,0\n", ["line 2", "columns 4, 5, 6, 7 (qw, qx, qy, qz)", "not a unit quaternion"]),
    ("quat_header.csv", "qz,y,z,qw,qx,qy,x\n0,0.1,0.3,1,0,0,0.4\n0,0.1,0.3,0.9,0,0,0.4\n",
     ["line 3", "columns 4, 5, 6, 1 (qw, qx, qy, qz)", "not a unit quaternion"]),
    ("nan.csv", GOOD + "\n0.4,nan,0.3,1,0,0,0\n", ["line 3", "column 2 (y)", "not finite"]),
    ("inf.jsonl", "[0.4,0.1,0.3,1,0,0,0]\n[0.4,0.1,Infinity,1,0,0,0]\n", ["line 2", "column 3 (z)", "not finite"]),
    ("huge.csv", "1e9,0.1,0.3,1,0,0,0\n", ["line 1", "column 1 (x)", "beyond"]),
    ("text.csv", GOOD + "0.4,0.1,abc,1,0,0,0\n", ["line 2", "column 3 (z)", "'abc' is not a number"]),
    ("columns.csv", GOOD + "0.4,0.1,0.3,1,0,0\n", ["line 2", "expected 7 columns", "got 6"]),
    ("first_columns.csv", "0.4,0.1,0.3,1,0,0\n", ["line 1", "expected 7 columns", "or 16", "got 6"]),
    ("header.csv", "x,y,z,qw,qx,qy,w\n" + GOOD, ["line 1 (header), column 7", "unknown column 'w'"]),
    ("repeat.csv", "x,y,z,qw,qx,qy,x\n" + GOOD, ["line 1 (header), column 7", "'x' repeats column 1"]),
    ("quat.jsonl", '{"position": [0.4, 0.1, 0.3], "quaternion": {"w": 2, "x": 0, "y": 0, "z": 0}}\n',
     ["line 1", "target.quaternion", "not a unit quaternion"]),
    ("short.jsonl", "[0.4,0.1,0.3]\n", ["line 1", "expected 7 numbers", "got a list of 3"]),
    ("word.jsonl", '[0.4,0.1,0.3,"1",0,0,0]\n', ["line 1", "column 4 (qw)", "is not a number"]),
    ("bad.jsonl", "[0.4,0.1,\n", ["line 1", "not valid JSON"]),
    ("skew.csv", ",".join(["1"] * 16) + "\n", ["line 1", "not a rigid transform"]),
])
def test_bad_target_files_exit_2_naming_line_and_column(tmp_path, name, text, expected, capsys):
    path = tmp_path / name
    path.write_text(text)
    code, out, err = run(["ik", "--model", "ur5", path, "-o", tmp_path / "q.csv"], capsys)
    assert code == 2, err
    assert name in err
    for e in expected:
        assert e in err, err
    assert not (tmp_path / "q.csv").exists()  # the partial output is dropped


def test_bad_npy_targets(tmp_path, targets, capsys):
    bad = targets.copy()
    bad[3, 0, 0] = 2.0
    np.save(tmp_path / "skew.npy", bad)
    code, _, err = run(["ik", "--model", "ur5", tmp_path / "skew.npy"], capsys)
    assert code == 2 and "row 3: not a rigid transform" in err
    np.save(tmp_path / "shape.npy", np.zeros((4, 6)))
    code, _, err = run(["ik", "--model", "ur5", tmp_path / "shape.npy"], capsys)
    assert code == 2 and "(N, 4, 4)" in err and "(4, 6)" in err


@pytest.mark.parametrize("argv, code, expected", [
    (["--model", "nope"], 3, "unknown model"),
    (["--model", "ur5", "--link", "nope"], 2, "unknown link 'nope'"),
    (["--model", "ur5", "--seed", "1,2"], 2, "--seed: expected 6 joint values"),
    (["--model", "ur5", "--seed", "a,b"], 2, "--seed"),
    (["--model", "ur5", "--position-tolerance", "0"], 2, "--position-tolerance"),
    (["--model", "ur5", "--max-iterations", "0"], 2, "--max-iterations"),
    (["--model", "ur5", "--chunk", "0"], 2, "--chunk"),
])
def test_bad_options(tmp_path, argv, code, expected, capsys):
    write_rows(tmp_path / "t.csv", [[0.4, 0.1, 0.3, 1, 0, 0, 0]])
    got, _, err = run(["ik", *argv, tmp_path / "t.csv"], capsys)
    assert got == code and expected in err, err


# ============================================================================ options
def test_position_mode_on_the_planar_arm(tmp_path, capsys):
    rng = np.random.default_rng(5)
    angle, reach = rng.uniform(-np.pi, np.pi, 12), rng.uniform(0.2, 0.85, 12)
    xyz = np.stack([reach * np.cos(angle), reach * np.sin(angle), np.zeros(12)], axis=1)
    write_rows(tmp_path / "xy.csv", np.hstack([xyz, np.tile([1.0, 0, 0, 0], (12, 1))]))
    code, out, err = run(["ik", "--dh", DEFAULT_PRESETS_DIR / "planar_2r.yaml", "--link", "tool", "--mode", "position",
                          tmp_path / "xy.csv", "-o", tmp_path / "q.csv"], capsys)
    assert code == 0, err
    planar = default_catalogue().get("planar_2r")
    q, success, errors, _ = ik_csv(tmp_path / "q.csv", planar)
    assert success.all() and (errors[:, 0] <= TOL).all()
    T = compile_model(planar).fk(q, ["tool"])[:, 0]
    assert np.abs(T[:, :3, 3] - xyz).max() <= TOL
    last = err.strip().splitlines()[-1]
    assert last.startswith("ik: solved 12/12 targets (100%); worst position error ") and "rotation" not in last


def test_chunks_do_not_change_the_answers(tmp_path, targets, capsys):
    np.save(tmp_path / "t.npy", targets)
    write_rows(tmp_path / "t.csv", pose_rows(targets))
    base = ["ik", "--model", "ur5", "--link", "tool0", "--random-seed", "3"]
    assert run(base + [tmp_path / "t.csv", "-o", tmp_path / "one.csv"], capsys)[0] == 0
    assert run(base + ["--chunk", "3", tmp_path / "t.csv", "-o", tmp_path / "csv3.csv"], capsys)[0] == 0
    assert run(base + ["--chunk", "7", tmp_path / "t.npy", "-o", tmp_path / "npy7.csv"], capsys)[0] == 0
    one = (tmp_path / "one.csv").read_text()
    assert (tmp_path / "csv3.csv").read_text() == one
    q_npy = ik_csv(tmp_path / "npy7.csv", default_catalogue().get("ur5"))[0]
    np.testing.assert_allclose(q_npy, ik_csv(tmp_path / "one.csv", default_catalogue().get("ur5"))[0], atol=1e-9)


def test_random_seed_reproducible_and_seed_option(tmp_path, ur5, targets, capsys):
    write_rows(tmp_path / "t.csv", pose_rows(targets))
    base = ["ik", "--model", "ur5", "--link", "tool0", tmp_path / "t.csv", "-o"]
    for name, seed in (("a.csv", 7), ("b.csv", 7), ("c.csv", 8)):  # 12 steps per attempt: most targets restart
        assert run(base + [tmp_path / name, "--max-iterations", 12, "--random-seed", seed], capsys)[0] == 0
    a = (tmp_path / "a.csv").read_text()
    assert (tmp_path / "b.csv").read_text() == a
    q, _, _, iterations = ik_csv(tmp_path / "a.csv", ur5)
    assert (iterations > 12).any()  # some target needed a restart: another random seed draws other restarts
    q_other = ik_csv(tmp_path / "c.csv", ur5)[0]
    assert np.abs(q_other - q).max() > 1e-3
    assert_reaches(ur5, q_other, targets)
    code, _, err = run(base + [tmp_path / "s.csv", "--seed=-0.5,-1,1,-1,-1.5,0.2"], capsys)
    assert code == 0, err
    assert_reaches(ur5, ik_csv(tmp_path / "s.csv", ur5)[0], targets)


def test_verify_reports_and_fails_only_off_target_solved_answers(tmp_path, targets, monkeypatch, capsys):
    write_rows(tmp_path / "t.csv", pose_rows(targets[:5]))
    argv = ["ik", "--model", "ur5", "--link", "tool0", "--verify", tmp_path / "t.csv", "-o", tmp_path / "q.csv"]
    code, _, err = run(argv, capsys)
    assert code == 0, err
    line = next(l for l in err.splitlines() if l.startswith("ik: verify:"))
    assert re.match(r"ik: verify: 5 solved answers vs pinocchio \S+: worst position error \S+ m, "
                    r"worst rotation error \S+ rad$", line), line
    assert float(line.split("position error ")[1].split()[0]) <= TOL

    from kinematics.cli import ik as ik_cli

    real = ik_cli.api.ik

    def off_target(*args, **kwargs):  # Pinocchio disagreeing by 1e-5 m with every answer
        answer = real(*args, **kwargs)
        ver = dict(answer.verification, position_error=answer.verification["position_error"] + 1e-5)
        return dataclasses.replace(answer, verification=ver)

    monkeypatch.setattr(ik_cli.api, "ik", off_target)
    code, _, err = run(argv, capsys)
    assert code == 1 and "ik: verify: FAIL: 5 solved answers are off their target" in err
    assert SUMMARY.match(err.strip().splitlines()[-1])
