"""Poses given as data (a request's base pose): validated into 4x4 rigid transforms.

The world frame is the root link's frame unless a base pose ``T_world_root`` is given (for
robots whose base moves or is mounted); :mod:`kinematics.algorithms.base` re-expresses FK
and Jacobians in that world. A base pose is a 4x4 matrix (nested lists), ``{"xyz": [x, y, z], "rpy": [r, p, y]}`` (URDF
roll-pitch-yaw) or ``{"position": [x, y, z], "quaternion": {"w", "x", "y", "z"}}`` (unit); for a
batch, either one pose for every configuration or a list with one pose per configuration.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import BasePoseError, PoseError
from ..model.joint_values import floating_joint_values  # noqa: F401 - read with q now; kept importable here
from ..spatial.pose_data import is_pose_list, read_pose, read_vector
from ..tolerances import MAX_ABS_COORDINATE, RIGID_TOLERANCE


def base_poses(value, n: int) -> np.ndarray | None:
    """``T_world_root`` for each of ``n`` configurations: (n, 4, 4), or None when no base is given."""
    if value is None:
        return None
    if is_pose_list(value):
        if len(value) != n:
            raise BasePoseError(f"base: {len(value)} poses given for {n} configurations (give one, or one each)")
        return np.stack([read_pose(v, f"base[{i}]") for i, v in enumerate(value)])
    return np.broadcast_to(read_pose(value, "base"), (n, 4, 4))


def pose_count(value) -> int:
    """How many poses ``value`` holds (before validation): a list's length, an array's first axis, else 1."""
    if isinstance(value, np.ndarray):
        return int(value.shape[0]) if value.ndim == 3 else 1
    return len(value) if is_pose_list(value) else 1


def pose_list(value, field: str) -> tuple[np.ndarray, bool]:
    """``(T (N, 4, 4), is_batch)`` of one pose or a list of poses (any form above, or an
    ``(N, 4, 4)`` / ``(4, 4)`` array), each checked to be a finite rigid transform; errors
    (:class:`PoseError`) name ``field`` and the pose's index."""
    if isinstance(value, np.ndarray):
        if value.shape == (4, 4):
            if value.dtype == np.float64:  # one pose (a single IK call): checked in Python, 5x the array checks' speed
                problem = _one_pose_problem(value.tolist())
                if problem is not None:
                    raise PoseError(f"{field}[0]: {problem}")
                return value[None], False
            value, is_batch = value[None], False
        elif value.ndim == 3 and value.shape[1:] == (4, 4):
            is_batch = True
        else:
            raise PoseError(f"{field}: expected an array of shape (N, 4, 4) or (4, 4), got {value.shape}")
        T = np.asarray(value, dtype=float)
        # the checks of is_rigid_transform, on the whole array at once (a loop took ~80 µs a pose)
        bad = ~(np.isfinite(T) & (np.abs(T) <= MAX_ABS_COORDINATE)).all(axis=(1, 2))
        if bad.any():
            raise PoseError(f"{field}[{int(np.argmax(bad))}]: a non-finite value or one beyond +-{MAX_ABS_COORDINATE:g}")
        R = T[:, :3, :3]
        eye, last = np.eye(3), np.array([0.0, 0.0, 0.0, 1.0])
        rigid = (np.abs(np.matmul(np.swapaxes(R, 1, 2), R) - eye) <= RIGID_TOLERANCE + 1e-5 * eye).all(axis=(1, 2))
        rigid &= np.abs(np.linalg.det(R) - 1.0) < RIGID_TOLERANCE
        rigid &= (np.abs(T[:, 3] - last) <= RIGID_TOLERANCE + 1e-5 * last).all(axis=1)
        if not rigid.all():
            raise PoseError(f"{field}[{int(np.argmin(rigid))}]: not a rigid transform (rotation orthonormal with "
                            "det 1, last row 0 0 0 1)")
        return T, is_batch
    if is_pose_list(value):
        if isinstance(value[0], list):  # a batch of 4x4 matrices: checked as one array (~100x faster)
            try:
                arr = np.array(value, dtype=float)
            except (TypeError, ValueError):  # ragged or not numbers: the loop below names the pose
                arr = None
            if arr is not None and arr.ndim == 3 and arr.shape[1:] == (4, 4):
                return pose_list(arr, field)[0], True
        return np.stack([read_pose(v, f"{field}[{i}]", PoseError) for i, v in enumerate(value)]), True
    if isinstance(value, Sequence) and not isinstance(value, (str, bytes)) and len(value) == 0:
        raise PoseError(f"{field}: an empty list of poses")
    return read_pose(value, field, PoseError)[None], False


def _one_pose_problem(rows: list[list[float]]) -> str | None:
    """What is wrong with one pose ``rows`` (4 x 4 floats), in the words of :func:`pose_list`'s array
    checks (the same tests and tolerances), or None."""
    big, tol, diag = MAX_ABS_COORDINATE, RIGID_TOLERANCE, RIGID_TOLERANCE + 1e-5
    for row in rows:
        for v in row:
            if not -big <= v <= big:  # (False for NaN; +-inf are beyond)
                return f"a non-finite value or one beyond +-{big:g}"
    (a, b, c, _), (d, e, f, _), (g, h, i, _), (l0, l1, l2, l3) = rows
    rigid = (abs(a * a + d * d + g * g - 1.0) <= diag and abs(b * b + e * e + h * h - 1.0) <= diag
             and abs(c * c + f * f + i * i - 1.0) <= diag and abs(a * b + d * e + g * h) <= tol
             and abs(a * c + d * f + g * i) <= tol and abs(b * c + e * f + h * i) <= tol
             and abs(a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) - 1.0) < tol
             and abs(l0) <= tol and abs(l1) <= tol and abs(l2) <= tol and abs(l3 - 1.0) <= diag)
    return None if rigid else "not a rigid transform (rotation orthonormal with det 1, last row 0 0 0 1)"


def tool_offset(point=None, tool=None) -> np.ndarray | None:
    """``T_link_tool`` (4, 4) of a request's ``point`` (``[x, y, z]`` in the link frame: a frame there
    with the link's axes) or ``tool`` (a pose in any form above, or a (4, 4) array); None when
    neither is given. Both at once are refused (:class:`PoseError`).

    >>> tool_offset(point=[0.0, 0.0, 0.1])[:3, 3]
    array([0. , 0. , 0.1])
    >>> tool_offset(tool={"xyz": [0, 0, 0.1], "rpy": [0, 0, 0]})[2, 3]
    np.float64(0.1)
    """
    if point is not None and tool is not None:
        raise PoseError("give a point or a tool, not both (a point is a tool with the link's axes)")
    if point is not None:
        if isinstance(point, np.ndarray):
            point = point.tolist()
        T = np.eye(4)
        T[:3, 3] = read_vector(point, 3, "point", PoseError)
        return T
    if tool is None:
        return None
    T, is_batch = pose_list(tool, "tool")
    if is_batch:
        raise PoseError("tool: give one pose (T_link_tool), not a list")
    return T[0]
