"""Pipeline CLI: ``kinematics fk`` / ``jacobian`` over trajectory files, ``models``.

Outputs are read back and compared with ``compile_model(model).fk`` / ``.jacobian`` (to
1e-12); quaternions are checked by rebuilding the rotation from them. Bad files must give
exit code 2 and a message naming the line/row and column, never a traceback.
"""

from __future__ import annotations

import csv
import json
import os
import stat
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue, load_urdf
from kinematics.cli import main

from tests.helpers import run_cli as run
from kinematics.io.catalogue import DEFAULT_PRESETS_DIR
from kinematics.io.result_files import NPY_HEADER_BYTES, RowSampler, npy_header
from tests.paths import FIXTURES, REPO

TOL = 1e-12


@pytest.fixture(scope="module")
def Q(ur5):
    return ur5.sample_configurations(57, np.random.default_rng(7))


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation of unit quaternions (..., 4) (w, x, y, z) -> (..., 3, 3)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def read_csv(path) -> tuple[list[str], np.ndarray]:
    with open(path) as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


def poses_from_csv(header, table, links) -> np.ndarray:
    """(N, L, 4, 4) rebuilt from the CSV columns <link>.x ... <link>.qz."""
    col = {h: i for i, h in enumerate(header)}
    out = np.zeros((table.shape[0], len(links), 4, 4))
    out[..., 3, 3] = 1.0
    for k, l in enumerate(links):
        out[:, k, :3, 3] = table[:, [col[f"{l}.{c}"] for c in "xyz"]]
        quat = table[:, [col[f"{l}.q{c}"] for c in "wxyz"]]
        assert np.allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-12)
        assert np.all(quat[:, 0] >= 0.0)
        out[:, k, :3, :3] = quat_to_matrix(quat)
    return out


# ============================================================================ FK round trips
def test_fk_csv_with_shuffled_header_matches_library(tmp_path, ur5, Q, capsys):
    order = [3, 0, 5, 1, 4, 2]
    names = [ur5.joint_names[i] for i in order]
    src = tmp_path / "q.csv"
    with open(src, "w") as fh:
        fh.write(",".join(names) + "\n")
        for i, row in enumerate(Q[:, order]):
            fh.write(",".join(repr(float(v)) for v in row) + "\n")
            if i == 10:
                fh.write("\n")  # a blank line is skipped
    out = tmp_path / "poses.csv"
    code, _, err = run(["fk", "--model", "ur5", src, "-o", out], capsys)
    assert code == 0, err
    header, table = read_csv(out)
    links = list(ur5.leaf_links)
    assert header == [f"{l}.{c}" for l in links for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]
    assert table.shape == (len(Q), 7 * len(links))
    expected = compile_model(ur5).fk(Q, links)
    np.testing.assert_allclose(poses_from_csv(header, table, links), expected, rtol=0, atol=TOL)


def test_fk_headerless_csv_is_in_joint_order_and_goes_to_stdout(tmp_path, ur5, Q, capsys):
    src = tmp_path / "q.csv"
    np.savetxt(src, Q, delimiter=",", fmt="%.17g")
    code, out, _ = run(["fk", "--model", "ur5", "--links", "tool0", src], capsys)
    assert code == 0
    lines = out.splitlines()
    header = lines[0].split(",")
    table = np.array([l.split(",") for l in lines[1:]], dtype=float)
    expected = compile_model(ur5).fk(Q, ["tool0"])
    np.testing.assert_allclose(poses_from_csv(header, table, ["tool0"]), expected, rtol=0, atol=TOL)
    # a header in a different order is not the same as no header: reversed columns differ
    reordered = tmp_path / "rev.csv"
    np.savetxt(reordered, Q[:, ::-1], delimiter=",", fmt="%.17g", header=",".join(ur5.joint_names[::-1]), comments="")
    code, out2, _ = run(["fk", "--model", "ur5", "--links", "tool0", reordered], capsys)
    assert code == 0 and out2 == out


