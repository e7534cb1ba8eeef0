"""Rotations: SO(3) conversions (skew matrices, URDF roll-pitch-yaw, unit quaternions).

``R_a_b`` is the orientation of frame ``b`` in frame ``a``. Roll-pitch-yaw follows URDF,
``R = Rz(yaw) Ry(pitch) Rx(roll)``; quaternions are ``(w, x, y, z)`` with ``w >= 0``.
Functions accept a leading batch dimension where stated.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: |cos(pitch)| below which a rotation counts as at the gimbal lock (roll set to 0)
GIMBAL_EPS = 1e-12


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

    Accurate to rounding everywhere, the gimbal lock included: pitch is
    ``atan2(-R20, hypot(R21, R22))`` (not an arcsine, which loses half the digits near
    ±pi/2), and yaw is fitted to the residual ``R (Ry(pitch) Rx(roll))^T``, so an
    ill-conditioned roll near the lock is compensated. Within :data:`GIMBAL_EPS` of the lock
    roll is 0 and yaw carries the rotation (the error of dropping roll there is below it).

    >>> rpy = np.array([0.3, np.pi / 2 - 1e-8, 0.2])
    >>> bool(np.abs(rpy_to_matrix(matrix_to_rpy(rpy_to_matrix(rpy))) - rpy_to_matrix(rpy)).max() < 1e-15)
    True
    """
    R = np.asarray(R, dtype=float)
    if R.size <= 9 * SCALAR_RPY_MAX:  # a few rotations: the same operations on scalars (the same bits)
        rows = [_rpy_one(r) for r in R.reshape(-1, 3, 3)]
        return (np.array(rows) if rows else np.empty((0, 3))).reshape(R.shape[:-2] + (3,))
    return _rpy_batch(R)


def _rpy_batch(R: np.ndarray) -> np.ndarray:
    """:func:`matrix_to_rpy` of float64 rotations (..., 3, 3) as array operations."""
    r21, r22 = R[..., 2, 1], R[..., 2, 2]
    c = np.hypot(r21, r22)  # |cos(pitch)|
    pitch = np.arctan2(-R[..., 2, 0], c)
    roll = np.where(c > GIMBAL_EPS, np.arctan2(r21, r22), 0.0)
    cp, sp, cr, sr = np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    # rows of M = Ry(pitch) Rx(roll); Rz(yaw) = R M^T, whose (1,0) - (0,1) and (0,0) + (1,1) give yaw
    m0 = np.stack([cp, sp * sr, sp * cr], axis=-1)
    m1 = np.stack([np.zeros_like(cr), cr, -sr], axis=-1)
    r0, r1 = R[..., 0, :], R[..., 1, :]
    z00, z01 = np.sum(r0 * m0, axis=-1), np.sum(r0 * m1, axis=-1)
    z10, z11 = np.sum(r1 * m0, axis=-1), np.sum(r1 * m1, axis=-1)
    yaw = np.arctan2(z10 - z01, z00 + z11)
    return np.stack([roll, pitch, yaw], axis=-1)


#: up to this many rotations :func:`matrix_to_rpy` computes one at a time on scalars (~5 µs each;
#: the array code costs ~35 µs whatever the count up to a few hundred: a single FK answer's rpy)
SCALAR_RPY_MAX = 6


def _rpy_one(R: np.ndarray) -> np.ndarray:
    """:func:`matrix_to_rpy` of one rotation (3, 3), operation for operation on scalars: the same
    ufuncs (``np.hypot``, ``np.arctan2``, ``np.cos``, ``np.sin``, each on one value as in the
    batch), and each ``np.sum`` over three products as numpy reduces it, ``((0 + a) + b) + c``
    (the zero first: a sum of negative zeros is +0). ``tests/kinematics/spatial`` compares the
    two bit for bit, the gimbal lock and signed zeros included."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R.tolist()
    c = np.hypot(r21, r22)
    pitch = np.arctan2(-r20, c)
    roll = np.arctan2(r21, r22) if c > GIMBAL_EPS else 0.0
    cp, sp, cr, sr = np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    m01, m02, m12 = sp * sr, sp * cr, -sr  # M = Ry(pitch) Rx(roll): rows (cp, m01, m02), (0, cr, m12)
    z00 = 0.0 + r00 * cp + r01 * m01 + r02 * m02
    z01 = 0.0 + r00 * 0.0 + r01 * cr + r02 * m12
    z10 = 0.0 + r10 * cp + r11 * m01 + r12 * m02
    z11 = 0.0 + r10 * 0.0 + r11 * cr + r12 * m12
    return np.array([roll, pitch, np.arctan2(z10 - z01, z00 + z11)])


def matrix_to_rpy_exact(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (``R = Rz(y) Ry(p) Rx(r)``) that reproduce ``R`` to rounding, even
    at or near the gimbal lock: yaw is fitted to the residual ``R (Ry(p) Rx(r))^T`` so that an
    ill-conditioned roll is compensated."""
    R = np.asarray(R, dtype=float)
    pitch = math.atan2(-R[2, 0], math.hypot(R[2, 1], R[2, 2]))
    roll = math.atan2(R[2, 1], R[2, 2]) if math.hypot(R[2, 1], R[2, 2]) > 1e-300 else 0.0
    M = rpy_to_matrix((roll, pitch, 0.0))
    Z = R @ M.T  # = Rz(yaw) up to rounding
    yaw = math.atan2(Z[1, 0] - Z[0, 1], Z[0, 0] + Z[1, 1])
    return roll, pitch, yaw


