"""The Pinocchio bridge (kinematics.verify.pinocchio): the cached reference per model, the map
of our q to Pinocchio's, mimic joints, and that the comparisons detect deviations."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from kinematics import ReferenceUnavailableError, compile_model, load_urdf, parse_urdf
from kinematics.spatial.reference import REFERENCES
from kinematics.verify import pinocchio as bridge
from kinematics.verify.pinocchio import (
    REFERENCE_NAME,
    Deviation,
    PinocchioReference,
    compare_fk,
    compare_jacobian,
    reference_for,
)

from tests.paths import FIXTURES

AGREEMENT = 1e-9

#: one joint of each moving type (continuous first, so that indices shift after its two entries)
THREE_JOINTS_URDF = """<robot name="three_joints">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/>
  <joint name="spin" type="continuous"><parent link="base"/><child link="a"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/></joint>
  <joint name="bend" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0.2 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="slide" type="prismatic"><parent link="b"/><child link="c"/>
    <origin xyz="0 0 0.3"/><axis xyz="1 0 0"/><limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
</robot>"""


def tree_mimic():
    return load_urdf(FIXTURES / "tree_mimic.urdf")


# ---------------------------------------------------------------------- the cache
def test_reference_for_is_cached_per_model_object():
    m = tree_mimic()
    ref = reference_for(m)
    assert isinstance(ref, PinocchioReference)
    assert reference_for(m) is ref
    assert ref.model is m


def test_distinct_models_get_distinct_references():
    m1, m2 = tree_mimic(), tree_mimic()
    assert m1 is not m2
    r1, r2 = reference_for(m1), reference_for(m2)
    assert r1 is not r2
    assert r1.model is m1 and r2.model is m2


# ---------------------------------------------------------------------- q -> Pinocchio's q
def test_to_pinocchio_q_continuous_revolute_prismatic():
    m = parse_urdf(THREE_JOINTS_URDF)
    assert m.joint_names == ("spin", "bend", "slide")
    ref = reference_for(m)
    pm = ref.pin_model
    assert pm.nq == 4 and pm.nv == 3  # continuous: (cos, sin) in q, one velocity
    q = np.array([2.5, -0.7, 0.25])
    x = ref.to_pinocchio_q(q)
    assert x.shape == (4,)
    idx = {name: pm.joints[pm.getJointId(name)].idx_q for name in m.joint_names}
    assert x[idx["spin"]] == np.cos(2.5)
    assert x[idx["spin"] + 1] == np.sin(2.5)
    assert x[idx["bend"]] == -0.7
    assert x[idx["slide"]] == 0.25
    # and Pinocchio agrees with us on that configuration
    assert compare_fk(m, q[None]).worst < AGREEMENT
    assert compare_jacobian(m, q[None], "c") < AGREEMENT


def test_to_pinocchio_q_continuous_beyond_pi():
    """A continuous joint at q and at q + 2 pi is the same configuration for Pinocchio."""
    m = parse_urdf(THREE_JOINTS_URDF)
    ref = reference_for(m)
    a = ref.to_pinocchio_q(np.array([0.4, 0.1, 0.1]))
    b = ref.to_pinocchio_q(np.array([0.4 + 2 * np.pi, 0.1, 0.1]))
    np.testing.assert_allclose(a, b, atol=1e-14)
    c = ref.to_pinocchio_q(np.array([np.pi + 0.4, 0.1, 0.1]))
    spin = ref.pin_model.joints[ref.pin_model.getJointId("spin")].idx_q
    assert c[spin] == pytest.approx(-a[spin]) and c[spin + 1] == pytest.approx(-a[spin + 1])


# ---------------------------------------------------------------------- mimic joints
def _check_tree_mimic_agrees(m, rng):
    Q = m.sample_configurations(8, rng)
    dev = compare_fk(m, Q)
    assert dev.max_position_error < AGREEMENT
    assert dev.max_rotation_error < AGREEMENT
    for link in m.links:
        assert compare_jacobian(m, Q, link) < AGREEMENT, link


def test_mimic_tree_agrees_with_pinocchio(rng):
    m = tree_mimic()
    assert any(j.mimic is not None for j in m.joints)
    _check_tree_mimic_agrees(m, rng)


def test_mimic_tree_jacobian_is_not_trivially_zero(rng):
    """The mimic joint's column lands on its leader: the right finger moves with left_elbow."""
    m = tree_mimic()
    Q = m.sample_configurations(3, rng)
    J = np.array([reference_for(m).jacobian(q, "right_finger", "world") for q in Q])
    assert np.abs(J[:, :, m.q_index["left_elbow"]]).max() > 1e-3
    np.testing.assert_allclose(J, compile_model(m).jacobian(Q, "right_finger", "world"), atol=AGREEMENT)


