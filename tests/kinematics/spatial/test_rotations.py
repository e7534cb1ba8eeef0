"""SO(3) conversions of kinematics.spatial.rotations, checked against numpy and scipy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinematics.spatial.rotations import (
    matrix_to_quaternion,
    matrix_to_rpy,
    matrix_to_rpy_exact,
    quaternion_to_matrix,
    rpy_to_matrix,
    skew,
)

TOL = 1e-12


def scipy_wxyz(R: np.ndarray) -> np.ndarray:
    """scipy's quaternion(s) of R (..., 3, 3) in (w, x, y, z) order with w >= 0."""
    xyzw = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat()
    wxyz = np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)
    wxyz[wxyz[:, 0] < 0] *= -1.0
    return wxyz.reshape(R.shape[:-2] + (4,))


def random_rotations(rng, n: int) -> np.ndarray:
    return Rotation.random(n, random_state=rng).as_matrix()


# ---------------------------------------------------------------------- skew
def test_skew_is_the_cross_product(rng):
    for _ in range(20):
        w, v = rng.normal(size=3), rng.normal(size=3)
        np.testing.assert_allclose(skew(w) @ v, np.cross(w, v), atol=TOL)


def test_skew_is_antisymmetric_and_batched(rng):
    W = rng.normal(size=(4, 5, 3))
    K = skew(W)
    assert K.shape == (4, 5, 3, 3)
    np.testing.assert_array_equal(K, -np.swapaxes(K, -1, -2))
    V = rng.normal(size=(4, 5, 3))
    np.testing.assert_allclose(np.einsum("...ij,...j->...i", K, V), np.cross(W, V), atol=TOL)


# ---------------------------------------------------------------------- roll-pitch-yaw
def test_rpy_to_matrix_is_urdf_convention(rng):
    """R = Rz(yaw) Ry(pitch) Rx(roll): scipy's intrinsic 'ZYX' with angles (yaw, pitch, roll)."""
    for _ in range(20):
        r, p, y = rng.uniform(-np.pi, np.pi, size=3)
        expected = Rotation.from_euler("ZYX", [y, p, r]).as_matrix()
        np.testing.assert_allclose(rpy_to_matrix([r, p, y]), expected, atol=TOL)


def test_rpy_round_trip_on_random_angles(rng):
    for _ in range(200):
        r, y = rng.uniform(-np.pi, np.pi, size=2)
        p = rng.uniform(-np.pi / 2 + 1e-3, np.pi / 2 - 1e-3)
        R = rpy_to_matrix([r, p, y])
        np.testing.assert_allclose(matrix_to_rpy(R), [r, p, y], atol=1e-9)
        np.testing.assert_allclose(rpy_to_matrix(matrix_to_rpy(R)), R, atol=TOL)


def test_matrix_to_rpy_batch_shape(rng):
    angles = np.stack([rng.uniform(-np.pi, np.pi, 12), rng.uniform(-1.5, 1.5, 12), rng.uniform(-np.pi, np.pi, 12)], axis=1)
    R = np.array([rpy_to_matrix(a) for a in angles]).reshape(3, 4, 3, 3)
    out = matrix_to_rpy(R)
    assert out.shape == (3, 4, 3)
    np.testing.assert_allclose(out.reshape(12, 3), angles, atol=1e-9)


@pytest.mark.parametrize("pitch", [np.pi / 2, -np.pi / 2])
def test_matrix_to_rpy_at_gimbal_lock_sets_roll_to_zero(rng, pitch):
    for _ in range(20):
        r, y = rng.uniform(-np.pi, np.pi, size=2)
        R = rpy_to_matrix([r, pitch, y])
        roll, p, yaw = matrix_to_rpy(R)
        assert roll == 0.0
        assert p == pytest.approx(pitch, abs=1e-7)
        np.testing.assert_allclose(rpy_to_matrix([roll, p, yaw]), R, atol=TOL)


