"""PoE forward kinematics and Jacobians: textbook closed forms, finite differences, properties."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from kinematics import as_batch, compile_model, load_urdf
from kinematics.algorithms.measures import conditioning
from kinematics.spatial.transforms import pose_components
from kinematics.verify.pinocchio import compare_fk, compare_jacobian
from kinematics.spatial.rotations import skew

from tests.paths import FIXTURES

TOL = 1e-12
FD_STEP = 1e-6
FD_TOL = 1e-7


def model(name):
    return load_urdf(FIXTURES / f"{name}.urdf")


def se3(S):
    """4x4 matrix [S] of a screw (w, v) (angular first), independent of the library's code."""
    out = np.zeros((4, 4))
    out[:3, :3] = skew(S[:3])
    out[:3, 3] = S[3:]
    return out


# ---------------------------------------------------------------- closed forms (textbook examples)
def test_planar_2r_closed_form(rng):
    """De Luca's 2R planar arm: p_x = l1 c1 + l2 c12, p_y = l1 s1 + l2 s12, heading q1 + q2."""
    m = model("planar_2r")
    l1, l2 = 0.7, 0.5
    Q = rng.uniform(-np.pi, np.pi, size=(50, 2))
    T = compile_model(m).fk(Q, ["tool"])[:, 0]
    q1, q12 = Q[:, 0], Q[:, 0] + Q[:, 1]
    np.testing.assert_allclose(T[:, 0, 3], l1 * np.cos(q1) + l2 * np.cos(q12), atol=TOL)
    np.testing.assert_allclose(T[:, 1, 3], l1 * np.sin(q1) + l2 * np.sin(q12), atol=TOL)
    np.testing.assert_allclose(T[:, 2, 3], 0.0, atol=TOL)
    np.testing.assert_allclose(T[:, 0, 0], np.cos(q12), atol=TOL)
    np.testing.assert_allclose(T[:, 1, 0], np.sin(q12), atol=TOL)


def test_planar_3r_screws_home_and_closed_form(rng):
    """Lynch & Park, Modern Robotics, Example 4.1: M = [I, (L1+L2+L3, 0, 0)], v2 = (0, -L1, 0), v3 = (0, -(L1+L2), 0)."""
    m = model("planar_3r")
    L1, L2, L3 = 1.0, 0.8, 0.5
    poe = compile_model(m)
    S_expected = np.array([[0, 0, 1, 0, 0, 0], [0, 0, 1, 0, -L1, 0], [0, 0, 1, 0, -(L1 + L2), 0]], float)
    np.testing.assert_allclose(poe.S, S_expected, atol=TOL)
    M = np.eye(4)
    M[0, 3] = L1 + L2 + L3
    np.testing.assert_allclose(poe.M[m.links.index("tool")], M, atol=TOL)
    Q = rng.uniform(-np.pi, np.pi, size=(40, 3))
    T = poe.fk(Q, ["tool"])[:, 0]
    c = np.cumsum(Q, axis=1)
    x = L1 * np.cos(c[:, 0]) + L2 * np.cos(c[:, 1]) + L3 * np.cos(c[:, 2])
    y = L1 * np.sin(c[:, 0]) + L2 * np.sin(c[:, 1]) + L3 * np.sin(c[:, 2])
    np.testing.assert_allclose(T[:, 0, 3], x, atol=TOL)
    np.testing.assert_allclose(T[:, 1, 3], y, atol=TOL)
    np.testing.assert_allclose(np.arctan2(T[:, 1, 0], T[:, 0, 0]), np.angle(np.exp(1j * c[:, 2])), atol=1e-10)


def test_spatial_3r_screws_home_and_matrix_exponential(rng):
    """Lynch & Park, Modern Robotics, Example 4.2: screws and M as written there;
    FK = expm([S1]q1) expm([S2]q2) expm([S3]q3) M."""
    m = model("spatial_3r")
    L1, L2 = 0.6, 0.4
    poe = compile_model(m)
    S_expected = np.array([[0, 0, 1, 0, 0, 0], [0, -1, 0, 0, 0, -L1], [1, 0, 0, 0, -L2, 0]], float)
    np.testing.assert_allclose(poe.S, S_expected, atol=TOL)
    M = np.array([[0, 0, 1, L1], [0, 1, 0, 0], [-1, 0, 0, -L2], [0, 0, 0, 1]], float)
    np.testing.assert_allclose(poe.M[m.links.index("tool")], M, atol=1e-12)
    Q = rng.uniform(-np.pi, np.pi, size=(10, 3))
    T = poe.fk(Q, ["tool"])[:, 0]
    for n, q in enumerate(Q):
        expected = expm(se3(S_expected[0]) * q[0]) @ expm(se3(S_expected[1]) * q[1]) @ expm(se3(S_expected[2]) * q[2]) @ M
        np.testing.assert_allclose(T[n], expected, atol=1e-12)