def test_fk_npy_all_links_round_trip(tmp_path, ur5, Q, capsys):
    src, out = tmp_path / "q.npy", tmp_path / "T.npy"
    np.save(src, Q)
    code, _, err = run(["fk", "--model", "ur5", "--links", "all", src, "-o", out, "--chunk", "10"], capsys)
    assert code == 0, err
    T = np.load(out, mmap_mode="r")
    assert T.shape == (len(Q), len(ur5.links), 4, 4) and T.dtype == np.float64
    umask = os.umask(0o022)
    os.umask(umask)
    assert stat.S_IMODE(os.stat(out).st_mode) == 0o666 & ~umask  # not mkstemp's 0600
    np.testing.assert_allclose(T, compile_model(ur5).fk(Q), rtol=0, atol=TOL)


def test_fk_jsonl_lists_and_maps_round_trip(tmp_path, ur5, Q, capsys):
    src, out = tmp_path / "q.jsonl", tmp_path / "poses.jsonl"
    with open(src, "w") as fh:
        for i, q in enumerate(Q):
            obj = dict(zip(ur5.joint_names[::-1], q[::-1].tolist())) if i % 2 else q.tolist()
            fh.write(json.dumps(obj) + "\n")
    links = ["tool0", "forearm_link"]
    code, _, err = run(["fk", "--model", "ur5", "--links", "tool0", "--links", "forearm_link", src, "-o", out], capsys)
    assert code == 0, err
    records = [json.loads(l) for l in out.read_text().splitlines()]
    assert len(records) == len(Q)
    expected = compile_model(ur5).fk(Q, links)
    for n, rec in enumerate(records):
        assert list(rec["poses"]) == links
        for k, l in enumerate(links):
            pose = rec["poses"][l]
            np.testing.assert_allclose(pose["matrix"], expected[n, k], rtol=0, atol=TOL)
            np.testing.assert_allclose(pose["position"], expected[n, k, :3, 3], rtol=0, atol=TOL)
            quat = np.array([pose["quaternion"][c] for c in "wxyz"])
            np.testing.assert_allclose(quat_to_matrix(quat), expected[n, k, :3, :3], rtol=0, atol=TOL)


def test_fk_urdf_file_closed_form_and_chunking(tmp_path, capsys):
    """De Luca's 2R planar arm: tool at (l1 c1 + l2 c12, l1 s1 + l2 s12, 0), chunk size 3."""
    rng = np.random.default_rng(3)
    Q2 = rng.uniform(-3, 3, size=(10, 2))
    src, out = tmp_path / "q.npy", tmp_path / "p.csv"
    np.save(src, Q2)
    code, _, err = run(["fk", "--urdf", FIXTURES / "planar_2r.urdf", src, "-o", out, "--chunk", "3"], capsys)
    assert code == 0, err
    header, table = read_csv(out)
    assert header[:3] == ["tool.x", "tool.y", "tool.z"]
    q1, q12 = Q2[:, 0], Q2.sum(axis=1)
    np.testing.assert_allclose(table[:, 0], 0.7 * np.cos(q1) + 0.5 * np.cos(q12), atol=TOL)
    np.testing.assert_allclose(table[:, 1], 0.7 * np.sin(q1) + 0.5 * np.sin(q12), atol=TOL)
    np.testing.assert_allclose(table[:, 2], 0.0, atol=TOL)
    # orientation: rotation about z by q1 + q2 -> (cos(a/2), 0, 0, sin(a/2)) up to sign
    half = q12 / 2
    sign = np.where(np.cos(half) < 0, -1.0, 1.0)
    np.testing.assert_allclose(table[:, 3], sign * np.cos(half), atol=TOL)
    np.testing.assert_allclose(table[:, 6], sign * np.sin(half), atol=TOL)


