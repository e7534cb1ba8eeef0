"""`kinematics fk/jacobian/ik` with robot logs: ROS bags and Parquet in, Parquet and MCAP (TF) out."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("rosbags")
pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from kinematics import compile_model
from kinematics.cli import main
from tests.rosbag_files import joint_states, write_bag, write_joint_parquet


@pytest.mark.parametrize("kind", ["mcap", "db3", "bag"])
def test_fk_bag_to_parquet(tmp_path, ur5, kind, capsys):
    Q, times, msgs = joint_states(ur5, 40)
    bag = write_bag(tmp_path / "run", kind, {"/joint_states": msgs})
    out = tmp_path / "poses.parquet"
    assert main(["fk", "--model", "ur5", str(bag), "--topic", "/joint_states", "--links", "tool0", "-o", str(out),
                 "--chunk", "16"]) == 0
    table = pq.read_table(out)
    assert table.schema.names == ["time"] + [f"tool0.{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]
    np.testing.assert_array_equal(table.column("time").to_numpy(), times)
    T = compile_model(ur5).fk(Q, ["tool0"])[:, 0]
    np.testing.assert_array_equal(np.stack([table.column(f"tool0.{c}").to_numpy() for c in "xyz"], 1), T[:, :3, 3])
    assert pq.ParquetFile(out).num_row_groups == 3  # streamed: one row group per chunk


def test_fk_bag_to_tf_mcap(tmp_path, ur5):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    Q, times, msgs = joint_states(ur5, 12)
    bag = write_bag(tmp_path / "run", "mcap", {"/joint_states": msgs})
    out = tmp_path / "tf.mcap"
    assert main(["fk", "--model", "ur5", str(bag), "-o", str(out)]) == 0
    with open(out, "rb") as fh:
        msgs_out = [(m.log_time, d) for _, c, m, d in make_reader(fh, decoder_factories=[DecoderFactory()])
                    .iter_decoded_messages(topics=["/tf"])]
    assert [t for t, _ in msgs_out] == times.tolist()
    assert len(msgs_out[0][1].transforms) == len(ur5.joints)
    assert main(["fk", "--model", "ur5", str(bag), "--links", "tool0", "-o", str(tmp_path / "x.mcap")]) == 2
    assert main(["jacobian", "--model", "ur5", str(bag), "-o", str(tmp_path / "j.mcap")]) == 2


def test_missing_joint_exit_2_or_skip(tmp_path, ur5, capsys):
    Q, times, msgs = joint_states(ur5, 8, drop={3: "wrist_1_joint"})
    bag = write_bag(tmp_path / "run", "bag", {"/joint_states": msgs})
    out = tmp_path / "p.parquet"
    assert main(["fk", "--model", "ur5", str(bag), "-o", str(out)]) == 2
    assert "message 3: no value for joint 'wrist_1_joint'" in capsys.readouterr().err
    assert not out.exists()
    assert main(["fk", "--model", "ur5", str(bag), "-o", str(out), "--skip-incomplete"]) == 0
    assert "skipped 1 messages" in capsys.readouterr().err
    assert pq.read_table(out).num_rows == 7


def test_parquet_in_jacobian_and_ik_out(tmp_path, ur5):
    poe = compile_model(ur5)
    Q = ur5.sample_configurations(30, np.random.default_rng(1))
    times = pa.array(np.arange(30) * 10**6, pa.timestamp("ns"))
    src = write_joint_parquet(tmp_path / "q.parquet", ur5, Q, times)
    assert main(["jacobian", "--model", "ur5", "--link", "tool0", str(src), "-o", str(tmp_path / "J.parquet")]) == 0
    J = pq.read_table(tmp_path / "J.parquet")
    assert J.schema.field("time").type == pa.timestamp("ns")
    np.testing.assert_array_equal(J.column("J05").to_numpy(), poe.jacobian(Q, "tool0")[:, 0, 5])
    # FK of tool0 -> targets -> IK, all Parquet, time carried
    assert main(["fk", "--model", "ur5", "--links", "tool0", str(src), "-o", str(tmp_path / "t.parquet")]) == 0
    assert main(["ik", "--model", "ur5", "--link", "tool0", str(tmp_path / "t.parquet"),
                 "-o", str(tmp_path / "q_ik.parquet")]) == 0
    ik = pq.read_table(tmp_path / "q_ik.parquet")
    assert ik.schema.names[0] == "time" and ik.column("success").to_pylist() == [True] * 30
    q_ik = np.stack([ik.column(n).to_numpy() for n in ur5.joint_names], 1)
    np.testing.assert_allclose(poe.fk(q_ik, ["tool0"]), poe.fk(Q, ["tool0"]), atol=1e-6)


def test_parquet_to_csv_and_stdin_refused(tmp_path, ur5, capsys):
    Q = ur5.sample_configurations(3, np.random.default_rng(2))
    src = write_joint_parquet(tmp_path / "q.parquet", ur5, Q)
    assert main(["fk", "--model", "ur5", "--links", "tool0", str(src), "-o", str(tmp_path / "p.csv")]) == 0
    assert (tmp_path / "p.csv").read_text().startswith("tool0.x,")
    assert main(["fk", "--model", "ur5", str(src)]) == 0  # CSV on stdout
    assert main(["fk", "--model", "ur5", str(src), "-o", "-", "--output-format", "parquet"]) == 2