# ---------------------------------------------------------------- Jacobians vs finite differences
def fd_jacobians(poe, q, link):
    """Central finite differences of our own FK -> the three Jacobians (linear rows first)."""
    T0 = poe.fk(q[None], [link])[0, 0]
    R0, p0 = T0[:3, :3], T0[:3, 3]
    out = {r: np.zeros((6, len(q))) for r in ("world", "local", "local_world_aligned")}
    for i in range(len(q)):
        dq = np.zeros_like(q)
        dq[i] = FD_STEP
        Tp = poe.fk((q + dq)[None], [link])[0, 0]
        Tm = poe.fk((q - dq)[None], [link])[0, 0]
        dT = (Tp - Tm) / (2 * FD_STEP)
        W = dT[:3, :3] @ R0.T  # [w] in world axes
        w = np.array([W[2, 1], W[0, 2], W[1, 0]])
        dp = dT[:3, 3]
        out["world"][:, i] = np.concatenate([dp - np.cross(w, p0), w])
        out["local_world_aligned"][:, i] = np.concatenate([dp, w])
        out["local"][:, i] = np.concatenate([R0.T @ dp, R0.T @ w])
    return out


@pytest.mark.parametrize("name,link", [("spatial_3r", "tool"), ("tree_mimic", "left_tip"), ("tree_mimic", "right_finger"), ("tree_mimic", "head")])
def test_jacobians_match_finite_differences(name, link, rng):
    m = model(name)
    poe = compile_model(m)
    for q in m.sample_configurations(4, rng):
        fd = fd_jacobians(poe, q, link)
        for reference, J_fd in fd.items():
            J = poe.jacobian(q[None], link, reference)[0]
            np.testing.assert_allclose(J, J_fd, atol=FD_TOL, err_msg=f"{name} {link} {reference}")


def test_jacobian_of_catalogue_arm_matches_finite_differences(catalogue, rng):
    m = catalogue.get("ur5")
    poe = compile_model(m)
    q = m.sample_configurations(1, rng)[0]
    fd = fd_jacobians(poe, q, "tool0")
    for reference, J_fd in fd.items():
        np.testing.assert_allclose(poe.jacobian(q[None], "tool0", reference)[0], J_fd, atol=FD_TOL)


def test_mimic_column_folded_into_leader(rng):
    """The mimic joint has no column; its effect appears in its leader's column (other branch)."""
    m = model("tree_mimic")
    assert "right_finger_joint" not in m.joint_names
    poe = compile_model(m)
    q = m.sample_configurations(1, rng)
    J = poe.jacobian(q, "right_finger", "world")[0]
    assert np.linalg.norm(J[:, m.q_index["left_elbow"]]) > 0.1  # the leader moves the finger
    assert np.allclose(J[:, m.q_index["left_shoulder"]], 0.0)  # left branch only


def test_jacobian_zero_columns_off_path(rng):
    m = model("tree_mimic")
    J = compile_model(m).jacobian(m.sample_configurations(1, rng), "left_tip", "local")[0]
    for name in ("right_shoulder", "right_slide_joint"):
        assert np.all(J[:, m.q_index[name]] == 0.0)


def test_fixture_tree_agrees_with_pinocchio(rng):
    m = model("tree_mimic")
    Q = m.sample_configurations(5, rng)
    dev = compare_fk(m, Q)
    assert dev.max_position_error < 1e-9 and dev.max_rotation_error < 1e-9
    for leaf in m.leaf_links:
        assert compare_jacobian(m, Q, leaf) < 1e-9


# ---------------------------------------------------------------- properties
@pytest.mark.parametrize("name", ["planar_2r", "spatial_3r", "tree_mimic"])
def test_rotations_orthonormal_and_home_pose(name, rng):
    m = model(name)
    poe = compile_model(m)
    T = poe.fk(m.sample_configurations(20, rng))
    R = T[..., :3, :3]
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    np.testing.assert_allclose(T[..., 3, :], np.broadcast_to([0, 0, 0, 1.0], T[..., 3, :].shape), atol=0)
    # q = 0 gives M, except where a mimic offset moves a joint at q = 0
    T0 = poe.fk(np.zeros((1, m.dof)))[0]
    moved_by_offset = {
        l for l in m.links if any(j.mimic is not None and j.mimic.offset != 0 for j in m.path_joints(l))
    }
    for k, l in enumerate(m.links):
        if l not in moved_by_offset:
            np.testing.assert_allclose(T0[k], poe.M[k], atol=1e-15)


def test_batch_equals_single(rng):
    m = model("tree_mimic")
    poe = compile_model(m)
    Q = m.sample_configurations(7, rng)
    batch = poe.fk(Q)
    J = poe.jacobian(Q, "right_finger", "local")
    for n, q in enumerate(Q):
        np.testing.assert_array_equal(poe.fk(q[None])[0], batch[n])
        np.testing.assert_allclose(poe.jacobian(q[None], "right_finger", "local")[0], J[n], atol=1e-15)


def test_continuous_joint_is_periodic(rng):
    m = model("tree_mimic")
    poe = compile_model(m)
    q = m.sample_configurations(1, rng)[0]
    q2 = q.copy()
    q2[m.q_index["right_shoulder"]] += 2 * np.pi
    np.testing.assert_allclose(poe.fk(q[None]), poe.fk(q2[None]), atol=1e-12)


