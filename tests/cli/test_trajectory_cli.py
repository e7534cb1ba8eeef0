"""``kinematics trajectory``: every output format holds the library's trajectory."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import TrajectoryLimits, default_catalogue, trajectory
from kinematics.cli import main

W = np.array([[0, -1.57, 1.57, 0, 1.57, 0], [0.5, -1.2, 1.2, 0.3, 1.57, 0], [1.0, -1.0, 0.8, 0, 1.2, 0.5]])


@pytest.fixture
def waypoints_csv(tmp_path):
    names = default_catalogue().get("ur5").joint_names
    path = tmp_path / "path.csv"
    np.savetxt(path, W, delimiter=",", header=",".join(names), comments="")
    return path


def run(*argv) -> int:
    return main([str(a) for a in argv])


def test_npz_and_csv(tmp_path, waypoints_csv):
    expected = trajectory(default_catalogue().get("ur5"), W, TrajectoryLimits(acceleration=3.0), rate=100)
    assert run("trajectory", "--model", "ur5", waypoints_csv, "--acceleration", "3", "-o", tmp_path / "a.npz") == 0
    arrays = np.load(tmp_path / "a.npz")
    np.testing.assert_array_equal(arrays["q"], expected.q)
    assert float(arrays["duration"]) == expected.duration
    assert run("trajectory", "--model", "ur5", waypoints_csv, "--acceleration", "3", "-o", tmp_path / "a.csv") == 0
    table = np.loadtxt(tmp_path / "a.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], expected.t, rtol=1e-15)
    np.testing.assert_allclose(table[:, 1:7], expected.q, rtol=1e-15)


def test_ros_outputs(tmp_path, waypoints_csv):
    highlevel = pytest.importorskip("rosbags.highlevel")
    pytest.importorskip("mcap")
    from rosbags.typesys import Stores, get_typestore

    for out in (tmp_path / "t.mcap", tmp_path / "ros2_bag"):
        assert run("trajectory", "--model", "ur5", waypoints_csv, "--acceleration", "3", "--jerk", "30",
                   "--rate", "50", "-o", out) == 0
        with highlevel.AnyReader([out], default_typestore=get_typestore(Stores.LATEST)) as reader:
            (conn, _, raw), = list(reader.messages())
            msg = reader.deserialize(raw, conn.msgtype)
        assert conn.msgtype == "trajectory_msgs/msg/JointTrajectory" and msg.joint_names[0] == "shoulder_pan_joint"
        np.testing.assert_allclose(msg.points[0].positions, W[0])
        np.testing.assert_allclose(msg.points[-1].positions, W[-1], atol=1e-9)
        assert np.abs(msg.points[-1].accelerations).max() < 1e-9


def test_many_paths_into_a_directory(tmp_path, waypoints_csv):
    second = tmp_path / "second.csv"
    second.write_text(waypoints_csv.read_text())
    assert run("trajectory", "--model", "ur5", waypoints_csv, second, "--acceleration", "3", "-o",
               tmp_path / "out") == 0
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["path.npz", "second.npz"]


def test_bad_limit_is_a_usage_error(tmp_path, waypoints_csv):
    assert run("trajectory", "--model", "ur5", waypoints_csv, "--acceleration", "-1", "-o", tmp_path / "a.npz") == 2
    assert run("trajectory", "--model", "ur5", waypoints_csv, "--acceleration", "x", "-o", tmp_path / "a.npz") == 2
