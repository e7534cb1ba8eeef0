"""Robot logs: ``sensor_msgs/JointState`` from ROS bags in, a TF tree as MCAP out, without a
ROS install (PyPI ``rosbags`` reads and serialises the messages, ``mcap`` writes MCAP).

**In** (:class:`JointStateLog`): a ROS 1 ``.bag``, a ROS 2 ``.db3`` (sqlite3) or ``.mcap``
file, or a ROS 2 bag directory (with its ``metadata.yaml``). The topic is ``topic``, or by
default the first ``sensor_msgs/msg/JointState`` topic of the bag. Each message is mapped
**by joint name** (publishers order their joints as they like, and may publish more joints
than the model has): a message without one of the model's joints is an error naming the joint
and the message (its 0-based index on the topic), or, with ``skip_incomplete=True``, it is
skipped and counted (``skipped``). The time of a message is its header stamp (nanoseconds),
or the bag's receive time when the stamp is zero; iterating yields ``(start, Q)`` like the
other readers, with ``times`` (int64 ns) of the last chunk.

**Out** (:class:`TFWriter`): an MCAP file (ROS 2 profile, CDR) with one
``tf2_msgs/msg/TFMessage`` per sample on ``/tf``: per joint of the model the transform of
its child link in its parent link (``T_parent_child`` from FK of every link), stamped with the
sample's time, so Foxglove shows the robot as a moving TF tree; optionally
(``pose_topics=True``) a ``geometry_msgs/msg/PoseStamped`` per link on ``/pose/<link>``
(the link's pose in the root frame).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..model.robot import RobotModel
from ..spatial.rotations import matrix_to_quaternion
from ..spatial.transforms import inverse_transform
from ..tolerances import MAX_ABS_JOINT_VALUE
from .result_files import AtomicOutput, drop_file, part_file
from .trajectory import CHUNK_ROWS, TrajectoryFileError, require_joint_columns

#: the ROS message type of joint states (rosbags' name, ROS 1 bags included)
JOINT_STATE = "sensor_msgs/msg/JointState"
#: file extensions read as ROS bags
LOG_EXTENSIONS = (".bag", ".db3", ".mcap")
#: the TF topic written
TF_TOPIC = "/tf"


def _rosbags():
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:  # pragma: no cover - the `logs` extra
        raise TrajectoryFileError("ROS bags need rosbags: pip install 'kinematics-service[logs]'") from None
    return AnyReader, Stores, get_typestore


def is_log(path) -> bool:
    """Whether ``path`` is a ROS bag: a ``.bag``, ``.db3`` or ``.mcap`` file, or a ROS 2 bag directory."""
    p = Path(str(path))
    return p.suffix.lower() in LOG_EXTENSIONS or (p.is_dir() and (p / "metadata.yaml").exists())


class JointStateLog:
    """Joint values of the ``sensor_msgs/JointState`` messages of a ROS bag, by joint name
    (see the module). Use as a context manager; iterate for ``(start, Q)`` chunks."""

    def __init__(self, path, model: RobotModel, topic: str | None = None, skip_incomplete: bool = False,
                 chunk_rows: int = CHUNK_ROWS, name: str | None = None):
        if chunk_rows < 1:
            raise ValueError("chunk_rows must be positive")
        require_joint_columns(model)
        AnyReader, Stores, get_typestore = _rosbags()
        self.model = model
        self.name = name or str(path)
        self.chunk_rows = chunk_rows
        self.skip_incomplete = skip_incomplete
        self.skipped = 0
        self.times: np.ndarray | None = None
        path = Path(str(path))
        if not path.exists():
            raise TrajectoryFileError(f"{self.name}: cannot open: no such file or directory")
        try:
            self._reader = AnyReader([path], default_typestore=get_typestore(Stores.LATEST))
            self._reader.open()
        except Exception as exc:  # noqa: BLE001 - rosbags raises several kinds for a bad file
            raise TrajectoryFileError(f"{self.name}: cannot read as a ROS bag: {exc}") from None
        conns = self._reader.connections
        self.topics = list(dict.fromkeys(c.topic for c in conns if c.msgtype == JOINT_STATE))
        if topic is None:
            if not self.topics:
                found = ", ".join(f"{c.topic} ({c.msgtype})" for c in conns) or "none"
                self.close()
                raise TrajectoryFileError(f"{self.name}: no {JOINT_STATE} topic (topics: {found})")
            topic = self.topics[0]
        elif topic not in self.topics:
            types = {c.topic: c.msgtype for c in conns}
            self.close()
            if topic in types:
                raise TrajectoryFileError(f"{self.name}: topic {topic!r} has {types[topic]}, not {JOINT_STATE}")
            raise TrajectoryFileError(f"{self.name}: no topic {topic!r} (JointState topics: "
                                      f"{', '.join(self.topics) or 'none'})")
        self.topic = topic
        self._conns = [c for c in conns if c.topic == topic]
        self.total = sum(c.msgcount for c in self._conns) or None
        self._perm: dict[tuple[str, ...], np.ndarray] = {}

    @property
    def time_field(self):
        """The time column of Parquet output: ``time``, int64 nanoseconds (a pyarrow field)."""
        import pyarrow as pa

        return pa.field("time", pa.int64())

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self._reader is not None:
            self._reader.close()
            self._reader = None

    def _permutation(self, names: tuple[str, ...], index: int) -> np.ndarray | None:
        """Index in the message of each model joint (None: a joint is missing and skipping is on)."""
        perm = self._perm.get(names)
        if perm is not None:
            return perm
        where = {n: k for k, n in enumerate(names)}
        missing = [j for j in self.model.joint_names if j not in where]
        if missing:
            if self.skip_incomplete:
                return None
            raise TrajectoryFileError(f"{self.name}: topic {self.topic}, message {index}: no value for joint "
                                      f"{missing[0]!r}" + (f" (nor {', '.join(map(repr, missing[1:]))})" if missing[1:] else "")
                                      + f"; the message names {', '.join(names) or 'no joint'} (skip such messages "
                                      "with --skip-incomplete)")
        perm = np.array([where[j] for j in self.model.joint_names], dtype=np.intp)
        if len(self._perm) < 64:
            self._perm[names] = perm
        return perm

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        reader = self._reader
        dof = self.model.dof
        Q = np.empty((self.chunk_rows, dof))
        T = np.empty(self.chunk_rows, dtype=np.int64)
        n = 0
        start = 0
        for index, (conn, stamp, raw) in enumerate(reader.messages(connections=self._conns)):
            try:
                msg = reader.deserialize(raw, conn.msgtype)
            except Exception as exc:  # noqa: BLE001 - a corrupt message
                raise TrajectoryFileError(f"{self.name}: topic {self.topic}, message {index}: cannot decode: {exc}") from None
            names = tuple(msg.name)
            perm = self._permutation(names, index)
            if perm is None:
                self.skipped += 1
                continue
            pos = np.asarray(msg.position, dtype=np.float64)
            if pos.shape[0] != len(names):
                if self.skip_incomplete:
                    self.skipped += 1
                    continue
                raise TrajectoryFileError(f"{self.name}: topic {self.topic}, message {index}: {len(names)} joint names "
                                          f"but {pos.shape[0]} positions")
            row = pos[perm]
            if not (np.isfinite(row).all() and (np.abs(row) <= MAX_ABS_JOINT_VALUE).all()):
                k = int(np.flatnonzero(~np.isfinite(row) | (np.abs(row) > MAX_ABS_JOINT_VALUE))[0])
                raise TrajectoryFileError(f"{self.name}: topic {self.topic}, message {index}: joint "
                                          f"{self.model.joint_names[k]!r}: value {row[k]:g} is not finite or beyond "
                                          f"+-{MAX_ABS_JOINT_VALUE:g}")
            Q[n] = row
            t = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            T[n] = t if t else stamp
            n += 1
            if n == self.chunk_rows:
                self.times = T.copy()
                yield start, Q.copy()
                start += n
                n = 0
        if n:
            self.times = T[:n].copy()
            yield start, Q[:n].copy()


def open_log(path, model: RobotModel, topic: str | None = None, skip_incomplete: bool = False,
             chunk_rows: int = CHUNK_ROWS) -> JointStateLog:
    """Open a ROS bag's joint states for chunked reading (:class:`JointStateLog`)."""
    return JointStateLog(path, model, topic=topic, skip_incomplete=skip_incomplete, chunk_rows=chunk_rows)


