"""Rigid-body transforms: SO(3)/SE(3) helpers used by the PoE kernels and the output code.

Conventions (``../shared/DESIGN.md``): ``T_a_b`` maps coordinates in frame ``b`` to frame
``a``. Twists and screws are ``(w, v)`` (angular first) inside this module, as in Modern
Robotics; the public Jacobians put linear rows first (Pinocchio's order).
All functions accept a leading batch dimension where stated.
"""

from __future__ import annotations

import numpy as np

#: Below this norm an axis is treated as zero (refused by the parser).
AXIS_EPS = 1e-12


def skew(w: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrix ``[w]`` of a 3-vector (or of a batch ``(..., 3)``).

    >>> skew(np.array([1.0, 2.0, 3.0]))
    array([[ 0., -3.,  2.],
           [ 3.,  0., -1.],
           [-2.,  1.,  0.]])
    """
    w = np.asarray(w, dtype=float)
    out = np.zeros(w.shape[:-1] + (3, 3))
    out[..., 0, 1] = -w[..., 2]
    out[..., 0, 2] = w[..., 1]
    out[..., 1, 0] = w[..., 2]
    out[..., 1, 2] = -w[..., 0]
    out[..., 2, 0] = -w[..., 1]
    out[..., 2, 1] = w[..., 0]
    return out


def rpy_to_matrix(rpy) -> np.ndarray:
    """Rotation of URDF roll-pitch-yaw: ``R = Rz(yaw) Ry(pitch) Rx(roll)``, shape (3, 3)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_to_rpy(R: np.ndarray) -> np.ndarray:
    """URDF roll-pitch-yaw of rotation(s) ``R`` (..., 3, 3) -> (..., 3); pitch in [-pi/2, pi/2].

    At the gimbal lock (|pitch| = pi/2) roll is set to 0 and yaw carries the rotation.
    """
    R = np.asarray(R, dtype=float)
    pitch = np.arcsin(np.clip(-R[..., 2, 0], -1.0, 1.0))
    cp = np.sqrt(R[..., 0, 0] ** 2 + R[..., 1, 0] ** 2)
    regular = cp > 1e-10
    roll = np.where(regular, np.arctan2(R[..., 2, 1], R[..., 2, 2]), 0.0)
    yaw = np.where(
        regular,
        np.arctan2(R[..., 1, 0], R[..., 0, 0]),
        np.arctan2(-R[..., 0, 1], R[..., 1, 1]),
    )
    return np.stack([roll, pitch, yaw], axis=-1)


def matrix_to_quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion(s) ``(w, x, y, z)`` of rotation(s) ``R`` (..., 3, 3) -> (..., 4), w >= 0.

    Shepperd's method: picks the numerically largest of the four candidates per rotation
    (compiled: :func:`kinematics.compiled.quaternions`; numpy needed ~40 calls, 90 µs for
    one pose).
    """
    from .compiled import quaternions  # numba: imported on first use

    R = np.asarray(R, dtype=float)
    batch = R.shape[:-2]
    flat = np.ascontiguousarray(R.reshape(-1, 3, 3))
    return quaternions(flat, np.empty((flat.shape[0], 4))).reshape(batch + (4,))


def quaternion_to_matrix(w: float, x: float, y: float, z: float) -> np.ndarray:
    """Rotation (3, 3) of the unit quaternion ``(w, x, y, z)`` (the inverse of :func:`matrix_to_quaternion`)."""
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def make_transform(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Homogeneous 4x4 transform from a rotation (3, 3) and a translation (3,)."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def origin_to_matrix(xyz, rpy) -> np.ndarray:
    """``T_parent_joint`` of a URDF ``<origin xyz rpy>``."""
    return make_transform(rpy_to_matrix(rpy), np.asarray(xyz, dtype=float))


def inverse_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transform(s) ``T`` (..., 4, 4) without a general matrix inverse."""
    T = np.asarray(T, dtype=float)
    R = T[..., :3, :3]
    p = T[..., :3, 3]
    out = np.zeros(T.shape)
    Rt = np.swapaxes(R, -1, -2)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, p)
    out[..., 3, 3] = 1.0
    return out


def is_rigid_transform(T, tol: float = 1e-6) -> bool:
    """True when ``T`` is a finite 4x4 homogeneous transform with a proper rotation."""
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        return False
    R = T[:3, :3]
    return (
        np.allclose(R.T @ R, np.eye(3), atol=tol)
        and abs(np.linalg.det(R) - 1.0) < tol
        and np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=tol)
    )


def exp_so3(w: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Rodrigues: ``exp([w] theta)`` for a unit axis ``w`` (3,) and angles ``theta`` (N,) -> (N, 3, 3)."""
    theta = np.asarray(theta, dtype=float)
    K = skew(w)
    K2 = K @ K
    s = np.sin(theta)[:, None, None]
    c = (1.0 - np.cos(theta))[:, None, None]
    return np.eye(3) + s * K + c * K2


def adjoint(T: np.ndarray) -> np.ndarray:
    """Adjoint ``Ad_T`` (6x6, angular-first twists) of transform(s) (..., 4, 4)."""
    T = np.asarray(T, dtype=float)
    R = T[..., :3, :3]
    p = T[..., :3, 3]
    out = np.zeros(T.shape[:-2] + (6, 6))
    out[..., :3, :3] = R
    out[..., 3:, 3:] = R
    out[..., 3:, :3] = skew(p) @ R
    return out