def test_dof_zero_model():
    from kinematics import parse_urdf

    m = parse_urdf('<robot name="r"><link name="a"/><link name="b"/><joint name="f" type="fixed"><parent link="a"/><child link="b"/><origin xyz="1 2 3"/></joint></robot>')
    poe = compile_model(m)
    assert m.dof == 0
    T = poe.fk(np.zeros((3, 0)))
    assert T.shape == (3, 2, 4, 4)
    np.testing.assert_allclose(T[:, 1, :3, 3], [[1, 2, 3]] * 3)
    assert poe.jacobian(np.zeros((2, 0)), "b").shape == (2, 6, 0)


# ---------------------------------------------------------------- pose output and measures
def test_pose_components_round_trip(rng):
    from scipy.spatial.transform import Rotation

    m = model("tree_mimic")
    T = compile_model(m).fk(m.sample_configurations(30, rng))
    pc = pose_components(T)
    R = T[..., :3, :3].reshape(-1, 3, 3)
    quat = pc["quaternion"].reshape(-1, 4)
    assert np.all(quat[:, 0] >= 0)
    np.testing.assert_allclose(np.linalg.norm(quat, axis=1), 1.0, atol=1e-12)
    R_q = Rotation.from_quat(quat[:, [1, 2, 3, 0]]).as_matrix()  # scipy is x,y,z,w
    np.testing.assert_allclose(R_q, R, atol=1e-12)
    rpy = pc["rpy"].reshape(-1, 3)
    R_rpy = Rotation.from_euler("ZYX", rpy[:, ::-1]).as_matrix()  # R = Rz(y) Ry(p) Rx(r)
    np.testing.assert_allclose(R_rpy, R, atol=1e-12)


def test_quaternions_every_branch_and_half_turns(rng):
    """matrix_to_quaternion (compiled Shepperd) takes each of its four branches (trace, then the
    largest diagonal entry) and the half turns about x, y, z and a diagonal; scipy agrees."""
    from scipy.spatial.transform import Rotation

    from kinematics.spatial.rotations import matrix_to_quaternion

    half_turns = Rotation.from_rotvec(np.pi * np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0] / np.sqrt(2)]))
    rots = Rotation.concatenate([Rotation.identity(), half_turns, Rotation.random(200, random_state=3)])
    R = rots.as_matrix()
    q = matrix_to_quaternion(R)
    assert q.shape == (len(R), 4) and np.all(q[:, 0] >= 0)
    np.testing.assert_allclose(Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix(), R, atol=1e-14)
    branches = np.argmax(np.stack([np.trace(R, axis1=1, axis2=2), R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]], axis=1), axis=1)
    assert set(branches.tolist()) == {0, 1, 2, 3}
    np.testing.assert_array_equal(matrix_to_quaternion(R.reshape(5, 41, 3, 3)).reshape(-1, 4), q)  # any batch shape


def test_conditioning_measures():
    J = np.zeros((6, 6))
    J[np.arange(6), np.arange(6)] = [3, 2, 1, 1, 0.5, 0.25]
    c = conditioning(J)
    np.testing.assert_allclose(c["singular_values"], [3, 2, 1, 1, 0.5, 0.25])
    assert c["manipulability"] == pytest.approx(0.75)  # 3*2*1*1*0.5*0.25
    assert c["condition_number"] == pytest.approx(12.0)
    J[5, 5] = 0.0
    assert conditioning(J)["condition_number"] == np.inf
    assert conditioning(J)["manipulability"] == 0.0


def test_as_batch_forms_and_errors():
    from kinematics import JointValueError

    m = model("tree_mimic")
    names = m.joint_names
    Q, batch = as_batch(m, [0.1] * m.dof)
    assert Q.shape == (1, m.dof) and not batch
    Q2, batch2 = as_batch(m, {n: 0.1 * (i + 1) for i, n in enumerate(reversed(names))})
    assert Q2[0, 0] == pytest.approx(0.1 * m.dof) and not batch2
    Q3, batch3 = as_batch(m, [[0.0] * m.dof] * 3)
    assert Q3.shape == (3, m.dof) and batch3
    with pytest.raises(JointValueError, match=f"expected {m.dof} joint values"):
        as_batch(m, [0.0] * (m.dof + 1))
    with pytest.raises(JointValueError, match="not finite"):
        as_batch(m, [float("nan")] + [0.0] * (m.dof - 1))
    with pytest.raises(JointValueError, match="unknown joint name.*nope"):
        as_batch(m, {**{n: 0.0 for n in names}, "nope": 1.0})
    with pytest.raises(JointValueError, match="mimic"):
        as_batch(m, {**{n: 0.0 for n in names}, "right_finger_joint": 1.0})
    with pytest.raises(JointValueError, match="missing value.*torso_joint"):
        as_batch(m, {n: 0.0 for n in names if n != "torso_joint"})
    with pytest.raises(JointValueError, match="configuration 1"):
        as_batch(m, [[0.0] * m.dof, [0.0] * (m.dof - 1)])
    with pytest.raises(JointValueError, match="not a number"):
        as_batch(m, ["a"] * m.dof)
