"""The q layout of floating and planar joints (Pinocchio's): nq, nv, slots, neutral, and the
validation of q (unit quaternions and (cos, sin), or normalize) and of velocities."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.errors import ConfigurationNormError, JointValueError
from kinematics.io.urdf import load_urdf
from kinematics.model.joint_values import as_batch, as_velocity_batch, out_of_limits

from tests.paths import FIXTURES


@pytest.fixture
def tree():
    return load_urdf(FIXTURES / "floating_planar_tree.urdf")


def test_layout_nq_nv_and_neutral(tree):
    assert tree.joint_names == ("shoulder", "float", "plane", "wrist_roll", "finger_slide", "side_joint")
    assert (tree.nq, tree.nv, tree.dof) == (15, 13, 13)
    slots = {s.name: (s.q_start, s.nq, s.v_start, s.nv) for s in tree.layout}
    assert slots["float"] == (1, 7, 1, 6) and slots["plane"] == (8, 4, 7, 3) and slots["wrist_roll"] == (12, 1, 10, 1)
    assert tree.neutral[1:8].tolist() == [0, 0, 0, 0, 0, 0, 1] and tree.neutral[8:12].tolist() == [0, 0, 1, 0]
    assert tree.q_labels[1:8] == ("float.x", "float.y", "float.z", "float.qx", "float.qy", "float.qz", "float.qw")
    assert tree.v_labels[7:10] == ("plane.vx", "plane.vy", "plane.wz")
    assert tree.lower_limits.shape == (15,) and np.isinf(tree.lower_limits[1:12]).all()


def test_one_dof_models_keep_dof_as_the_length_of_q(catalogue):
    ur5 = catalogue.get("ur5")
    assert ur5.nq == ur5.nv == ur5.dof == len(ur5.joint_names) and not ur5.multi_dof
    assert ur5.q_index == {n: i for i, n in enumerate(ur5.joint_names)}


def test_sampled_configurations_have_unit_parts(tree, rng):
    Q = tree.sample_configurations(50, rng)
    assert Q.shape == (50, 15)
    np.testing.assert_allclose(np.linalg.norm(Q[:, 4:8], axis=1), 1.0)
    np.testing.assert_allclose(np.hypot(Q[:, 10], Q[:, 11]), 1.0)


def _map(tree, **overrides):
    values = {"shoulder": 0.1, "float": [0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 1.0], "plane": [0.5, 0.2, 1.0, 0.0],
              "wrist_roll": 3.0, "finger_slide": 0.05, "side_joint": -0.2}
    values.update(overrides)
    return values


def test_name_maps_take_lists_for_multi_dof_joints(tree):
    Q, batch = as_batch(tree, _map(tree))
    assert not batch and Q.shape == (1, 15) and Q[0, 1:8].tolist() == [0.1, 0.2, 0.3, 0, 0, 0, 1]
    with pytest.raises(JointValueError, match="joint 'plane' is a planar joint: give 4 numbers"):
        as_batch(tree, _map(tree, plane=[0.5, 0.2, 0.3]))
    with pytest.raises(JointValueError, match="joint 'float' is a floating joint: give 7 numbers"):
        as_batch(tree, _map(tree, float=0.5))


def test_vectors_have_nq_entries_named_in_errors(tree):
    with pytest.raises(JointValueError, match="expected 15 joint values"):
        as_batch(tree, [0.0] * 13)
    q = list(tree.neutral)
    q[9] = float("nan")
    with pytest.raises(JointValueError, match="joint 'plane.y'"):
        as_batch(tree, q)


@pytest.mark.parametrize("joint,value,what", [
    ("float", [0, 0, 0, 0.0, 0.0, 0.0, 2.0], "quaternion"),
    ("float", [0, 0, 0, 0.0, 0.0, 0.0, 0.0], "quaternion"),
    ("plane", [0, 0, 0.5, 0.5], "(cos(theta), sin(theta))"),
])
def test_non_unit_parts_are_refused_naming_the_joint(tree, joint, value, what):
    with pytest.raises(ConfigurationNormError) as exc:
        as_batch(tree, _map(tree, **{joint: value}))
    assert f"joint {joint!r}" in str(exc.value) and what in str(exc.value) and exc.value.joint == joint
    if max(np.abs(value[-4:] if joint == "float" else value[-2:])) > 0:
        Q, _ = as_batch(tree, _map(tree, **{joint: value}), normalize=True)
        s = tree.slot[joint]
        part = Q[0, s.q_start + 3:s.q_start + 7] if joint == "float" else Q[0, s.q_start + 2:s.q_start + 4]
        assert np.linalg.norm(part) == pytest.approx(1.0, abs=1e-15)
    else:  # a zero quaternion cannot be normalized
        with pytest.raises(ConfigurationNormError, match="cannot be scaled"):
            as_batch(tree, _map(tree, **{joint: value}), normalize=True)


def test_almost_unit_parts_are_accepted_and_made_unit(tree):
    q = np.array(tree.neutral)
    q[7] = 1.0 + 5e-7
    Q, _ = as_batch(tree, q)
    assert np.linalg.norm(Q[0, 4:8]) == 1.0 and q[7] == 1.0 + 5e-7  # the caller's array is not changed


def test_batches_name_the_configuration(tree):
    good = list(tree.neutral)
    bad = list(tree.neutral)
    bad[11] = 0.3
    with pytest.raises(ConfigurationNormError, match="configuration 1, joint 'plane'"):
        as_batch(tree, [good, bad])


def test_limits_apply_to_one_dof_entries_only(tree):
    q = np.array(tree.neutral)
    q[0] = 3.0  # shoulder beyond +-2
    q[1:4] = 1e3  # floating positions have no limits
    assert out_of_limits(tree, q[None]) == [["shoulder"]]


def test_velocities_have_nv_entries(tree):
    Qd, batch = as_velocity_batch(tree, [0.1] * 13)
    assert Qd.shape == (1, 13) and not batch
    m = {"shoulder": 1, "float": [1, 2, 3, 4, 5, 6], "plane": [1, 2, 3], "wrist_roll": 0, "finger_slide": 0,
         "side_joint": 0}
    Qd, _ = as_velocity_batch(tree, [m, m])
    assert Qd.shape == (2, 13) and Qd[0, 1:7].tolist() == [1, 2, 3, 4, 5, 6] and Qd[0, 7:10].tolist() == [1, 2, 3]
    with pytest.raises(JointValueError, match="expected 13 joint velocities"):
        as_velocity_batch(tree, [0.1] * 15)
    with pytest.raises(JointValueError, match="give 6 velocities"):
        as_velocity_batch(tree, {**m, "float": [1, 2, 3, 4, 5, 6, 7]})