# ============================================================================ TF out
class TFWriter(AtomicOutput):
    """Writes FK of every link as a TF tree to an MCAP file (see the module).

    ``write(poses, times)``: ``poses`` (n, L, 4, 4) ``T_root_link`` of every link of the
    model, in ``model.links`` order; ``times`` (n,) int64 nanoseconds. The file is written to a
    temporary name and renamed on :meth:`close`.
    """

    def __init__(self, dest, model: RobotModel, pose_topics: bool = False, topic: str = TF_TOPIC):
        try:
            from mcap.writer import Writer
        except ImportError:  # pragma: no cover - the `logs` extra
            raise TrajectoryFileError("MCAP output needs mcap: pip install 'kinematics-service[logs]'") from None
        _, Stores, get_typestore = _rosbags()
        self.model = model
        self.rows = 0
        self._dest = str(dest)
        fd, self._tmp = part_file(self._dest, self._dest)
        self._fh = os.fdopen(fd, "wb")
        self._ts = get_typestore(Stores.LATEST)
        self._types = self._ts.types
        index = {l: i for i, l in enumerate(model.links)}
        edges = [(j.parent, j.child) for j in model.joints]
        self._parent = np.array([index[p] for p, _ in edges], dtype=np.intp)
        self._child = np.array([index[c] for _, c in edges], dtype=np.intp)
        self._edges = edges
        self._writer = Writer(self._fh)
        self._writer.start(profile="ros2", library="kinematics")
        tf_type = "tf2_msgs/msg/TFMessage"
        sid = self._writer.register_schema(name=tf_type, encoding="ros2msg",
                                           data=self._ts.generate_msgdef(tf_type, ros_version=2)[0].encode())
        self._tf = self._writer.register_channel(topic=topic, message_encoding="cdr", schema_id=sid)
        self._poses = None
        if pose_topics:
            ps = "geometry_msgs/msg/PoseStamped"
            pid = self._writer.register_schema(name=ps, encoding="ros2msg",
                                               data=self._ts.generate_msgdef(ps, ros_version=2)[0].encode())
            self._poses = [self._writer.register_channel(topic=f"/pose/{l}", message_encoding="cdr", schema_id=pid)
                           for l in model.links]

    def write(self, poses: np.ndarray, times) -> None:
        poses = np.asarray(poses, dtype=np.float64)
        times = np.asarray(times, dtype=np.int64)
        n = poses.shape[0]
        if poses.shape[1:] != (len(self.model.links), 4, 4) or times.shape != (n,):
            raise ValueError(f"poses must be (n, {len(self.model.links)}, 4, 4) for every link and times (n,)")
        rel = np.matmul(inverse_transform(poses[:, self._parent]), poses[:, self._child])  # T_parent_child
        trans = rel[..., :3, 3].tolist()
        quat = matrix_to_quaternion(rel[..., :3, :3]).tolist()
        t = self._types
        Header, Time = t["std_msgs/msg/Header"], t["builtin_interfaces/msg/Time"]
        TS, TF = t["geometry_msgs/msg/TransformStamped"], t["tf2_msgs/msg/TFMessage"]
        Transform, Vector3, Quaternion = t["geometry_msgs/msg/Transform"], t["geometry_msgs/msg/Vector3"], t["geometry_msgs/msg/Quaternion"]
        serialize = self._ts.serialize_cdr
        for i in range(n):
            ns = int(times[i])
            stamp = Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
            msg = TF(transforms=[
                TS(header=Header(stamp=stamp, frame_id=p), child_frame_id=c,
                   transform=Transform(translation=Vector3(x=tr[0], y=tr[1], z=tr[2]),
                                       rotation=Quaternion(x=q[1], y=q[2], z=q[3], w=q[0])))
                for (p, c), tr, q in zip(self._edges, trans[i], quat[i])])
            self._writer.add_message(self._tf, log_time=ns, data=bytes(serialize(msg, TF.__msgtype__)),
                                     publish_time=ns, sequence=self.rows + i)
        if self._poses is not None:
            self._write_poses(poses, times)
        self.rows += n

    def _write_poses(self, poses, times) -> None:
        t = self._types
        PS, Header, Time = t["geometry_msgs/msg/PoseStamped"], t["std_msgs/msg/Header"], t["builtin_interfaces/msg/Time"]
        Pose, Point, Quaternion = t["geometry_msgs/msg/Pose"], t["geometry_msgs/msg/Point"], t["geometry_msgs/msg/Quaternion"]
        pos = poses[..., :3, 3].tolist()
        quat = matrix_to_quaternion(poses[..., :3, :3]).tolist()
        root = self.model.root
        for i in range(poses.shape[0]):
            ns = int(times[i])
            stamp = Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
            for k, ch in enumerate(self._poses):
                p, q = pos[i][k], quat[i][k]
                msg = PS(header=Header(stamp=stamp, frame_id=root),
                         pose=Pose(position=Point(x=p[0], y=p[1], z=p[2]), orientation=Quaternion(x=q[1], y=q[2], z=q[3], w=q[0])))
                self._writer.add_message(ch, log_time=ns, data=bytes(self._ts.serialize_cdr(msg, PS.__msgtype__)),
                                         publish_time=ns, sequence=self.rows + i)

    def close(self) -> None:
        if self._fh is None:
            return
        self._writer.finish()
        self._fh.close()
        self._fh = None
        os.replace(self._tmp, self._dest)

    def abort(self) -> None:
        if self._fh is None:
            return
        self._fh.close()
        self._fh = None
        drop_file(self._tmp)