def test_mimic_tree_without_native_mimic(rng, monkeypatch):
    """When Pinocchio refuses ``mimic=True`` the bridge builds the model without it, sets the
    mimic joint from its leader and folds its Jacobian column into the leader's."""
    real = bridge.pin.buildModelFromXML

    def refuse_mimic(xml, *args, mimic=False, **kwargs):
        if mimic:
            raise RuntimeError("The parent joint of the mimic joint is not in the kinematic tree")
        return real(xml, *args, mimic=False, **kwargs)

    monkeypatch.setattr(bridge.pin, "buildModelFromXML", refuse_mimic)
    m = tree_mimic()  # a fresh model object: not in the cache
    ref = reference_for(m)
    assert ref.mimic_native is False
    assert "right_finger_joint" in [name for *_, name in ref.q_map]
    # the mimic joint's entry is multiplier * leader + offset
    pm = ref.pin_model
    q = np.array([0.1, 0.2, 0.3, -0.8, 0.05])
    x = ref.to_pinocchio_q(q)
    finger = pm.joints[pm.getJointId("right_finger_joint")].idx_q
    assert x[finger] == pytest.approx(-0.7 * q[m.q_index["left_elbow"]] + 0.15)
    _check_tree_mimic_agrees(m, rng)


# ---------------------------------------------------------------------- detecting deviations
def test_compare_fk_detects_an_offset(rng):
    m = tree_mimic()
    Q = m.sample_configurations(4, rng)
    links = ["left_tip", "right_finger"]
    poses = compile_model(m).fk(Q, links)
    assert compare_fk(m, Q, links, poses=poses).worst < AGREEMENT
    shifted = poses.copy()
    shifted[2, 1, 1, 3] += 1e-6
    dev = compare_fk(m, Q, links, poses=shifted)
    assert dev.max_position_error == pytest.approx(1e-6, rel=1e-6)
    assert dev.max_rotation_error < AGREEMENT
    turned = poses.copy()
    turned[0, 0, 2, 1] -= 3e-6
    dev = compare_fk(m, Q, links, poses=turned)
    assert dev.max_rotation_error == pytest.approx(3e-6, rel=1e-6)
    assert dev.max_position_error < AGREEMENT


def test_compare_jacobian_detects_a_wrong_jacobian(rng):
    m = tree_mimic()
    Q = m.sample_configurations(3, rng)
    poe = compile_model(m)
    right = {r: poe.jacobian(Q, "right_finger", r) for r in REFERENCES}
    assert compare_jacobian(m, Q, "right_finger", jacobians=right) < AGREEMENT
    for reference in REFERENCES:
        wrong = dict(right)
        wrong[reference] = right[reference].copy()
        wrong[reference][1, 4, 0] += 2e-5
        err = compare_jacobian(m, Q, "right_finger", jacobians=wrong)
        assert err == pytest.approx(2e-5, rel=1e-6), reference
        # comparing only another reference does not see it
        other = next(r for r in REFERENCES if r != reference)
        assert compare_jacobian(m, Q, "right_finger", references=(other,), jacobians=wrong) < AGREEMENT


def test_compare_jacobian_detects_a_swapped_column(rng):
    """A Jacobian with the mimic leader's column moved elsewhere is caught."""
    m = tree_mimic()
    Q = m.sample_configurations(2, rng)
    J = compile_model(m).jacobian(Q, "right_finger", "local")
    k = m.q_index["left_elbow"]
    wrong = J.copy()
    wrong[:, :, [k, 0]] = J[:, :, [0, k]]
    assert compare_jacobian(m, Q, "right_finger", references=("local",), jacobians={"local": wrong}) > 1e-3


