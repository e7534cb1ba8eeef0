"""SE(3) helpers of kinematics.spatial.transforms: exponentials of screws against scipy's expm,
inverses, the rigidity check, and the pose components."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from kinematics.spatial.rotations import quaternion_to_matrix, rpy_to_matrix, skew
from kinematics.spatial.transforms import (
    exp_screws,
    inverse_transform,
    is_rigid_transform,
    make_transform,
    pose_components,
)

TOL = 1e-12


def random_rigid(rng, n: int) -> np.ndarray:
    T = np.zeros((n, 4, 4))
    T[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    T[:, :3, 3] = rng.uniform(-2.0, 2.0, size=(n, 3))
    T[:, 3, 3] = 1.0
    return T


def screw_exp_by_expm(w, r, revolute: bool, theta: float) -> np.ndarray:
    """exp of the se(3) matrix of a screw, written out independently of the library."""
    se3 = np.zeros((4, 4))
    if revolute:
        se3[:3, :3] = skew(w)
        se3[:3, 3] = -np.cross(w, r)
    else:
        se3[:3, 3] = w
    return expm(se3 * theta)


def random_screws(rng, n: int):
    w = rng.normal(size=(n, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    r = rng.uniform(-1.0, 1.0, size=(n, 3))
    revolute = np.array([k % 2 == 0 for k in range(n)])
    return w, r, revolute


# ---------------------------------------------------------------------- exp_screws
def test_exp_screws_matches_expm(rng):
    n, N = 6, 8
    w, r, revolute = random_screws(rng, n)
    theta = rng.uniform(-4.0, 4.0, size=(N, n))
    E = exp_screws(w, r, revolute, theta)
    assert E.shape == (N, n, 4, 4)
    for i in range(N):
        for j in range(n):
            np.testing.assert_allclose(E[i, j], screw_exp_by_expm(w[j], r[j], revolute[j], theta[i, j]), atol=TOL)


def test_exp_screws_of_a_revolute_screw_fixes_its_axis_points(rng):
    """Every point r + t w on a revolute axis stays where it is."""
    w, r, _ = random_screws(rng, 3)
    E = exp_screws(w, r, np.ones(3, dtype=bool), rng.uniform(-3, 3, size=3))
    for j in range(3):
        point = np.append(r[j] + 0.7 * w[j], 1.0)
        np.testing.assert_allclose(E[j] @ point, point, atol=TOL)


def test_exp_screws_prismatic_is_a_pure_translation(rng):
    w, r, _ = random_screws(rng, 3)
    theta = np.array([0.3, -1.2, 2.0])
    E = exp_screws(w, r, np.zeros(3, dtype=bool), theta)
    np.testing.assert_array_equal(E[:, :3, :3], np.broadcast_to(np.eye(3), (3, 3, 3)))
    np.testing.assert_allclose(E[:, :3, 3], theta[:, None] * w, atol=TOL)


def test_exp_screws_shapes_and_zero_angle(rng):
    n = 4
    w, r, revolute = random_screws(rng, n)
    one = exp_screws(w, r, revolute, np.zeros(n))
    assert one.shape == (n, 4, 4)
    np.testing.assert_allclose(one, np.broadcast_to(np.eye(4), (n, 4, 4)), atol=0)
    theta = rng.uniform(-2.0, 2.0, size=(2, 3, n))
    E = exp_screws(w, r, revolute, theta)
    assert E.shape == (2, 3, n, 4, 4)
    np.testing.assert_allclose(E[1, 2], exp_screws(w, r, revolute, theta[1, 2]), atol=0)
    np.testing.assert_array_equal(E[..., 3, :], np.broadcast_to([0.0, 0.0, 0.0, 1.0], (2, 3, n, 4)))


def test_exp_screws_quarter_turn_example():
    T = exp_screws(np.array([[0.0, 0, 1]]), np.array([[1.0, 0, 0]]), np.array([True]), np.array([np.pi / 2]))
    np.testing.assert_allclose(T[0, :3, 3], [1.0, -1.0, 0.0], atol=TOL)
    np.testing.assert_allclose(T[0, :3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=TOL)


# ---------------------------------------------------------------------- inverse_transform
def test_inverse_transform_of_rigid_transforms(rng):
    T = random_rigid(rng, 20)
    for Ti in T:
        inv = inverse_transform(Ti)
        np.testing.assert_allclose(inv @ Ti, np.eye(4), atol=TOL)
        np.testing.assert_allclose(Ti @ inv, np.eye(4), atol=TOL)
        np.testing.assert_allclose(inv, np.linalg.inv(Ti), atol=TOL)


def test_inverse_transform_batched(rng):
    T = random_rigid(rng, 24).reshape(2, 3, 4, 4, 4)
    inv = inverse_transform(T)
    assert inv.shape == T.shape
    np.testing.assert_allclose(inv @ T, np.broadcast_to(np.eye(4), T.shape), atol=TOL)
    np.testing.assert_array_equal(inv[1, 2, 3], inverse_transform(T[1, 2, 3]))


# ---------------------------------------------------------------------- is_rigid_transform
def test_is_rigid_transform_accepts_rigid(rng):
    for T in random_rigid(rng, 10):
        assert is_rigid_transform(T)
    assert is_rigid_transform(np.eye(4).tolist())  # nested lists are read too


def test_is_rigid_transform_tolerance(rng):
    T = random_rigid(rng, 1)[0]
    small = T.copy()
    small[:3, :3] += 1e-9
    assert is_rigid_transform(small)
    large = T.copy()
    large[:3, :3] += 1e-3
    assert not is_rigid_transform(large)


@pytest.mark.parametrize("case", ["reflection", "scaled", "bad_last_row", "homogeneous_scale", "nan", "inf",
                                  "shape_3x4", "shape_3x3", "shape_batch"])
def test_is_rigid_transform_refuses(rng, case):
    T = random_rigid(rng, 1)[0]
    if case == "reflection":  # orthonormal, det -1
        T[:3, :3] = T[:3, :3] @ np.diag([1.0, 1.0, -1.0])
        assert np.allclose(T[:3, :3].T @ T[:3, :3], np.eye(3))
    elif case == "scaled":
        T[:3, :3] *= 1.01
    elif case == "bad_last_row":
        T[3, :3] = [0.0, 0.1, 0.0]
    elif case == "homogeneous_scale":
        T[3, 3] = 2.0
    elif case == "nan":
        T[0, 3] = np.nan
    elif case == "inf":
        T[1, 3] = np.inf
    elif case == "shape_3x4":
        T = T[:3]
    elif case == "shape_3x3":
        T = T[:3, :3]
    elif case == "shape_batch":
        T = T[None]
    assert not is_rigid_transform(T)


# ---------------------------------------------------------------------- make_transform
def test_make_transform(rng):
    R = Rotation.random(random_state=rng).as_matrix()
    p = rng.normal(size=3)
    T = make_transform(R, p)
    assert T.shape == (4, 4)
    np.testing.assert_array_equal(T[:3, :3], R)
    np.testing.assert_array_equal(T[:3, 3], p)
    np.testing.assert_array_equal(T[3], [0.0, 0.0, 0.0, 1.0])
    x = rng.normal(size=3)
    np.testing.assert_allclose((T @ np.append(x, 1.0))[:3], R @ x + p, atol=TOL)
    assert is_rigid_transform(T)


# ---------------------------------------------------------------------- pose_components
def test_pose_components_on_a_batch(rng):
    T = random_rigid(rng, 6).reshape(2, 3, 4, 4)
    c = pose_components(T)
    assert set(c) == {"position", "quaternion", "rpy"}
    assert c["position"].shape == (2, 3, 3)
    assert c["quaternion"].shape == (2, 3, 4)
    assert c["rpy"].shape == (2, 3, 3)
    np.testing.assert_array_equal(c["position"], T[..., :3, 3])
    assert np.all(c["quaternion"][..., 0] >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(c["quaternion"], axis=-1), 1.0, atol=1e-15)
    for n in range(2):
        for k in range(3):
            R = T[n, k, :3, :3]
            np.testing.assert_allclose(quaternion_to_matrix(*c["quaternion"][n, k]), R, atol=TOL)
            np.testing.assert_allclose(rpy_to_matrix(c["rpy"][n, k]), R, atol=TOL)
            assert -np.pi / 2 <= c["rpy"][n, k, 1] <= np.pi / 2
            x, y, z, w = Rotation.from_matrix(R).as_quat()
            expected = np.array([w, x, y, z]) * (1.0 if w >= 0 else -1.0)
            np.testing.assert_allclose(c["quaternion"][n, k], expected, atol=TOL)


def test_pose_components_known_pose():
    c = pose_components(make_transform(rpy_to_matrix([0.0, 0.0, np.pi / 2]), [1.0, 2.0, 3.0]))
    np.testing.assert_array_equal(c["position"], [1.0, 2.0, 3.0])
    np.testing.assert_allclose(c["quaternion"], [np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)], atol=TOL)
    np.testing.assert_allclose(c["rpy"], [0.0, 0.0, np.pi / 2], atol=TOL)
