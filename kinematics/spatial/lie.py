"""Batched SO(3)/SE(3) maps for multi-dof joints: quaternions in Pinocchio's order ``(x, y, z, w)``,
and the exponentials that integrate a twist (linear part first).

>>> R = quaternion_xyzw_to_matrix(np.array([0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)]))
>>> R.round(12) + 0.0
array([[ 0., -1.,  0.],
       [ 1.,  0.,  0.],
       [ 0.,  0.,  1.]])
>>> T = se3_exp(np.array([1.0, 0.0, 0.0, 0.0, 0.0, np.pi]))  # a half-turn screw about z while moving along x
>>> T[:3, 3].round(12) + 0.0
array([0.        , 0.63661977, 0.        ])
"""

from __future__ import annotations

import numpy as np

from .rotations import matrix_to_quaternion, skew


def quaternion_xyzw_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotations (..., 3, 3) of unit quaternions (..., 4) given as ``(x, y, z, w)`` (Eigen's formula)."""
    q = np.asarray(q, dtype=float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - w * z)
    R[..., 0, 2] = 2 * (x * z + w * y)
    R[..., 1, 0] = 2 * (x * y + w * z)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - w * x)
    R[..., 2, 0] = 2 * (x * z - w * y)
    R[..., 2, 1] = 2 * (y * z + w * x)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def matrix_to_quaternion_xyzw(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) ``(x, y, z, w)``, ``w >= 0``, of rotations (..., 3, 3)."""
    wxyz = matrix_to_quaternion(R)
    return np.concatenate([wxyz[..., 1:], wxyz[..., :1]], axis=-1)


def _coefficients(theta: np.ndarray):
    """``sin t / t``, ``(1 - cos t) / t^2``, ``(t - sin t) / t^3`` with their series near 0."""
    small = theta < 1e-4
    t = np.where(small, 1.0, theta)
    t2 = theta * theta
    a = np.where(small, 1 - t2 / 6 + t2 * t2 / 120, np.sin(t) / t)
    b = np.where(small, 0.5 - t2 / 24 + t2 * t2 / 720, (1 - np.cos(t)) / (t * t))
    c = np.where(small, 1 / 6 - t2 / 120 + t2 * t2 / 5040, (t - np.sin(t)) / (t * t * t))
    return a, b, c


def se3_exp(xi: np.ndarray) -> np.ndarray:
    """``exp`` (..., 4, 4) of twists (..., 6) ``(v, w)``, **linear part first** (Pinocchio's ``exp6``):
    the motion of a body moving with that constant twist (in its own frame) for unit time."""
    xi = np.asarray(xi, dtype=float)
    v, w = xi[..., :3], xi[..., 3:]
    a, b, c = _coefficients(np.linalg.norm(w, axis=-1))
    K = skew(w)
    K2 = K @ K
    T = np.zeros(xi.shape[:-1] + (4, 4))
    T[..., :3, :3] = np.eye(3) + a[..., None, None] * K + b[..., None, None] * K2
    V = np.eye(3) + b[..., None, None] * K + c[..., None, None] * K2
    T[..., :3, 3] = (V @ v[..., None])[..., 0]
    T[..., 3, 3] = 1.0
    return T


def so3_log(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) of rotations (..., 3, 3), angle in [0, π] (through the unit
    quaternion, so accurate near 0 and near a half turn).

    >>> so3_log(se3_exp(np.array([0.0, 0.0, 0.0, 0.3, -0.2, 0.1]))[:3, :3]).round(12)
    array([ 0.3, -0.2,  0.1])
    """
    q = matrix_to_quaternion(R)  # (w, x, y, z), w >= 0
    v = q[..., 1:]
    s = np.linalg.norm(v, axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 0])
    scale = np.where(s > 1e-12, angle / np.where(s > 1e-12, s, 1.0), 2.0)
    return v * scale[..., None]