@pytest.mark.parametrize("eps", [0.0, 1e-14, 1e-12, 1e-9, 1e-7, 1e-5, 1e-3])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_matrix_to_rpy_exact_reproduces_near_and_at_gimbal_lock(rng, eps, sign):
    for _ in range(20):
        r, y = rng.uniform(-np.pi, np.pi, size=2)
        R = rpy_to_matrix([r, sign * (np.pi / 2 - eps), y])
        angles = matrix_to_rpy_exact(R)
        assert len(angles) == 3 and all(isinstance(a, float) for a in angles)
        np.testing.assert_allclose(rpy_to_matrix(angles), R, rtol=0, atol=2e-15)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_rpy_at_an_exact_gimbal_lock_matrix(rng, sign):
    """A rotation with pitch = +-pi/2 whose entries R00, R10, R21, R22 are exactly 0 (as a
    product of quarter turns gives): only roll -+ yaw is defined; both conversions set roll
    to 0 and reproduce the rotation."""
    for _ in range(10):
        a = rng.uniform(-np.pi, np.pi)
        s, c = np.sin(a), np.cos(a)
        R = np.array([[0.0, s, c], [0.0, c, -s], [-1.0, 0.0, 0.0]]) if sign > 0 else \
            np.array([[0.0, -s, -c], [0.0, c, -s], [1.0, 0.0, 0.0]])
        assert np.allclose(R @ R.T, np.eye(3)) and np.linalg.det(R) == pytest.approx(1.0)
        for angles in (matrix_to_rpy(R), matrix_to_rpy_exact(R)):
            assert angles[0] == 0.0
            assert angles[1] == pytest.approx(sign * np.pi / 2)
            np.testing.assert_allclose(rpy_to_matrix(angles), R, rtol=0, atol=2e-15)


@pytest.mark.parametrize("eps", [1e-12, 1e-10, 1e-8])
def test_matrix_to_rpy_exact_near_lock_with_rounded_entries(rng, eps):
    """Near the lock a matrix from another source (here via scipy's quaternions) has absolute
    errors of ~1e-16 in the tiny entries R00, R10, R21, R22; the exact conversion still
    reproduces it, where yaw from atan2(R10, R00) alone would not."""
    for _ in range(20):
        r, y = rng.uniform(-np.pi, np.pi, size=2)
        R = Rotation.from_euler("ZYX", [y, np.pi / 2 - eps, r]).as_matrix()
        np.testing.assert_allclose(rpy_to_matrix(matrix_to_rpy_exact(R)), R, rtol=0, atol=2e-15)


def test_matrix_to_rpy_exact_on_random_rotations(rng):
    for R in random_rotations(rng, 50):
        np.testing.assert_allclose(rpy_to_matrix(matrix_to_rpy_exact(R)), R, rtol=0, atol=2e-15)


# ---------------------------------------------------------------------- quaternions
def test_matrix_to_quaternion_matches_scipy(rng):
    R = random_rotations(rng, 200)
    q = matrix_to_quaternion(R)
    np.testing.assert_allclose(q, scipy_wxyz(R), atol=TOL)


def test_matrix_to_quaternion_batch_shapes_unit_norm_and_sign(rng):
    R = random_rotations(rng, 24)
    for shape in [(24,), (4, 6), (2, 3, 4)]:
        q = matrix_to_quaternion(R.reshape(shape + (3, 3)))
        assert q.shape == shape + (4,)
        np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-15)
        assert np.all(q[..., 0] >= 0.0)
        np.testing.assert_array_equal(q.reshape(24, 4), matrix_to_quaternion(R))
    single = matrix_to_quaternion(R[0])
    assert single.shape == (4,)
    np.testing.assert_array_equal(single, matrix_to_quaternion(R)[0])


def test_matrix_to_quaternion_of_non_contiguous_input(rng):
    """A transposed view (the inverse rotations) is read as given, not as its memory layout."""
    R = random_rotations(rng, 10)
    Rt = np.swapaxes(R, -1, -2)
    assert not Rt.flags.c_contiguous
    np.testing.assert_allclose(matrix_to_quaternion(Rt), scipy_wxyz(np.ascontiguousarray(Rt)), atol=TOL)


def test_quaternion_to_matrix_inverts_matrix_to_quaternion(rng):
    for R in random_rotations(rng, 50):
        np.testing.assert_allclose(quaternion_to_matrix(*matrix_to_quaternion(R)), R, atol=TOL)


def test_quaternion_to_matrix_matches_scipy(rng):
    for _ in range(20):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        w, x, y, z = q
        np.testing.assert_allclose(quaternion_to_matrix(w, x, y, z), Rotation.from_quat([x, y, z, w]).as_matrix(), atol=TOL)


@pytest.mark.parametrize(
    "R, expected",
    [
        (np.eye(3), [1.0, 0.0, 0.0, 0.0]),  # trace largest
        (np.diag([1.0, -1.0, -1.0]), [0.0, 1.0, 0.0, 0.0]),  # pi about x: R00 largest
        (np.diag([-1.0, 1.0, -1.0]), [0.0, 0.0, 1.0, 0.0]),  # pi about y: R11 largest
        (np.diag([-1.0, -1.0, 1.0]), [0.0, 0.0, 0.0, 1.0]),  # pi about z: R22 largest
    ],
    ids=["identity", "pi_about_x", "pi_about_y", "pi_about_z"],
)
def test_shepperd_branches_exact(R, expected):
    np.testing.assert_array_equal(matrix_to_quaternion(R), expected)