def test_fk_dh_table(tmp_path, capsys):
    """The planar_2r preset (l1 = 0.5, l2 = 0.4, degrees) through --dh."""
    src = tmp_path / "q.jsonl"
    Q2 = np.array([[0.3, -1.2], [2.0, 0.4], [0.0, 0.0]])
    src.write_text("".join(json.dumps({"joint_1": a, "joint_2": b}) + "\n" for a, b in Q2))
    code, out, err = run(["fk", "--dh", DEFAULT_PRESETS_DIR / "planar_2r.yaml", src], capsys)
    assert code == 0, err
    lines = out.splitlines()
    header = lines[0].split(",")
    assert len(header) == 7 and header[0].endswith(".x")  # one leaf: the tool link
    table = np.array([l.split(",") for l in lines[1:]], dtype=float)
    q1, q12 = Q2[:, 0], Q2.sum(axis=1)
    x, y = table[:, 0], table[:, 1]
    np.testing.assert_allclose(x, 0.5 * np.cos(q1) + 0.4 * np.cos(q12), atol=TOL)
    np.testing.assert_allclose(y, 0.5 * np.sin(q1) + 0.4 * np.sin(q12), atol=TOL)


# ============================================================================ Jacobians
@pytest.mark.parametrize("reference", ["world", "local", "local_world_aligned"])
def test_jacobian_outputs_match_library(tmp_path, ur5, Q, capsys, reference):
    src = tmp_path / "q.npy"
    np.save(src, Q)
    expected = compile_model(ur5).jacobian(Q, "wrist_3_link", reference)
    base = ["jacobian", "--model", "ur5", "--link", "wrist_3_link", "--reference", reference, src]
    code, _, err = run(base + ["-o", tmp_path / "J.npy"], capsys)
    assert code == 0, err
    J = np.load(tmp_path / "J.npy")
    assert J.shape == (len(Q), 6, ur5.dof)
    np.testing.assert_allclose(J, expected, rtol=0, atol=TOL)
    code, _, _ = run(base + ["-o", tmp_path / "J.csv"], capsys)
    header, table = read_csv(tmp_path / "J.csv")
    assert header[:8] == ["J00", "J01", "J02", "J03", "J04", "J05", "J10", "J11"] and len(header) == 36
    np.testing.assert_allclose(table.reshape(-1, 6, 6), expected, rtol=0, atol=TOL)
    assert table[0, header.index("J42")] == pytest.approx(expected[0, 4, 2], abs=TOL)  # row 4, column 2
    code, _, _ = run(base + ["-o", tmp_path / "J.jsonl"], capsys)
    recs = [json.loads(l)["jacobian"] for l in (tmp_path / "J.jsonl").read_text().splitlines()]
    np.testing.assert_allclose(np.array(recs), expected, rtol=0, atol=TOL)


def test_jacobian_default_link_is_first_leaf(tmp_path, ur5, Q, capsys):
    src = tmp_path / "q.npy"
    np.save(src, Q[:4])
    code, _, _ = run(["jacobian", "--model", "ur5", src, "-o", tmp_path / "J.npy"], capsys)
    assert code == 0
    np.testing.assert_allclose(np.load(tmp_path / "J.npy"),
                               compile_model(ur5).jacobian(Q[:4], ur5.leaf_links[0], "world"), rtol=0, atol=TOL)


# ============================================================================ verify
def test_verify_reports_deviation_and_passes(tmp_path, Q, capsys):
    src = tmp_path / "q.npy"
    np.save(src, Q)
    code, _, err = run(["fk", "--model", "ur5", "--links", "all", src, "-o", tmp_path / "T.npy", "--verify=20"], capsys)
    assert code == 0
    assert "20 sampled configurations" in err and "max position error" in err
    code, _, err = run(["jacobian", "--model", "ur5", src, "-o", tmp_path / "J.npy", "--verify"], capsys)
    assert code == 0 and "max entry error" in err


def test_verify_fails_on_a_wrong_result(tmp_path, Q, capsys, monkeypatch):
    """A kernel that is off by 1e-6 must make --verify exit 1."""
    from kinematics.engine.poe import PoEModel

    real_fk = PoEModel.fk
    monkeypatch.setattr(PoEModel, "fk", lambda self, Q, links=None, out=None, tool=None: real_fk(self, Q, links, tool=tool) + 1e-6)
    src = tmp_path / "q.npy"
    np.save(src, Q)
    code, _, err = run(["fk", "--model", "ur5", src, "-o", tmp_path / "T.csv", "--verify", "5"], capsys)
    assert code == 1
    assert "FAIL" in err