def matrix_to_quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion(s) ``(w, x, y, z)`` of rotation(s) ``R`` (..., 3, 3) -> (..., 4), w >= 0.

    Shepperd's method: the numerically largest of the four candidates per rotation
    (compiled with numba: a pose's quaternion is a few nanoseconds, not ~40 numpy calls).

    >>> matrix_to_quaternion(rpy_to_matrix([0.0, 0.0, np.pi / 2])).round(12)
    array([0.70710678, 0.        , 0.        , 0.70710678])
    """
    R = np.asarray(R, dtype=float)
    batch = R.shape[:-2]
    flat = np.ascontiguousarray(R.reshape(-1, 3, 3))
    return quaternions(flat, np.empty((flat.shape[0], 4))).reshape(batch + (4,))


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """The angle (..., ) in [0, π] of rotation(s) ``R`` (..., 3, 3), accurate for small angles too
    (``atan2`` of the skew and symmetric parts, not an arccosine of the trace).

    >>> float(rotation_angle(rpy_to_matrix([0.0, 0.0, 1e-9])))
    1e-09
    """
    R = np.asarray(R, dtype=float)
    s = 0.5 * np.sqrt((R[..., 2, 1] - R[..., 1, 2]) ** 2 + (R[..., 0, 2] - R[..., 2, 0]) ** 2
                      + (R[..., 1, 0] - R[..., 0, 1]) ** 2)
    c = 0.5 * (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1.0)
    return np.arctan2(s, c)


def quaternion_to_matrix(w: float, x: float, y: float, z: float) -> np.ndarray:
    """Rotation (3, 3) of the unit quaternion ``(w, x, y, z)`` (the inverse of :func:`matrix_to_quaternion`)."""
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


@nb.njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def quaternions(R, out):
    """Unit quaternions ``(w, x, y, z)``, w >= 0, of rotations R (M, 3, 3) into out (M, 4).

    Shepperd's method: the largest of trace, R00, R11, R22 (the first on ties) picks the
    formula, so the square root is of a number at least 1 (well conditioned).
    """
    for i in range(R.shape[0]):
        m00, m01, m02 = R[i, 0, 0], R[i, 0, 1], R[i, 0, 2]
        m10, m11, m12 = R[i, 1, 0], R[i, 1, 1], R[i, 1, 2]
        m20, m21, m22 = R[i, 2, 0], R[i, 2, 1], R[i, 2, 2]
        trace = m00 + m11 + m22
        k = 0
        best = trace
        if m00 > best:
            k, best = 1, m00
        if m11 > best:
            k, best = 2, m11
        if m22 > best:
            k = 3
        if k == 0:
            s = math.sqrt(max(1.0 + trace, 0.0)) * 2.0
            w, x, y, z = 0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s
        elif k == 1:
            s = math.sqrt(max(1.0 + m00 - m11 - m22, 0.0)) * 2.0
            w, x, y, z = (m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s
        elif k == 2:
            s = math.sqrt(max(1.0 + m11 - m22 - m00, 0.0)) * 2.0
            w, x, y, z = (m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s
        else:
            s = math.sqrt(max(1.0 + m22 - m00 - m11, 0.0)) * 2.0
            w, x, y, z = (m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s
        if w < 0.0:
            w, x, y, z = -w, -x, -y, -z
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        out[i, 0] = w / norm
        out[i, 1] = x / norm
        out[i, 2] = y / norm
        out[i, 3] = z / norm
    return out
