"""Poses given as data (JSON-like values) read into 4x4 rigid transforms.

A pose is a 4x4 matrix (nested lists), ``{"xyz": [x, y, z], "rpy": [r, p, y]}`` (URDF
roll-pitch-yaw) or ``{"position": [x, y, z], "quaternion": {"w", "x", "y", "z"}}`` (unit). Both
the request readers of :mod:`kinematics.io.poses` (base poses, targets, tools) and the joint-value
reader of :mod:`kinematics.model.joint_values` (a floating joint's value given as a pose) read
them here; errors name ``where`` the value was and are of the class the caller asks for.

>>> read_pose({"xyz": [1, 2, 3], "rpy": [0, 0, 0]}, "base")[:3, 3]
array([1., 2., 3.])
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import BasePoseError, PoseError
from ..tolerances import MAX_ABS_COORDINATE, RIGID_TOLERANCE
from .rotations import quaternion_to_matrix, rpy_to_matrix
from .transforms import is_rigid_transform, make_transform


def read_vector(value, n: int, where: str, error: type[PoseError] = BasePoseError) -> np.ndarray:
    """``n`` finite numbers (each within +-MAX_ABS_COORDINATE) as a float array, else ``error``."""
    if not isinstance(value, Sequence) or isinstance(value, (str, bytes)) or len(value) != n:
        raise error(f"{where}: expected {n} numbers, got {value!r}")
    try:
        v = np.array([float(x) for x in value])
    except (TypeError, ValueError):
        raise error(f"{where}: {value!r} is not a list of numbers") from None
    if not np.all(np.isfinite(v)) or np.any(np.abs(v) > MAX_ABS_COORDINATE):
        raise error(f"{where}: {value!r} has a non-finite value or one beyond +-{MAX_ABS_COORDINATE:g}")
    return v


def read_pose(value, where: str, error: type[PoseError] = BasePoseError) -> np.ndarray:
    """One pose in any of the forms above as a (4, 4) rigid transform, else ``error`` naming ``where``."""
    if isinstance(value, Mapping):
        keys = set(value)
        if keys == {"xyz", "rpy"}:
            return make_transform(rpy_to_matrix(read_vector(value["rpy"], 3, f"{where}.rpy", error)),
                                  read_vector(value["xyz"], 3, f"{where}.xyz", error))
        if keys == {"position", "quaternion"}:
            quat = value["quaternion"]
            if not isinstance(quat, Mapping) or set(quat) != {"w", "x", "y", "z"}:
                raise error(f"{where}.quaternion: expected {{\"w\", \"x\", \"y\", \"z\"}}, got {quat!r}")
            w, x, y, z = read_vector([quat["w"], quat["x"], quat["y"], quat["z"]], 4, f"{where}.quaternion", error)
            norm = np.sqrt(w * w + x * x + y * y + z * z)
            if abs(norm - 1.0) > RIGID_TOLERANCE:
                raise error(f"{where}.quaternion: not a unit quaternion (norm {norm:.9g})")
            R = quaternion_to_matrix(*(np.array([w, x, y, z]) / norm))
            return make_transform(R, read_vector(value["position"], 3, f"{where}.position", error))
        raise error(
            f"{where}: expected {{\"xyz\", \"rpy\"}}, {{\"position\", \"quaternion\"}} or a 4x4 matrix, "
            f"got the keys {sorted(map(str, keys))}"
        )
    if isinstance(value, Sequence) and not isinstance(value, (str, bytes)) and len(value) == 4:
        T = np.array([read_vector(row, 4, f"{where}[{i}]", error) for i, row in enumerate(value)])
        if not is_rigid_transform(T, RIGID_TOLERANCE):
            raise error(f"{where}: not a rigid transform (rotation orthonormal with det 1, last row 0 0 0 1)")
        return T
    raise error(f"{where}: expected a pose, got {value!r}")


def is_pose_list(value) -> bool:
    """A list of poses (as opposed to one 4x4 matrix, whose items are rows of numbers)."""
    return (isinstance(value, Sequence) and not isinstance(value, (str, bytes)) and len(value) > 0
            and all(isinstance(v, Mapping) or (isinstance(v, Sequence) and not isinstance(v, (str, bytes))
                                               and len(v) > 0 and not isinstance(v[0], (int, float)))
                    for v in value))
