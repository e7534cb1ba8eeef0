"""Small ROS bags, MCAP and Parquet files for the tests, made with the libraries the product reads
them with (rosbags, pyarrow): joint states in a shuffled order per message, with an extra joint."""

from __future__ import annotations

from pathlib import Path

import numpy as np

EXTRA_JOINT = "gripper_finger_joint"  # published by the robot, not in the model


def joint_states(model, n: int, seed: int = 0, drop: dict[int, str] | None = None):
    """``(Q (n, dof), times (n,) ns, messages)``: JointState messages naming the joints in a random
    order per message, plus an extra joint; ``drop`` {message index: joint} leaves a joint out."""
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.LATEST)
    JS, H, Time = (ts.types[k] for k in ("sensor_msgs/msg/JointState", "std_msgs/msg/Header",
                                          "builtin_interfaces/msg/Time"))
    rng = np.random.default_rng(seed)
    Q = model.sample_configurations(n, rng)
    times = 1_700_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 2_000_000 + 17
    names = list(model.joint_names) + [EXTRA_JOINT]
    msgs = []
    for i in range(n):
        values = np.append(Q[i], 0.01 * i)
        order = rng.permutation(len(names))
        if drop and i in drop:
            order = np.array([k for k in order if names[k] != drop[i]])
        t = int(times[i])
        msgs.append(JS(header=H(stamp=Time(sec=t // 10**9, nanosec=t % 10**9), frame_id=""),
                       name=[names[k] for k in order], position=values[order], velocity=np.zeros(0),
                       effort=np.zeros(0)))
    return Q, times, msgs


def write_bag(path: Path, kind: str, topics: dict[str, list]) -> Path:
    """A bag of ``kind`` (``bag``: ROS 1; ``mcap``/``db3``: ROS 2, returning the storage file inside the
    bag directory) with ``topics`` {topic: messages} (JointState or std_msgs/String messages)."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.LATEST)
    if kind == "bag":
        writer = Writer1(path.with_suffix(".bag"))
        serialize = ts.serialize_ros1
    else:
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer(path, version=9, storage_plugin=plugin)
        serialize = ts.serialize_cdr
    with writer:
        for topic, msgs in topics.items():
            conn = writer.add_connection(topic, msgs[0].__msgtype__, typestore=ts)
            for i, msg in enumerate(msgs):
                writer.write(conn, 1000 + i, bytes(serialize(msg, msg.__msgtype__)))
    if kind == "bag":
        return path.with_suffix(".bag")
    return path / f"{path.name}.{kind}"


def string_messages(n: int):
    from rosbags.typesys import Stores, get_typestore

    String = get_typestore(Stores.LATEST).types["std_msgs/msg/String"]
    return [String(data=f"hello {i}") for i in range(n)]


def write_joint_parquet(path: Path, model, Q: np.ndarray, times=None, row_group_size: int | None = None,
                        reverse: bool = True) -> Path:
    """Joint columns by name (reversed order by default), an extra column, and ``time``."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    names = list(model.joint_names)
    order = names[::-1] if reverse else names
    cols = {"note": pa.array([f"r{i}" for i in range(len(Q))])}
    if times is not None:
        cols["time"] = pa.array(times)
    for name in order:
        cols[name] = pa.array(Q[:, names.index(name)])
    pq.write_table(pa.table(cols), path, row_group_size=row_group_size)
    return path


def write_joint_dataset(root: Path, model, sizes, seed: int, row_group_size: int) -> np.ndarray:
    """A Parquet dataset ``root/log/part-K.parquet`` of random configurations of ``model``, ``sizes``
    rows a file (:func:`write_joint_parquet`, times numbering the rows across files): every row's q."""
    (root / "log").mkdir()
    rng = np.random.default_rng(seed)
    Qs, start = [], 0
    for k, n in enumerate(sizes):
        Q = model.sample_configurations(n, rng)
        write_joint_parquet(root / "log" / f"part-{k}.parquet", model, Q, np.arange(start, start + n, dtype=np.int64),
                            row_group_size=row_group_size)
        Qs.append(Q)
        start += n
    return np.concatenate(Qs)


def write_target_dataset(root: Path, model, link: str, sizes, seed: int, row_group_size: int) -> np.ndarray:
    """A Parquet dataset ``root/targets/part-K.parquet`` of ``link``'s poses at random configurations of
    ``model`` (the columns of ``kinematics fk``'s Parquet output, ``<link>.x ... <link>.qz``, and ``time``
    numbering the rows across files), ``sizes`` rows a file: every row's target (N, 4, 4)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from kinematics import fk
    from kinematics.io.parquet import result_columns

    (root / "targets").mkdir()
    rng = np.random.default_rng(seed)
    Ts, start = [], 0
    for k, n in enumerate(sizes):
        T = fk(model, model.sample_configurations(n, rng), links=[link]).poses
        cols = {"time": pa.array(np.arange(start, start + n, dtype=np.int64)), **result_columns("fk", T, [link])}
        pq.write_table(pa.table(cols), root / "targets" / f"part-{k}.parquet", row_group_size=row_group_size)
        Ts.append(T[:, 0])
        start += n
    return np.concatenate(Ts)
