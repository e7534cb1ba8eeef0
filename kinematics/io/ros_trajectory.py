"""A timed trajectory as a ROS ``trajectory_msgs/msg/JointTrajectory`` (the `logs` extra): one
message with a point per sample (``positions``, ``velocities``, ``accelerations``,
``time_from_start``), written to an MCAP file (ROS 2 profile, CDR) or a ROS 2 bag directory, on
``/joint_trajectory`` by default. CSV and ``.npz`` need no extra."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .trajectory import TrajectoryFileError

JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
#: the topic written
TRAJECTORY_TOPIC = "/joint_trajectory"


def _typestore():
    try:
        from rosbags.typesys import Stores, get_typestore
    except ImportError:  # pragma: no cover - the `logs` extra
        raise TrajectoryFileError("ROS trajectories need rosbags: pip install 'kinematics-service[logs]'") from None
    return get_typestore(Stores.LATEST)


def joint_trajectory_message(ts, joint_names, t, q, qd, qdd, frame_id: str = ""):
    """The ``JointTrajectory`` message (``ts``: a rosbags type store) of samples ``t`` (K,), ``q``, ``qd``, ``qdd`` (K, dof)."""
    T = ts.types
    Header, Time, Duration = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"], T["builtin_interfaces/msg/Duration"]
    Point, JT = T["trajectory_msgs/msg/JointTrajectoryPoint"], T[JOINT_TRAJECTORY]
    ns = np.round(np.asarray(t) * 1e9).astype(np.int64)
    points = [Point(positions=np.asarray(q[k], float), velocities=np.asarray(qd[k], float),
                    accelerations=np.asarray(qdd[k], float), effort=np.zeros(0),
                    time_from_start=Duration(sec=int(n // 1_000_000_000), nanosec=int(n % 1_000_000_000)))
              for k, n in enumerate(ns)]
    return JT(header=Header(stamp=Time(sec=0, nanosec=0), frame_id=frame_id), joint_names=list(joint_names),
              points=points)


def write_mcap(path, joint_names, t, q, qd, qdd, topic: str = TRAJECTORY_TOPIC) -> None:
    """One ``JointTrajectory`` message in an MCAP file at ``path``."""
    try:
        from mcap.writer import Writer
    except ImportError:  # pragma: no cover - the `logs` extra
        raise TrajectoryFileError("MCAP output needs mcap: pip install 'kinematics-service[logs]'") from None
    ts = _typestore()
    msg = joint_trajectory_message(ts, joint_names, t, q, qd, qdd)
    with open(path, "wb") as fh:
        writer = Writer(fh)
        writer.start(profile="ros2", library="kinematics")
        sid = writer.register_schema(name=JOINT_TRAJECTORY, encoding="ros2msg",
                                     data=ts.generate_msgdef(JOINT_TRAJECTORY, ros_version=2)[0].encode())
        channel = writer.register_channel(topic=topic, message_encoding="cdr", schema_id=sid)
        writer.add_message(channel, log_time=0, publish_time=0, sequence=0,
                           data=bytes(ts.serialize_cdr(msg, JOINT_TRAJECTORY)))
        writer.finish()


def write_bag(path, joint_names, t, q, qd, qdd, topic: str = TRAJECTORY_TOPIC) -> None:
    """One ``JointTrajectory`` message in a new ROS 2 bag directory ``path`` (sqlite3 storage)."""
    try:
        from rosbags.rosbag2 import Writer
    except ImportError:  # pragma: no cover - the `logs` extra
        raise TrajectoryFileError("ROS 2 bags need rosbags: pip install 'kinematics-service[logs]'") from None
    if Path(path).exists():
        raise TrajectoryFileError(f"{path}: a ROS 2 bag is a new directory; this one exists")
    ts = _typestore()
    msg = joint_trajectory_message(ts, joint_names, t, q, qd, qdd)
    try:
        writer = Writer(path, version=8)
    except TypeError:  # older rosbags
        writer = Writer(path)
    with writer:
        conn = writer.add_connection(topic, JOINT_TRAJECTORY, typestore=ts)
        writer.write(conn, 0, bytes(ts.serialize_cdr(msg, JOINT_TRAJECTORY)))


def write_csv(path_or_file, joint_names, t, q, qd, qdd) -> None:
    """Columns ``t``, then per joint ``q_<name>``, ``qd_<name>``, ``qdd_<name>`` groups."""
    header = ["t"] + [f"{p}_{n}" for p in ("q", "qd", "qdd") for n in joint_names]
    data = np.column_stack([t, q, qd, qdd])
    np.savetxt(path_or_file, data, delimiter=",", header=",".join(header), comments="", fmt="%.17g")


def write_npz(path, t, q, qd, qdd, duration: float) -> None:
    """``t``, ``q``, ``qd``, ``qdd`` and a 0-d ``duration``, as the service's ``.npz`` answer."""
    np.savez(path, t=t, q=q, qd=qd, qdd=qdd, duration=np.asarray(duration))
