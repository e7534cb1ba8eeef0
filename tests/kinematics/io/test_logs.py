"""Robot logs in (ROS 1 .bag, ROS 2 .db3 / .mcap JointState) and out (Parquet, MCAP TF tree)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("rosbags")
pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from kinematics import compile_model
from kinematics.io.logs import JointStateLog, TFWriter, is_log
from kinematics.io.parquet import ParquetJointRows, ParquetResultWriter, ParquetTargetRows, is_parquet
from kinematics.io.trajectory import TrajectoryFileError
from tests.rosbag_files import joint_states, string_messages, write_bag, write_joint_parquet


@pytest.mark.parametrize("kind", ["bag", "mcap", "db3"])
def test_joint_states_read_by_name_with_times(tmp_path, ur5, kind):
    Q, times, msgs = joint_states(ur5, 23)
    path = write_bag(tmp_path / "run", kind, {"/chatter": string_messages(3), "/joint_states": msgs})
    assert is_log(path)
    with JointStateLog(path, ur5, chunk_rows=10) as log:
        assert log.topic == "/joint_states" and log.total == 23
        chunks = [(start, Qc, log.times) for start, Qc in log]
    assert [c[0] for c in chunks] == [0, 10, 20]
    np.testing.assert_array_equal(np.concatenate([c[1] for c in chunks]), Q)  # bit for bit, joint order fixed
    np.testing.assert_array_equal(np.concatenate([c[2] for c in chunks]), times)


def test_ros2_bag_directory_and_topic_choice(tmp_path, ur5):
    Q1, _, m1 = joint_states(ur5, 5, seed=1)
    Q2, _, m2 = joint_states(ur5, 7, seed=2)
    path = write_bag(tmp_path / "two", "mcap", {"/arm/joint_states": m1, "/other/joint_states": m2})
    with JointStateLog(path.parent, ur5) as log:  # the directory with metadata.yaml
        assert log.topics == ["/arm/joint_states", "/other/joint_states"]
        np.testing.assert_array_equal(np.concatenate([q for _, q in log]), Q1)  # the first JointState topic
    with JointStateLog(path, ur5, topic="/other/joint_states") as log:
        np.testing.assert_array_equal(np.concatenate([q for _, q in log]), Q2)
    with pytest.raises(TrajectoryFileError, match="no topic '/nope'.*/arm/joint_states"):
        JointStateLog(path, ur5, topic="/nope")


def test_wrong_topic_type_and_no_joint_states(tmp_path, ur5):
    path = write_bag(tmp_path / "chat", "bag", {"/chatter": string_messages(2)})
    with pytest.raises(TrajectoryFileError, match="no sensor_msgs/msg/JointState topic.*/chatter"):
        JointStateLog(path, ur5)
    with pytest.raises(TrajectoryFileError, match="'/chatter' has std_msgs/msg/String"):
        JointStateLog(path, ur5, topic="/chatter")


@pytest.mark.parametrize("kind", ["bag", "mcap"])
def test_missing_joint_is_an_error_or_skipped(tmp_path, ur5, kind):
    Q, times, msgs = joint_states(ur5, 6, drop={4: "elbow_joint"})
    path = write_bag(tmp_path / "gap", kind, {"/joint_states": msgs})
    with JointStateLog(path, ur5) as log:
        with pytest.raises(TrajectoryFileError, match="message 4: no value for joint 'elbow_joint'"):
            list(log)
    with JointStateLog(path, ur5, skip_incomplete=True) as log:
        got = np.concatenate([q for _, q in log])
        assert log.skipped == 1
        np.testing.assert_array_equal(got, np.delete(Q, 4, axis=0))
        np.testing.assert_array_equal(log.times, np.delete(times, 4))


def test_bad_file(tmp_path, ur5):
    bad = tmp_path / "junk.bag"
    bad.write_bytes(b"not a bag")
    with pytest.raises(TrajectoryFileError, match="cannot read as a ROS bag"):
        JointStateLog(bad, ur5)
    with pytest.raises(TrajectoryFileError, match="no such file"):
        JointStateLog(tmp_path / "none.mcap", ur5)


# ---------------------------------------------------------------------------- Parquet
def test_parquet_joint_columns_by_name_streamed(tmp_path, ur5):
    Q = ur5.sample_configurations(1000, np.random.default_rng(3))
    times = np.arange(1000, dtype=np.int64) * 5
    path = write_joint_parquet(tmp_path / "q.parquet", ur5, Q, times, row_group_size=300)
    assert is_parquet(path)
    with ParquetJointRows(path, ur5, chunk_rows=128) as rows:
        assert rows.total == 1000 and rows.time_column == "time"
        got = [(s, q, rows.times.to_numpy()) for s, q in rows]
    assert max(q.shape[0] for _, q, _ in got) <= 128  # bounded chunks
    np.testing.assert_array_equal(np.concatenate([q for _, q, _ in got]), Q)
    np.testing.assert_array_equal(np.concatenate([t for _, _, t in got]), times)


def test_parquet_dataset_directory_and_glob(tmp_path, ur5):
    Q = ur5.sample_configurations(30, np.random.default_rng(4))
    (tmp_path / "ds").mkdir()
    for k in range(3):
        write_joint_parquet(tmp_path / "ds" / f"part-{k}.parquet", ur5, Q[10 * k:10 * k + 10], np.arange(10) + 10 * k)
    for source in (tmp_path / "ds", str(tmp_path / "ds" / "*.parquet")):
        with ParquetJointRows(source, ur5) as rows:
            np.testing.assert_array_equal(np.concatenate([q for _, q in rows]), Q)


def test_parquet_errors_name_row_and_joint(tmp_path, ur5):
    Q = ur5.sample_configurations(5, np.random.default_rng(5))
    path = tmp_path / "q.parquet"
    cols = {n: pa.array(Q[:, k]) for k, n in enumerate(ur5.joint_names) if n != "wrist_2_joint"}
    pq.write_table(pa.table(cols), path)
    with pytest.raises(TrajectoryFileError, match="no column for joint.*wrist_2_joint"):
        ParquetJointRows(path, ur5)
    cols["wrist_2_joint"] = pa.array([0.0, 1.0, None, 2.0, 3.0])
    pq.write_table(pa.table(cols), path)
    with ParquetJointRows(path, ur5) as rows, pytest.raises(TrajectoryFileError, match="row 2, column 'wrist_2_joint'.*null"):
        list(rows)
    cols["wrist_2_joint"] = pa.array([0.0, 1.0, 2.0, np.inf, 3.0])
    pq.write_table(pa.table(cols), path)
    with ParquetJointRows(path, ur5) as rows, pytest.raises(TrajectoryFileError, match="row 3, column 'wrist_2_joint'"):
        list(rows)
    with pytest.raises(TrajectoryFileError, match="no time column 'stamp'"):
        ParquetJointRows(path, ur5, time_column="stamp")


def test_parquet_writer_fk_jacobian_time_carried(tmp_path, ur5):
    poe = compile_model(ur5)
    Q = ur5.sample_configurations(50, np.random.default_rng(6))
    field = pa.field("time", pa.timestamp("ns"))
    with ParquetResultWriter(tmp_path / "p.parquet", "fk", ["tool0", "base_link"], time_field=field) as w:
        for a in (0, 20):
            b = min(a + 20, 50) if a == 0 else 50
            w.write(poe.fk(Q[a:b], ["tool0", "base_link"]), pa.array(np.arange(a, b) * 1000, pa.timestamp("ns")))
    table = pq.read_table(tmp_path / "p.parquet")
    assert pq.ParquetFile(tmp_path / "p.parquet").num_row_groups == 2
    assert table.schema.names[:3] == ["time", "tool0.x", "tool0.y"] and table.schema.field("time").type == field.type
    T = poe.fk(Q, ["tool0"])[:, 0]
    np.testing.assert_array_equal(table.column("tool0.z").to_numpy(), T[:, 2, 3])
    with ParquetResultWriter(tmp_path / "J.parquet", "jacobian", ur5.joint_names) as w:
        w.write(poe.jacobian(Q, "tool0"))
    J = pq.read_table(tmp_path / "J.parquet")
    np.testing.assert_array_equal(J.column("J31").to_numpy(), poe.jacobian(Q, "tool0")[:, 3, 1])
    with ParquetResultWriter(tmp_path / "empty.parquet", "fk", ["tool0"]) as w:
        pass
    assert pq.read_table(tmp_path / "empty.parquet").num_rows == 0


def test_parquet_writer_is_atomic(tmp_path, ur5):
    dest = tmp_path / "out.parquet"
    with pytest.raises(RuntimeError):
        with ParquetResultWriter(dest, "fk", ["tool0"]) as w:
            w.write(np.tile(np.eye(4), (3, 1, 1, 1)))
            raise RuntimeError("stop")
    assert list(tmp_path.iterdir()) == []


def test_parquet_targets_with_link_prefix(tmp_path, ur5):
    poe = compile_model(ur5)
    Q = ur5.sample_configurations(8, np.random.default_rng(8))
    with ParquetResultWriter(tmp_path / "t.parquet", "fk", ["tool0"]) as w:
        w.write(poe.fk(Q, ["tool0"]))
    with ParquetTargetRows(tmp_path / "t.parquet") as rows:
        T = np.concatenate([t for _, t in rows])
    np.testing.assert_allclose(T, poe.fk(Q, ["tool0"])[:, 0], atol=1e-14)


# ---------------------------------------------------------------------------- MCAP TF out
def test_tf_mcap_composes_to_fk(tmp_path, ur5):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    poe = compile_model(ur5)
    Q = ur5.sample_configurations(4, np.random.default_rng(9))
    times = np.array([5, 10**9 + 7, 2 * 10**9, 3 * 10**9 + 1], dtype=np.int64)
    with TFWriter(tmp_path / "tf.mcap", ur5, pose_topics=True) as w:
        w.write(poe.fk(Q), times)
    with open(tmp_path / "tf.mcap", "rb") as fh:
        messages = list(make_reader(fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages())
    tf = [(m.log_time, d) for s, c, m, d in messages if c.topic == "/tf"]
    assert [t for t, _ in tf] == times.tolist()
    assert {c.topic for _, c, _, _ in messages} == {"/tf"} | {f"/pose/{l}" for l in ur5.links}
    # walk the tree from the root to tool0 in sample 2: the product is FK of tool0
    edges = {tr.child_frame_id: tr for tr in tf[2][1].transforms}
    assert tf[2][1].transforms[0].header.stamp.sec == 2
    from kinematics.spatial.rotations import quaternion_to_matrix

    T, link = np.eye(4), "tool0"
    while link in edges:
        tr = edges[link]
        E = np.eye(4)
        r = tr.transform.rotation
        E[:3, :3] = quaternion_to_matrix(r.w, r.x, r.y, r.z)
        E[:3, 3] = [tr.transform.translation.x, tr.transform.translation.y, tr.transform.translation.z]
        T = E @ T
        link = tr.header.frame_id
    assert link == ur5.root
    np.testing.assert_allclose(T, poe.fk(Q[2:3], ["tool0"])[0, 0], atol=1e-12)
