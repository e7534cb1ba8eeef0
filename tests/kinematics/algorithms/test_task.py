"""Task vectors r = (p, phi) and analytic Jacobians J_r = E(phi)^-1 J (kinematics.algorithms.task):
central finite differences of r(q) in every representation, De Luca's planar and SCARA
vectors, the singularities refused, and the layouts validated."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import api
from kinematics.algorithms.task import (REPRESENTATIONS, analytic_jacobian, task, task_representation,
                                        task_vector)
from kinematics.errors import RepresentationSingularityError, TaskError
from kinematics.io import default_catalogue
from kinematics.spatial.rotations import quaternion_to_matrix, rpy_to_matrix

H = 1e-6


def finite_differences(model, link, Q, rep):
    """Central differences of r(q) (N, m, dof), angles unwrapped."""
    n = model.dof
    out = np.empty((len(Q), rep.size, n))
    wrap = np.array(rep.angles)
    for k in range(n):
        E = np.zeros(n)
        E[k] = H
        rp, _ = task(model, Q + E, link, rep)
        rm, _ = task(model, Q - E, link, rep)
        d = rp - rm
        d[:, wrap] = (d[:, wrap] + np.pi) % (2 * np.pi) - np.pi
        out[:, :, k] = d / (2 * H)
    return out


@pytest.mark.parametrize("representation", REPRESENTATIONS)
@pytest.mark.parametrize("model_id, link", [("ur5", "tool0"), ("panda", "panda_hand_tcp")])
def test_analytic_jacobian_equals_finite_differences(model_id, link, representation, rng):
    model = default_catalogue().get(model_id)
    rep = task_representation(representation)
    Q = model.sample_configurations(12, rng)
    r, Jr = task(model, Q, link, rep)
    assert r.shape == (12, rep.size) and Jr.shape == (12, rep.size, model.dof)
    np.testing.assert_allclose(Jr, finite_differences(model, link, Q, rep), atol=2e-8)


def test_r_is_the_pose_in_each_representation(rng):
    model = default_catalogue().get("ur5")
    Q = model.sample_configurations(5, rng)
    T = api.fk(model, Q, links=["tool0"]).poses[:, 0]
    rpy = task_vector(T, task_representation("rpy"))
    zyx = task_vector(T, task_representation("zyx"))
    np.testing.assert_allclose(zyx[:, 3:], rpy[:, [5, 4, 3]])
    quat = task_vector(T, task_representation("quaternion"))
    rotvec = task_vector(T, task_representation("rotvec"))
    zyz = task_vector(T, task_representation("zyz"))
    for k in range(5):
        R = T[k, :3, :3]
        np.testing.assert_allclose(rpy[k, :3], T[k, :3, 3])
        np.testing.assert_allclose(rpy_to_matrix(rpy[k, 3:]), R, atol=1e-14)
        np.testing.assert_allclose(quaternion_to_matrix(*quat[k, 3:]), R, atol=1e-14)
        theta = np.linalg.norm(rotvec[k, 3:])
        u = rotvec[k, 3:] / theta
        K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
        np.testing.assert_allclose(np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K, R, atol=1e-14)
        f, t, p = zyz[k, 3:]
        Rz = lambda a: np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
        Ry = np.array([[np.cos(t), 0, np.sin(t)], [0, 1, 0], [-np.sin(t), 0, np.cos(t)]])
        np.testing.assert_allclose(Rz(f) @ Ry @ Rz(p), R, atol=1e-14)


def test_planar_and_scara_vectors_are_the_textbook_ones(rng):
    """De Luca's arms: planar (px, py, phi = q1 + q2); SCARA (a1 c1 + a2 c12, a1 s1 + a2 s12, d1 + q3 + d4,
    q1 + q2 + q4)."""
    catalogue = default_catalogue()
    planar = catalogue.get("planar_2r")
    Q = planar.sample_configurations(10, rng) * 0.45  # |q1 + q2| < pi: no wrap
    r, Jr = task(planar, Q, "tool", task_representation("planar"))
    a1, a2 = 0.5, 0.4
    q1, q2 = Q.T
    np.testing.assert_allclose(r, np.stack([a1 * np.cos(q1) + a2 * np.cos(q1 + q2),
                                            a1 * np.sin(q1) + a2 * np.sin(q1 + q2), q1 + q2], axis=-1), atol=1e-14)
    np.testing.assert_allclose(Jr[:, 2], np.ones((10, 2)), atol=1e-14)
    scara = catalogue.get("scara")
    Q = scara.sample_configurations(10, rng) * 0.3
    r, Jr = task(scara, Q, "tool", task_representation("scara"))
    a1, a2, d1, d4 = 0.325, 0.275, 0.4, -0.1
    q1, q2, q3, q4 = Q.T
    expected = np.stack([a1 * np.cos(q1) + a2 * np.cos(q1 + q2), a1 * np.sin(q1) + a2 * np.sin(q1 + q2),
                         d1 + q3 + d4, q1 + q2 + q4], axis=-1)
    np.testing.assert_allclose(r, expected, atol=1e-14)
    np.testing.assert_allclose(Jr[:, 3], np.tile([1.0, 1.0, 0.0, 1.0], (10, 1)), atol=1e-14)
    np.testing.assert_allclose(Jr[:, 2], np.tile([0.0, 0.0, 1.0, 0.0], (10, 1)), atol=1e-14)


def test_subsets_and_the_use_case(rng):
    model = default_catalogue().get("ur5")
    Q = model.sample_configurations(4, rng)
    full = api.task(model, Q.tolist(), link="tool0", representation="zyz")
    part = api.task(model, Q.tolist(), link="tool0", representation="zyz", components=["theta", "px"])
    np.testing.assert_allclose(part.r, full.r[:, [4, 0]])
    np.testing.assert_allclose(part.J_r, full.J_r[:, [4, 0]])
    assert part.is_batch and part.representation.labels == ("theta", "px")
    base = {"xyz": [1.0, 2.0, 3.0], "rpy": [0.0, 0.0, 0.5]}
    moved = api.task(model, Q[0].tolist(), link="tool0", representation="position", base=base)
    p = api.fk(model, Q[0].tolist(), links=["tool0"], base=base).poses[0, 0, :3, 3]
    np.testing.assert_allclose(moved.r[0], p)
    np.testing.assert_allclose(moved.J_r[0], api.jacobian(model, Q[0].tolist(), link="tool0", base=base,
                                                          reference="local_world_aligned").jacobians[0, :3])


def _pose(R):
    T = np.eye(4)
    T[:3, :3] = R
    return T[None]


@pytest.mark.parametrize("representation, R, why", [
    ("rpy", rpy_to_matrix([0.3, np.pi / 2, 0.2]), "gimbal lock"),
    ("zyx", rpy_to_matrix([0.0, -np.pi / 2, 1.0]), "gimbal lock"),
    ("zyz", rpy_to_matrix([0.0, 0.0, 0.7]), "theta at 0"),
    ("rotvec", rpy_to_matrix([np.pi, 0.0, 0.0]), "half turn"),
    ("quaternion", rpy_to_matrix([0.0, np.pi, 0.0]), "qw = 0"),
    ("scara", rpy_to_matrix([0.0, np.pi / 2, 0.0]), "gimbal lock"),
])
def test_representation_singularities_are_refused(representation, R, why):
    rep = task_representation(representation)
    with pytest.raises(RepresentationSingularityError, match=why):
        analytic_jacobian(_pose(R), np.zeros((1, 6, 2)), rep)
    task_vector(_pose(R), rep)  # the vector itself is still defined there


def test_position_components_need_no_orientation():
    rep = task_representation("rpy", ["px", "pz"])
    J = np.arange(12.0).reshape(1, 6, 2)
    np.testing.assert_allclose(analytic_jacobian(_pose(rpy_to_matrix([0, np.pi / 2, 0])), J, rep)[0], J[0, [0, 2]])


@pytest.mark.parametrize("representation, components, message", [
    ("euler", None, "representation"),
    ("zyz", ["roll"], r"components\[0\]: 'roll' is not a component"),
    ("rpy", ["px", "px"], "twice"),
    ("rpy", [], "non-empty"),
    ("planar", ["alpha_z"], "not a component"),
])
def test_layouts_are_validated(representation, components, message):
    with pytest.raises(TaskError, match=message):
        task_representation(representation, components)
