"""Cartesian paths (kinematics.algorithms.ik_path): straight lines and rotation geodesics at the
step, continuation that never jumps more than max_joint_step, and honest stops (unreachable,
joint_jump through a singularity, limits)."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue
from kinematics.algorithms.ik import pose_errors
from kinematics.algorithms.ik_path import cartesian_path, interpolate
from kinematics.errors import KinematicsError
from kinematics.spatial.lie import so3_log

Q0 = np.array([0.3, -1.0, 1.2, -0.5, 0.8, 0.2])


@pytest.fixture(scope="module")
def ur5():
    return default_catalogue().get("ur5")


def _T(model, q, link="tool0"):
    return compile_model(model).fk(np.atleast_2d(q), [link])[:, 0]


def test_interpolation_is_straight_and_geodesic():
    a = np.eye(4)
    b = np.eye(4)
    b[:3, 3] = [0.3, 0.0, 0.0]
    c, s = np.cos(1.0), np.sin(1.0)
    b[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    T, length = interpolate(np.array([a, b]), 0.01, 0.05)
    assert len(T) == 31  # 0.3 m / 0.01 -> 30 steps (1 rad / 0.05 -> 20)
    steps = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)
    assert steps.max() <= 0.01 + 1e-12
    np.testing.assert_allclose(T[:, 1:3, 3], 0.0, atol=1e-15)  # on the segment
    angles = np.linalg.norm(so3_log(T[:, :3, :3]), axis=1)
    np.testing.assert_allclose(angles, np.linspace(0, 1, 31), atol=1e-12)  # the geodesic about z, evenly
    np.testing.assert_allclose(length[-1], 0.3)
    with pytest.raises(KinematicsError, match="two or more"):
        interpolate(a[None], 0.01, 0.05)
    with pytest.raises(KinematicsError, match="step"):
        interpolate(np.array([a, b]), 0.0, 0.05)


def test_a_straight_line_is_complete_and_smooth(ur5):
    T0 = _T(ur5, Q0)[0]
    T1 = T0.copy(); T1[:3, 3] += [0.1, -0.05, 0.05]
    ans = cartesian_path(ur5, "tool0", np.array([T0, T1]), Q0, max_joint_step=0.1)
    assert ans.complete and ans.stopped is None and ans.fraction == 1.0
    assert len(ans.q) == len(ans.targets) and ans.max_joint_step <= 0.1
    np.testing.assert_allclose(ans.q[0], Q0, atol=1e-9)
    p, r = pose_errors(compile_model(ur5).fk(ans.q, ["tool0"])[:, 0], ans.targets)
    assert p.max() < 1e-9 and r.max() < 1e-9
    assert np.abs(np.diff(ans.q, axis=0)).max() == pytest.approx(ans.max_joint_step)


def test_out_of_reach_stops_at_the_exact_index(ur5):
    T0 = _T(ur5, Q0)[0]
    far = T0.copy(); far[:3, 3] = [1.5, 0.0, 0.3]
    ans = cartesian_path(ur5, "tool0", np.array([T0, far]), Q0)
    assert not ans.complete and ans.stopped["reason"] == "unreachable"
    i = ans.stopped["index"]
    assert len(ans.q) == i and 0 < ans.fraction < 1
    # the last row reached is reachable, the stop target is not (reach of the UR5 ~ 0.95 m from the shoulder)
    assert np.linalg.norm(ans.targets[i, :3, 3]) > np.linalg.norm(ans.targets[i - 1, :3, 3])


def test_past_a_wrist_singularity_the_jump_is_reported_and_through_it_the_path_goes_on(ur5):
    q = np.array([0.3, -1.0, 1.2, -0.5, 0.2, 0.2])
    Ta, Tm, Tb = _T(ur5, np.array([q, q - [0, 0, 0, 0, 0.2, 0], q - [0, 0, 0, 0, 0.4, 0]]))
    # the straight line from Ta to Tb passes beside the singular pose (q5 = 0): near it the wrist
    # would have to spin; the path stops where the next row would jump, having jumped nowhere
    ans = cartesian_path(ur5, "tool0", np.array([Ta, Tb]), q, step_position=0.002, step_rotation=0.02,
                         max_joint_step=0.05)
    assert not ans.complete and ans.stopped == {"index": 10, "reason": "joint_jump"}
    assert len(ans.q) == 10 and ans.max_joint_step <= 0.05 and 0.4 < ans.fraction < 0.6
    # through the singular pose itself (a waypoint there) the wrist joint simply passes zero
    ans = cartesian_path(ur5, "tool0", np.array([Ta, Tm, Tb]), q, step_position=0.002, step_rotation=0.02,
                         max_joint_step=0.05)
    assert ans.complete and ans.max_joint_step <= 0.05
    assert np.all(np.isfinite(ans.q)) and ans.q[:, 4].min() < 0 < ans.q[:, 4].max()


def test_rows_stay_inside_the_limits(ur5):
    puma = default_catalogue().get("puma560_standard")
    q = np.array([0.0, 0.3, -0.3, 0.0, 0.5, 0.0])
    T0 = _T(puma, q, "tool")[0]
    T1 = T0.copy(); T1[:3, 3] = [0.05, 0.15, 0.9]  # towards the top of the reach, through poses off the limits
    ans = cartesian_path(puma, "tool", np.array([T0, T1]), q)
    assert ans.stopped is None or ans.stopped["reason"] in ("limits", "unreachable", "joint_jump")
    assert np.all((ans.q >= puma.lower_limits - 1e-12) & (ans.q <= puma.upper_limits + 1e-12))


def test_a_chain_without_a_closed_form_uses_continuation():
    planar = default_catalogue().get("planar_3r")
    link = planar.leaf_links[0]
    q = np.array([0.3, 0.6, -0.4])
    T0 = _T(planar, q, link)[0]
    T1 = T0.copy(); T1[:3, 3] += [-0.05, 0.05, 0.0]
    ans = cartesian_path(planar, link, np.array([T0, T1]), q)
    assert ans.complete and ans.family == "planar" and ans.max_joint_step < 0.3


def test_a_step_so_small_the_count_overflows_is_refused_by_name():
    """5e-324 m (the smallest double) between targets: the count is infinite, refused, never converted."""
    W = np.stack([np.eye(4)] * 2)
    W[1, 0, 3] = 0.05
    with pytest.raises(KinematicsError, match="step: the path would have more than"):
        interpolate(W, 5e-324, 0.05)
    assert len(interpolate(W, 0.01, 0.05)[0]) == 6
