"""Poses given as data (a request's base pose): validated into 4x4 rigid transforms.

The world frame is the root link's frame unless a base pose ``T_world_root`` is given (for
robots whose base moves or is mounted); :mod:`kinematics.algorithms.base` re-expresses FK
and Jacobians in that world. A base pose is a 4x4 matrix (nested lists), ``{"xyz": [x, y, z], "rpy": [r, p, y]}`` (URDF
roll-pitch-yaw) or ``{"position": [x, y, z], "quaternion": {"w", "x", "y", "z"}}`` (unit); for a
batch, either one pose for every configuration or a list with one pose per configuration.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import BasePoseError, PoseError
from ..spatial.rotations import quaternion_to_matrix, rpy_to_matrix
from ..spatial.transforms import is_rigid_transform, make_transform
from ..tolerances import MAX_ABS_COORDINATE, RIGID_TOLERANCE


def _vector(value, n: int, where: str, error: type[PoseError] = BasePoseError) -> np.ndarray:
    if not isinstance(value, Sequence) or isinstance(value, (str, bytes)) or len(value) != n:
        raise error(f"{where}: expected {n} numbers, got {value!r}")
    try:
        v = np.array([float(x) for x in value])
    except (TypeError, ValueError):
        raise error(f"{where}: {value!r} is not a list of numbers") from None
    if not np.all(np.isfinite(v)) or np.any(np.abs(v) > MAX_ABS_COORDINATE):
        raise error(f"{where}: {value!r} has a non-finite value or one beyond +-{MAX_ABS_COORDINATE:g}")
    return v


def _one_pose(value, where: str, error: type[PoseError] = BasePoseError) -> np.ndarray:
    if isinstance(value, Mapping):
        keys = set(value)
        if keys == {"xyz", "rpy"}:
            return make_transform(rpy_to_matrix(_vector(value["rpy"], 3, f"{where}.rpy", error)),
                                  _vector(value["xyz"], 3, f"{where}.xyz", error))
        if keys == {"position", "quaternion"}:
            quat = value["quaternion"]
            if not isinstance(quat, Mapping) or set(quat) != {"w", "x", "y", "z"}:
                raise error(f"{where}.quaternion: expected {{\"w\", \"x\", \"y\", \"z\"}}, got {quat!r}")
            w, x, y, z = _vector([quat["w"], quat["x"], quat["y"], quat["z"]], 4, f"{where}.quaternion", error)
            norm = np.sqrt(w * w + x * x + y * y + z * z)
            if abs(norm - 1.0) > RIGID_TOLERANCE:
                raise error(f"{where}.quaternion: not a unit quaternion (norm {norm:.9g})")
            R = quaternion_to_matrix(*(np.array([w, x, y, z]) / norm))
            return make_transform(R, _vector(value["position"], 3, f"{where}.position", error))
        raise error(
            f"{where}: expected {{\"xyz\", \"rpy\"}}, {{\"position\", \"quaternion\"}} or a 4x4 matrix, "
            f"got the keys {sorted(map(str, keys))}"
        )
    if isinstance(value, Sequence) and not isinstance(value, (str, bytes)) and len(value) == 4:
        T = np.array([_vector(row, 4, f"{where}[{i}]", error) for i, row in enumerate(value)])
        if not is_rigid_transform(T, RIGID_TOLERANCE):
            raise error(f"{where}: not a rigid transform (rotation orthonormal with det 1, last row 0 0 0 1)")
        return T
    raise error(f"{where}: expected a pose, got {value!r}")


def _is_pose_list(value) -> bool:
    """A list of poses (as opposed to one 4x4 matrix, whose items are rows of numbers)."""
    return (isinstance(value, Sequence) and not isinstance(value, (str, bytes)) and len(value) > 0
            and all(isinstance(v, Mapping) or (isinstance(v, Sequence) and not isinstance(v, (str, bytes))
                                               and len(v) > 0 and not isinstance(v[0], (int, float)))
                    for v in value))


def base_poses(value, n: int) -> np.ndarray | None:
    """``T_world_root`` for each of ``n`` configurations: (n, 4, 4), or None when no base is given."""
    if value is None:
        return None
    if _is_pose_list(value):
        if len(value) != n:
            raise BasePoseError(f"base: {len(value)} poses given for {n} configurations (give one, or one each)")
        return np.stack([_one_pose(v, f"base[{i}]") for i, v in enumerate(value)])
    return np.broadcast_to(_one_pose(value, "base"), (n, 4, 4))


def pose_count(value) -> int:
    """How many poses ``value`` holds (before validation): a list's length, an array's first axis, else 1."""
    if isinstance(value, np.ndarray):
        return int(value.shape[0]) if value.ndim == 3 else 1
    return len(value) if _is_pose_list(value) else 1


def pose_list(value, field: str) -> tuple[np.ndarray, bool]:
    """``(T (N, 4, 4), is_batch)`` of one pose or a list of poses (any form above, or an
    ``(N, 4, 4)`` / ``(4, 4)`` array), each checked to be a finite rigid transform; errors
    (:class:`PoseError`) name ``field`` and the pose's index."""
    if isinstance(value, np.ndarray):
        if value.shape == (4, 4):
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
    if _is_pose_list(value):
        if isinstance(value[0], list):  # a batch of 4x4 matrices: checked as one array (~100x faster)
            try:
                arr = np.array(value, dtype=float)
            except (TypeError, ValueError):  # ragged or not numbers: the loop below names the pose
                arr = None
            if arr is not None and arr.ndim == 3 and arr.shape[1:] == (4, 4):
                return pose_list(arr, field)[0], True
        return np.stack([_one_pose(v, f"{field}[{i}]", PoseError) for i, v in enumerate(value)]), True
    if isinstance(value, Sequence) and not isinstance(value, (str, bytes)) and len(value) == 0:
        raise PoseError(f"{field}: an empty list of poses")
    return _one_pose(value, field, PoseError)[None], False


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
        T[:3, 3] = _vector(point, 3, "point", PoseError)
        return T
    if tool is None:
        return None
    T, is_batch = pose_list(tool, "tool")
    if is_batch:
        raise PoseError("tool: give one pose (T_link_tool), not a list")
    return T[0]