def test_row_sampler_is_uniform_without_replacement():
    s = RowSampler(50, seed=1)
    Qall = np.arange(1000.0)[:, None]
    for start in range(0, 1000, 64):
        s.offer(start, Qall[start:start + 64], Qall[start:start + 64] * 2)
    assert len(set(s.rows.tolist())) == 50
    np.testing.assert_array_equal(s.Q[:, 0], s.rows)
    np.testing.assert_array_equal(s.results[:, 0], 2 * s.rows)
    assert s.rows.min() < 250 and s.rows.max() > 750  # drawn from the whole stream, not the first chunk


# ============================================================================ bad files
BAD_FILES = [
    ("bad.csv", "shoulder_pan_joint,elbow_joint,tool0_joint\n1,2,3\n", ["line 1", "column 3", "'tool0_joint'"]),
    ("bad.csv", "0,0,0,0,0,0\n\n0,0,0,0,0\n", ["line 3", "expected 6 columns", "got 5"]),
    ("bad.csv", "0,0,0,0,0,0\n0,0,abc,0,0,0\n", ["line 2", "column 3", "'elbow_joint'", "'abc' is not a number"]),
    ("bad.csv", "0,0,0,0,0,0\n0,0,0,0,nan,0\n", ["line 2", "column 5", "'wrist_2_joint'", "not finite"]),
    ("bad.csv", "wrist_1_joint,shoulder_pan_joint,shoulder_lift_joint,elbow_joint,wrist_2_joint,wrist_3_joint\n"
                "0,0,0,0,0,0\n1,inf,0,0,0,0\n", ["line 3", "column 2", "'shoulder_pan_joint'", "not finite"]),
    ("bad.csv", "shoulder_pan_joint,shoulder_lift_joint\n1,2\n", ["line 1", "no column for joint(s) elbow_joint"]),
    ("bad.jsonl", "[0,0,0,0,0,0]\n[0,0,0,0,0]\n", ["line 2", "expected 6 joint values", "got 5"]),
    ("bad.jsonl", "[0,0,0,0,0,0]\n[0,0,0,0,0,\"1\"]\n", ["line 2", "column 6", "'wrist_3_joint'", "not a number"]),
    ("bad.jsonl", "[0,0,0,0,0,0]\n{\"shoulder_pan_joint\": 1, \"elbo\": 2}\n", ["line 2", "unknown joint name(s): elbo"]),
    ("bad.jsonl", "[0,0,0,0,0,0]\n[0,0,0,0,0,NaN]\n", ["line 2", "column 6", "not finite"]),
    ("bad.jsonl", "[0,0,0,0,0,0]\n[0,0,\n", ["line 2", "not valid JSON"]),
]


@pytest.mark.parametrize("name,text,needles", BAD_FILES)
def test_bad_input_files_name_line_and_column(tmp_path, capsys, name, text, needles):
    src = tmp_path / name
    src.write_text(text)
    out = tmp_path / "out.csv"
    code, _, err = run(["fk", "--model", "ur5", src, "-o", out], capsys)
    assert code == 2
    assert err.startswith("kinematics fk: error: ") and err.count("\n") == 1
    for needle in needles:
        assert needle in err, (needle, err)
    assert not out.exists() and not list(tmp_path.glob(".out.csv.*"))  # no partial output left


def test_bad_npy_files(tmp_path, capsys):
    cases = {
        "shape.npy": (np.zeros((4, 5)), ["shape (N, 6)", "got shape (4, 5)"]),
        "nan.npy": (np.where(np.arange(24).reshape(4, 6) == 13, np.nan, 0.0), ["row 2", "column 2", "'shoulder_lift_joint'"]),
        "strings.npy": (np.array([["a"] * 6]), ["must be numbers"]),
    }
    for name, (arr, needles) in cases.items():
        np.save(tmp_path / name, arr)
        code, _, err = run(["jacobian", "--model", "ur5", tmp_path / name, "-o", tmp_path / "J.npy"], capsys)
        assert code == 2, name
        for needle in needles:
            assert needle in err, (needle, err)
    np.save(tmp_path / "obj.npy", np.array([[None] * 6]), allow_pickle=True)
    code, _, err = run(["fk", "--model", "ur5", tmp_path / "obj.npy"], capsys)
    assert code == 2 and "cannot read as .npy" in err


