"""Rigid transforms: SE(3) as 4x4 homogeneous matrices, and exponentials of screws.

``T_a_b`` maps coordinates in frame ``b`` to frame ``a``: ``p_a = T_a_b @ p_b``. A screw
``S = (w, v)`` puts the angular part first here, as Modern Robotics does; the Jacobians the
library returns put the linear rows first (Pinocchio's order).
"""

from __future__ import annotations

import numpy as np

from ..errors import KinematicsError
from ..tolerances import RIGID_TOLERANCE
from .rotations import matrix_to_quaternion, matrix_to_rpy, skew

def cross3(a, b) -> np.ndarray:
    """``a × b`` of two 3-vectors: the arithmetic of ``np.cross`` (the same bits) without its
    broadcasting machinery, which costs tens of microseconds a call on a pair of 3-vectors."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def make_transform(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Homogeneous 4x4 transform from a rotation (3, 3) and a translation (3,)."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


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


def is_rigid_transform(T, tol: float = RIGID_TOLERANCE) -> bool:
    """True when ``T`` is a finite 4x4 homogeneous transform with a proper rotation."""
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        return False
    R = T[:3, :3]
    return bool(
        np.allclose(R.T @ R, np.eye(3), atol=tol)
        and abs(np.linalg.det(R) - 1.0) < tol
        and np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=tol)
    )


def exp_screws(w: np.ndarray, r: np.ndarray, revolute: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``exp([S_j] theta_j)`` (..., n, 4, 4) of n unit screws and their values ``theta`` (..., n).

    A revolute screw turns about the unit axis ``w_j`` through the point ``r_j``
    (``S_j = (w_j, -w_j x r_j)``): Rodrigues' rotation ``R = I + sin θ [w] + (1 - cos θ) [w]^2``
    and the translation ``(I - R) r_j``. A prismatic one slides along ``w_j``: ``(I, θ w_j)``.

    A quarter turn about the z axis through (1, 0, 0) takes the origin to (1, -1, 0):

    >>> T = exp_screws(np.array([[0.0, 0, 1]]), np.array([[1.0, 0, 0]]), np.array([True]), np.array([np.pi / 2]))
    >>> T[0, :3, 3].round(12) + 0.0
    array([ 1., -1.,  0.])
    """
    theta = np.asarray(theta, dtype=float)
    K = skew(w)  # (n, 3, 3)
    s = np.sin(theta)[..., None, None]
    c = (1.0 - np.cos(theta))[..., None, None]
    R = np.eye(3) + s * K + c * (K @ K)
    R = np.where(revolute[:, None, None], R, np.eye(3))
    E = np.zeros(theta.shape + (4, 4))
    E[..., 3, 3] = 1.0
    E[..., :3, :3] = R
    p_rev = np.einsum("...kij,kj->...ki", np.eye(3) - R, r)
    p_pri = theta[..., None] * w
    E[..., :3, 3] = np.where(revolute[:, None], p_rev, p_pri)
    return E


def pose_components(T: np.ndarray) -> dict[str, np.ndarray]:
    """Position (..., 3), quaternion ``(w, x, y, z)`` (..., 4) and URDF rpy (..., 3) of poses (..., 4, 4).

    >>> from kinematics.spatial.rotations import rpy_to_matrix
    >>> c = pose_components(make_transform(rpy_to_matrix([0.0, 0.0, np.pi]), [1.0, 2.0, 3.0]))
    >>> c["position"].tolist(), c["quaternion"].round(12).tolist(), c["rpy"].round(12).tolist()
    ([1.0, 2.0, 3.0], [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 3.14159265359])
    """
    T = np.asarray(T, dtype=float)
    return {
        "position": T[..., :3, 3],
        "quaternion": matrix_to_quaternion(T[..., :3, :3]),
        "rpy": matrix_to_rpy(T[..., :3, :3]),
    }


def as_tool(tool) -> np.ndarray | None:
    """A tool offset ``T_link_tool`` as a (4, 4) float64 array (None stays None); another shape is a
    :class:`~kinematics.errors.KinematicsError`."""
    if tool is None:
        return None
    T = np.asarray(tool, dtype=np.float64)
    if T.shape != (4, 4):
        raise KinematicsError(f"a tool offset must be a 4x4 transform, got shape {T.shape}")
    return T