def floating_joint_values(values: Mapping, floating: Sequence[str], where: str = "") -> dict:
    """A ``{joint: value}`` map whose floating joints (names in ``floating``) may be given as a pose:
    ``{"position", "quaternion": {w, x, y, z}}`` (taken as given: its norm is checked, naming the
    joint, with the rest of q), ``{"xyz", "rpy"}`` or a 4x4 matrix (rigid) -> the same map with
    those joints as their 7 values ``x, y, z, qx, qy, qz, qw`` (Pinocchio's layout). Other
    values are left as they are.

    >>> floating_joint_values({"root": {"xyz": [1, 2, 3], "rpy": [0, 0, 0]}, "elbow": 0.5}, ["root"])
    {'root': [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0], 'elbow': 0.5}
    """
    from ..errors import JointValueError
    from ..spatial.rotations import matrix_to_quaternion

    out = dict(values)
    for name in floating:
        v = values.get(name)
        is_matrix = (isinstance(v, Sequence) and not isinstance(v, (str, bytes)) and len(v) == 4
                     and all(isinstance(r, Sequence) and not isinstance(r, (str, bytes)) for r in v))
        if not (isinstance(v, Mapping) or is_matrix):
            continue
        at = f"{where}joint {name!r}"
        if isinstance(v, Mapping) and set(v) == {"position", "quaternion"}:
            quat = v["quaternion"]
            if not isinstance(quat, Mapping) or set(quat) != {"w", "x", "y", "z"}:
                raise JointValueError(f"{at}: quaternion: expected {{\"w\", \"x\", \"y\", \"z\"}}, got {quat!r}")
            p = _vector(v["position"], 3, f"{at}: position", PoseError)
            out[name] = [*map(float, p), *(_scalar_of(quat[k], at) for k in ("x", "y", "z", "w"))]
            continue
        try:
            T = _one_pose(v, at, PoseError)
        except PoseError as exc:
            raise JointValueError(str(exc)) from None
        w, x, y, z = matrix_to_quaternion(T[:3, :3])
        out[name] = [*map(float, T[:3, 3]), float(x), float(y), float(z), float(w)]
    return out


def _scalar_of(v, where: str) -> float:
    from ..errors import JointValueError

    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise JointValueError(f"{where}: quaternion entry {v!r} is not a number")
    return float(v)