# ---------------------------------------------------------------------- unavailable reference
def test_reference_unavailable_when_pinocchio_cannot_read_the_urdf():
    m = dataclasses.replace(tree_mimic(), urdf="this is not a URDF")
    with pytest.raises(ReferenceUnavailableError, match="tree_mimic"):
        reference_for(m)
    with pytest.raises(ReferenceUnavailableError):
        compare_fk(m, np.zeros((1, m.dof)))


def test_reference_unavailable_when_pinocchio_lacks_our_links():
    m = dataclasses.replace(tree_mimic(), urdf=(FIXTURES / "planar_2r.urdf").read_text())
    with pytest.raises(ReferenceUnavailableError, match="BODY frame"):
        reference_for(m)


# ---------------------------------------------------------------------- Deviation
def test_deviation_worst():
    assert Deviation(1e-3, 2e-3).worst == 2e-3
    assert Deviation(4e-3, 2e-3).worst == 4e-3
    assert Deviation(1e-3, 2e-3, 5e-3).worst == 5e-3
    assert Deviation(1e-3, 2e-3, None).worst == 2e-3
    assert Deviation(0.0, 0.0).worst == 0.0
    assert Deviation(0.0, 0.0).reference == REFERENCE_NAME
    assert REFERENCE_NAME.startswith("pinocchio ")


# ---------------------------------------------------------------------- velocities and tool frames
def test_to_pinocchio_v_one_entry_per_continuous_joint():
    m = parse_urdf(THREE_JOINTS_URDF)
    ref = reference_for(m)
    assert ref.pin_model.nv == m.dof  # a continuous joint: two q entries, one velocity
    v = ref.to_pinocchio_v(np.array([0.3, -0.2, 0.7]))
    pm = ref.pin_model
    for name, value in zip(m.joint_names, (0.3, -0.2, 0.7)):
        assert v[pm.joints[pm.getJointId(name)].idx_v] == value


def test_velocities_of_the_mimic_tree_with_and_without_native_mimic(rng, monkeypatch):
    m = tree_mimic()
    Q = m.sample_configurations(4, rng)
    Qd = rng.uniform(-1, 1, Q.shape)
    assert bridge.compare_velocity(m, Q, Qd) < AGREEMENT
    real = bridge.pin.buildModelFromXML

    def refuse_mimic(xml, *args, mimic=False, **kwargs):
        if mimic:
            raise RuntimeError("refused")
        return real(xml, *args, mimic=False, **kwargs)

    monkeypatch.setattr(bridge.pin, "buildModelFromXML", refuse_mimic)
    fresh = tree_mimic()
    assert reference_for(fresh).mimic_native is False
    assert bridge.compare_velocity(fresh, Q, Qd) < AGREEMENT


def test_compare_velocity_detects_a_wrong_twist(rng):
    m = tree_mimic()
    Q = m.sample_configurations(3, rng)
    Qd = rng.uniform(-1, 1, Q.shape)
    twists = compile_model(m).velocity(Q, Qd)
    assert bridge.compare_velocity(m, Q, Qd, twists=twists) < AGREEMENT
    twists["local"][1, 2, 4] += 2e-6
    assert bridge.compare_velocity(m, Q, Qd, twists=twists) == pytest.approx(2e-6, rel=1e-6)


def test_tool_frames_are_added_to_a_copy_of_the_model(rng):
    m = tree_mimic()
    ref = reference_for(m)
    frames_before = ref.pin_model.nframes
    tool = np.eye(4)
    tool[:3, 3] = [0.1, 0.0, 0.05]
    frames = ref.frames(["left_tip"], tool)
    assert ref.pin_model.nframes == frames_before  # the cached model is untouched
    q = m.sample_configurations(1, rng)[0]
    np.testing.assert_allclose(frames.poses(q)["left_tip"], ref.poses(q)["left_tip"] @ tool, atol=1e-15)
    T = np.eye(4)
    T[:3, 3] = [0.0, 0.2, 0.0]
    dev = compare_fk(m, q[None], ["left_tip"], poses=(compile_model(m).fk(q[None], ["left_tip"]) @ T), tool=T)
    assert dev.worst < AGREEMENT
    assert compare_fk(m, q[None], ["left_tip"], tool=tool).worst < AGREEMENT
    assert compare_jacobian(m, q[None], "left_tip", tool=tool) < AGREEMENT