def test_usage_and_model_errors_exit_codes(tmp_path, capsys):
    src = tmp_path / "q.csv"
    src.write_text("0,0,0,0,0,0\n")
    assert run(["fk", "--model", "no_such_robot", src], capsys)[0] == 3
    bad_urdf = tmp_path / "bad.urdf"
    bad_urdf.write_text("<robot name='x'><link name='a'/><joint name='j' type='revolute'></robot>")
    code, _, err = run(["fk", "--urdf", bad_urdf, src], capsys)
    assert code == 3 and err.startswith("kinematics fk: error: ")
    code, _, err = run(["fk", "--urdf", tmp_path / "none.urdf", src], capsys)
    assert code == 3 and "none.urdf" in err
    code, _, err = run(["fk", "--model", "ur5", "--links", "no_link", src], capsys)
    assert code == 2 and "no_link" in err
    code, _, err = run(["jacobian", "--model", "ur5", "--link", "no_link", src], capsys)
    assert code == 2 and "no_link" in err
    code, _, err = run(["fk", "--model", "ur5", src, "-o", tmp_path / "out.xlsx"], capsys)
    assert code == 2 and ".xlsx" in err
    code, _, err = run(["fk", "--model", "ur5", tmp_path / "missing.csv"], capsys)
    assert code == 2 and "missing.csv" in err
    code, _, err = run(["fk", "--model", "ur5", src, "-o", tmp_path / "no_dir" / "out.csv"], capsys)
    assert code == 2 and "cannot write" in err
    with pytest.raises(SystemExit) as exc:
        main(["fk", "--model", "ur5", "--urdf", "x.urdf", str(src)])  # two model sources
    assert exc.value.code == 2
    capsys.readouterr()


def test_help_documents_exit_codes_and_columns(capsys):
    with pytest.raises(SystemExit):
        main(["fk", "--help"])
    out = capsys.readouterr().out
    assert "exit codes:" in out and "3  the model could not be loaded" in out and "<link>.qw" in out
    with pytest.raises(SystemExit):
        main(["jacobian", "--help"])
    out = capsys.readouterr().out
    assert "J<r><c>" in out and "exit codes:" in out


# ============================================================================ npy writer
def test_streamed_npy_header_is_fixed_size_and_valid(tmp_path):
    for shape in [(0, 3, 4, 4), (7, 6, 9), (10**12, 10000, 4, 4)]:
        h = npy_header(shape)
        assert len(h) == NPY_HEADER_BYTES and len(h) % 64 == 0
        path = tmp_path / "h.npy"
        n = 2 if shape[0] else 0
        data = np.arange(n * int(np.prod(shape[1:])), dtype=np.float64)
        path.write_bytes(npy_header((n,) + shape[1:]) + data.tobytes())
        arr = np.load(path)
        assert arr.shape == (n,) + shape[1:]
        np.testing.assert_array_equal(arr.ravel(), data)


def test_empty_input_gives_empty_outputs(tmp_path, capsys):
    src = tmp_path / "q.csv"
    src.write_text("")
    code, _, _ = run(["fk", "--model", "ur5", "--links", "all", src, "-o", tmp_path / "T.npy"], capsys)
    assert code == 0
    assert np.load(tmp_path / "T.npy").shape == (0, 11, 4, 4)