@pytest.mark.parametrize("axis", [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], ids=["x", "y", "z"])
@pytest.mark.parametrize("delta", [0.0, 1e-8, 1e-6, 1e-3])
def test_shepperd_branches_near_half_turn_are_accurate(axis, delta):
    """Just short of a half turn about a coordinate axis (slightly tilted), where the trace
    formula alone would lose most digits: each diagonal branch must agree with scipy."""
    axis = np.array(axis) + np.array([0.01, -0.02, 0.03])
    axis /= np.linalg.norm(axis)
    R = Rotation.from_rotvec((np.pi - delta) * axis).as_matrix()
    q = matrix_to_quaternion(R)
    expected = np.concatenate([[np.cos((np.pi - delta) / 2)], np.sin((np.pi - delta) / 2) * axis])
    if delta == 0.0:  # w is 0 to rounding: the sign is not defined
        q = q * np.sign(q[1:] @ expected[1:])
    np.testing.assert_allclose(q, expected, atol=1e-13)


@pytest.mark.parametrize("angle", [1e-12, 1e-8, 1e-4, 0.5])
def test_small_angle_uses_trace_branch_accurately(rng, angle):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    R = Rotation.from_rotvec(angle * axis).as_matrix()
    expected = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])
    np.testing.assert_allclose(matrix_to_quaternion(R), expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize("eps", [0.0, 1e-13, 1e-11, 1e-10, 1e-8, 1e-6])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_matrix_to_rpy_reproduces_the_rotation_near_the_gimbal_lock(eps, sign):
    """The rpy of every FK answer rebuild its rotation to well within the 1e-9 agreement, near
    the lock too (an arcsine pitch and a plain atan2 yaw were off by up to 1e-6 there)."""
    from scipy.spatial.transform import Rotation

    for yaw, roll in [(-0.3, -2.0), (1.1, 0.4), (3.0, -3.0)]:
        R = Rotation.from_euler("ZYX", [yaw, sign * (np.pi / 2 - eps), roll]).as_matrix()
        assert np.abs(rpy_to_matrix(matrix_to_rpy(R)) - R).max() < 1e-12
    batch = np.stack([Rotation.from_euler("ZYX", [0.2 * k, sign * (np.pi / 2 - eps), -0.1 * k]).as_matrix()
                      for k in range(8)])
    rpy = matrix_to_rpy(batch)
    assert rpy.shape == (8, 3)
    assert max(np.abs(rpy_to_matrix(a) - R).max() for a, R in zip(rpy, batch)) < 1e-12


def test_a_few_rotations_take_the_scalar_way_with_the_array_ways_bits(rng):
    """``matrix_to_rpy`` of a few rotations runs the scalar copy of the array code (a single FK answer's
    rpy, ~7x faster): every bit must be the array code's on the same rotations, at and near the gimbal
    lock, on signed zeros, for (3, 3), (1, 1, 3, 3) and (k, 3, 3) shapes."""
    from kinematics.spatial.rotations import SCALAR_RPY_MAX, _rpy_batch

    angles = [rng.uniform(-4.0, 4.0, 3) for _ in range(3000)]
    specials = (0.0, -0.0, np.pi / 2, -np.pi / 2, np.pi, 1e-300, np.pi / 2 - 1e-9, np.pi / 2 - 1e-12)
    angles += [np.array([a, b, c]) for a in specials for b in specials for c in specials[:5]]
    rotations = [rpy_to_matrix(a) for a in angles]
    rotations += [np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]),
                  np.array([[1.0, 0.0, -0.0], [-0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])]
    for R in rotations:
        want = _rpy_batch(R[None])[0]
        for shaped in (R, R[None, None]):
            got = matrix_to_rpy(shaped).reshape(3)
            assert got.tobytes() == want.tobytes(), (R, got, want)
    stack = np.array(rotations)
    for k in range(2, SCALAR_RPY_MAX + 1):  # a few links of one configuration: each is one scalar computation
        for a in range(0, 600, k):
            assert matrix_to_rpy(stack[a:a + k]).tobytes() == _rpy_batch(stack[a:a + k]).tobytes()
    assert matrix_to_rpy(np.empty((0, 3, 3))).shape == (0, 3)