# ============================================================================ models
def test_models_lists_catalogue(capsys):
    code, out, _ = run(["models"], capsys)
    assert code == 0
    lines = out.splitlines()
    assert lines[0].split() == ["id", "source"]
    ids = {l.split()[0]: l.split()[1] for l in lines[1:]}
    assert ids["ur5"] == "example-robot-data" and ids["planar_2r"] == "preset"
    assert len(ids) == len(default_catalogue().ids())
    code, out, _ = run(["models", "ur5", "planar_2r", "--dof", "--json"], capsys)
    recs = {r["id"]: r for r in json.loads(out)}
    assert recs["ur5"]["dof"] == 6 and recs["ur5"]["links"] == 11 and "tool0" in recs["ur5"]["leaf_links"]
    assert recs["planar_2r"]["dof"] == 2
    assert run(["models", "nope"], capsys)[0] == 2


# ============================================================================ subprocess
def test_subprocess_pipe_has_no_progress_bar(tmp_path, ur5, Q):
    src = tmp_path / "q.csv"
    np.savetxt(src, Q[:5], delimiter=",", header=",".join(ur5.joint_names), comments="")
    proc = subprocess.run([sys.executable, "-m", "kinematics", "fk", "--model", "ur5", "--links", "tool0", str(src)],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""  # piped: no progress bar, no summary
    lines = proc.stdout.splitlines()
    table = np.array([l.split(",") for l in lines[1:]], dtype=float)
    np.testing.assert_allclose(table[:, :3], compile_model(ur5).fk(Q[:5], ["tool0"])[:, 0, :3, 3], atol=TOL)
    bad = tmp_path / "bad.csv"
    bad.write_text("0,0,0,0,0,0\n0,0,0,x,0,0\n")
    proc = subprocess.run([sys.executable, "-m", "kinematics", "fk", "--model", "ur5", str(bad)],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and "line 2, column 4" in proc.stderr
    assert proc.stdout == ""  # nothing half-written to stdout when the first chunk is bad


# ============================================================================ memory bound
#: peak of Python allocations allowed while streaming 200k configurations (tracemalloc)
STREAM_MEMORY_BOUND = 64 * 1024 * 1024


@pytest.mark.slow
def test_streaming_200k_rows_stays_in_bounded_memory(tmp_path, ur5, capsys):
    n = 200_000
    rng = np.random.default_rng(11)
    src = tmp_path / "q.csv"
    Qbig = rng.uniform(-3, 3, size=(n, ur5.dof))
    with open(src, "w") as fh:
        fh.write(",".join(ur5.joint_names) + "\n")
        np.savetxt(fh, Qbig, delimiter=",", fmt="%.17g")
    out = tmp_path / "T.npy"
    naive_bytes = n * len(ur5.links) * 16 * 8  # the whole (N, L, 4, 4) output at once
    assert naive_bytes > 4 * STREAM_MEMORY_BOUND
    del Qbig
    tracemalloc.start()
    try:
        code = main(["fk", "--model", "ur5", "--links", "all", str(src), "-o", str(out)])
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert code == 0, capsys.readouterr().err
    assert peak < STREAM_MEMORY_BOUND, f"peak {peak / 2**20:.1f} MiB"
    T = np.load(out, mmap_mode="r")
    assert T.shape == (n, len(ur5.links), 4, 4)
    rows = np.array([0, 12_345, 99_999, 100_000, n - 1])
    Qcheck = np.loadtxt(src, delimiter=",", skiprows=1, max_rows=n)[rows]
    np.testing.assert_allclose(T[rows], compile_model(ur5).fk(Qcheck), rtol=0, atol=TOL)


def test_an_atomic_file_replaces_its_destination_only_when_done(tmp_path):
    from kinematics.cli.common import atomic_file

    dest = tmp_path / "out.bin"
    dest.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        with atomic_file(str(dest), ".out.") as fh:
            fh.write(b"half")
            raise RuntimeError("interrupted")
    assert dest.read_bytes() == b"old" and os.listdir(tmp_path) == ["out.bin"]
    with atomic_file(str(dest), ".out.") as fh:
        fh.write(b"new")
    assert dest.read_bytes() == b"new" and os.listdir(tmp_path) == ["out.bin"]
    assert stat.S_IMODE(dest.stat().st_mode) == 0o644
