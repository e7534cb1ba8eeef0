"""The use-case layer (kinematics.api): fk, jacobian, joint_batch, resolve_links, budgets,
limits, verification, load_model and warm_up, checked against the engine they wrap."""

from __future__ import annotations

import numpy as np
import pytest

import kinematics
from kinematics import (
    BudgetError,
    JointValueError,
    KinematicsError,
    LimitError,
    UnknownLinkError,
    compile_model,
)
from kinematics.api import (
    Budget,
    FKAnswer,
    JacobianAnswer,
    Verification,
    dh_form,
    fk,
    jacobian,
    joint_batch,
    load_model,
    reference_name,
    resolve_links,
    screws,
    warm_up,
)
from kinematics.spatial.reference import REFERENCES, Reference
from kinematics.spatial.rotations import rpy_to_matrix
from kinematics.spatial.transforms import make_transform, pose_components
from kinematics.tolerances import AGREEMENT_TOLERANCE
from kinematics.verify.pinocchio import REFERENCE_NAME

from tests.paths import FIXTURES, REPO


def configurations(model, n, seed=3):
    return model.sample_configurations(n, np.random.default_rng(seed), continuous_range=np.pi)


# ---------------------------------------------------------------------- fk
def test_fk_equals_the_engine_bit_for_bit(ur5):
    Q = configurations(ur5, 7)
    links = ["tool0", "wrist_2_link", "base_link"]
    answer = fk(ur5, Q.tolist(), links=links)
    assert isinstance(answer, FKAnswer)
    assert answer.links == links
    assert answer.poses.shape == (7, 3, 4, 4)
    np.testing.assert_array_equal(answer.Q, Q)
    np.testing.assert_array_equal(answer.poses, compile_model(ur5).fk(Q, links))
    assert answer.verification is None
    c = answer.components()
    np.testing.assert_array_equal(c["position"], answer.poses[..., :3, 3])
    np.testing.assert_array_equal(c["quaternion"], pose_components(answer.poses)["quaternion"])


def test_is_batch(ur5):
    vector = [0.1] * 6
    name_map = dict(zip(ur5.joint_names, vector))
    assert fk(ur5, vector).is_batch is False
    assert fk(ur5, name_map).is_batch is False
    assert fk(ur5, [vector]).is_batch is True
    assert fk(ur5, [vector, vector]).is_batch is True
    assert fk(ur5, [name_map, vector]).is_batch is True
    assert fk(ur5, np.array([vector])).is_batch is True
    assert fk(ur5, np.array(vector)).is_batch is False
    np.testing.assert_array_equal(fk(ur5, name_map).poses, fk(ur5, vector).poses)


def test_links_none_all_duplicates_unknown(ur5):
    assert fk(ur5, [0.0] * 6).links == list(ur5.leaf_links)
    assert resolve_links(ur5, None) == list(ur5.leaf_links)
    assert fk(ur5, [0.0] * 6, links="all").links == list(ur5.links)
    assert fk(ur5, [0.0] * 6, links="all").poses.shape == (1, len(ur5.links), 4, 4)
    assert resolve_links(ur5, ["tool0", "base_link", "tool0", "base_link"]) == ["tool0", "base_link"]
    answer = fk(ur5, [0.2] * 6, links=["tool0", "base_link", "tool0"])
    assert answer.links == ["tool0", "base_link"]
    np.testing.assert_array_equal(answer.poses, compile_model(ur5).fk(np.full((1, 6), 0.2), ["tool0", "base_link"]))
    with pytest.raises(UnknownLinkError, match="no_such_link"):
        resolve_links(ur5, ["tool0", "no_such_link"])
    with pytest.raises(UnknownLinkError, match="no_such_link"):
        fk(ur5, [0.0] * 6, links=["no_such_link"])
    with pytest.raises(KinematicsError, match="'tool0'"):
        resolve_links(ur5, "tool0")  # a bare string other than "all"


def test_base_moves_poses(ur5):
    Q = configurations(ur5, 4)
    xyz, rpy = [0.3, -1.2, 0.5], [0.1, -0.4, 2.0]
    B = make_transform(rpy_to_matrix(rpy), xyz)
    plain = fk(ur5, Q, links="all")
    moved = fk(ur5, Q, links="all", base={"xyz": xyz, "rpy": rpy})
    np.testing.assert_allclose(moved.poses, B @ plain.poses, rtol=0, atol=1e-15)
    assert np.abs(moved.poses - plain.poses).max() > 0.1
    # one base per configuration
    bases = [{"xyz": [float(k), 0.0, 0.0], "rpy": [0.0, 0.0, 0.0]} for k in range(4)]
    each = fk(ur5, Q, links=["tool0"], base=bases)
    expected = plain.poses[:, [ur5.links.index("tool0")]].copy()
    expected[:, 0, 0, 3] += np.arange(4.0)
    np.testing.assert_allclose(each.poses, expected, rtol=0, atol=1e-15)


# ---------------------------------------------------------------------- limits
def test_limits_refuse_and_report(ur5):
    inside = [0.0] * 6
    outside = [0.0, 0.0, 4.0, 0.0, 0.0, 0.0]  # elbow_joint is limited to +-pi
    with pytest.raises(LimitError, match="elbow_joint"):
        fk(ur5, outside, limits="refuse")
    with pytest.raises(LimitError, match="elbow_joint"):
        jacobian(ur5, [inside, outside], limits="refuse")
    fk(ur5, inside, limits="refuse")  # within: no error
    answer = fk(ur5, outside, limits="report")
    assert answer.out_of_limits() == [["elbow_joint"]]
    assert answer.out_of_limits_count() == 1
    np.testing.assert_array_equal(answer.poses, compile_model(ur5).fk(np.array([outside]), answer.links))
    batch = fk(ur5, [inside, outside, [7.0] + outside[1:], inside])
    assert batch.out_of_limits() == [[], ["elbow_joint"], ["shoulder_pan_joint", "elbow_joint"], []]
    assert batch.out_of_limits_count() == 2
    assert jacobian(ur5, [outside, outside, inside]).out_of_limits_count() == 2
    with pytest.raises(KinematicsError, match="ignore"):
        fk(ur5, inside, limits="ignore")


# ---------------------------------------------------------------------- budgets
def test_budget_max_batch(ur5):
    budget = Budget(max_batch=3)
    assert fk(ur5, [[0.0] * 6] * 3, budget=budget).poses.shape[0] == 3
    for call in (lambda: fk(ur5, [[0.0] * 6] * 4, budget=budget),
                 lambda: jacobian(ur5, [[0.0] * 6] * 4, budget=budget),
                 lambda: joint_batch(ur5, [[0.0] * 6] * 4, budget)):
        with pytest.raises(BudgetError) as err:
            call()
        assert (err.value.budget, err.value.field, err.value.limit) == ("batch", "q", 3)


def test_budget_max_verify_only_when_verifying(ur5):
    budget = Budget(max_verify=2)
    Q3 = [[0.1] * 6] * 3
    fk(ur5, Q3, budget=budget)  # not verified: no bound
    jacobian(ur5, Q3, budget=budget)
    assert fk(ur5, Q3[:2], verify=True, budget=budget).verification is not None  # at the bound
    for call in (lambda: fk(ur5, Q3, verify=True, budget=budget),
                 lambda: jacobian(ur5, Q3, verify=True, budget=budget)):
        with pytest.raises(BudgetError) as err:
            call()
        assert (err.value.budget, err.value.field, err.value.limit) == ("verify", "verify", 2)


def test_budget_max_result_values(ur5):
    Q = [[0.0] * 6] * 2
    # fk: N x L x 16 numbers
    fk(ur5, Q, links=["tool0", "base_link"], budget=Budget(max_result_values=2 * 2 * 16))
    with pytest.raises(BudgetError) as err:
        fk(ur5, Q, links=["tool0", "base_link"], budget=Budget(max_result_values=2 * 2 * 16 - 1))
    assert (err.value.budget, err.value.field, err.value.limit) == ("result", "q", 63)
    # duplicates do not count twice
    fk(ur5, Q, links=["tool0", "tool0"], budget=Budget(max_result_values=2 * 16))
    # jacobian: N x 6 x dof numbers
    jacobian(ur5, Q, budget=Budget(max_result_values=2 * 6 * 6))
    with pytest.raises(BudgetError) as err:
        jacobian(ur5, Q, budget=Budget(max_result_values=2 * 6 * 6 - 1))
    assert (err.value.budget, err.value.field, err.value.limit) == ("result", "q", 71)


def test_unbounded_budget_by_default():
    b = Budget()
    b.check_batch(10**9)
    b.check_verify(10**9)
    b.check_result(10**12, "many")


# ---------------------------------------------------------------------- jacobian
@pytest.mark.parametrize("reference", REFERENCES)
def test_jacobian_equals_the_engine_bit_for_bit(ur5, reference):
    Q = configurations(ur5, 5)
    answer = jacobian(ur5, Q.tolist(), link="wrist_3_link", reference=reference)
    assert isinstance(answer, JacobianAnswer)
    assert answer.link == "wrist_3_link"
    assert answer.reference == reference and isinstance(answer.reference, Reference)
    assert answer.jacobians.shape == (5, 6, 6)
    np.testing.assert_array_equal(answer.jacobians, compile_model(ur5).jacobian(Q, "wrist_3_link", reference))
    assert answer.verification is None


def test_jacobian_default_link_and_conditioning(ur5):
    Q = configurations(ur5, 3)
    answer = jacobian(ur5, Q)
    assert answer.link == ur5.leaf_links[0]
    np.testing.assert_array_equal(answer.jacobians, compile_model(ur5).jacobian(Q, ur5.leaf_links[0], "world"))
    c = answer.conditioning()
    assert set(c) == {"singular_values", "manipulability", "condition_number"}
    assert c["singular_values"].shape == (3, 6)
    np.testing.assert_allclose(c["singular_values"], np.linalg.svd(answer.jacobians, compute_uv=False), atol=1e-12)
    np.testing.assert_allclose(c["manipulability"], np.abs(np.linalg.det(answer.jacobians)), rtol=1e-9, atol=1e-15)
    with pytest.raises(UnknownLinkError):
        jacobian(ur5, Q, link="nope")
    with pytest.raises(KinematicsError, match="bogus"):
        jacobian(ur5, Q, reference="bogus")


# ---------------------------------------------------------------------- verification
def test_fk_verify(ur5):
    Q = configurations(ur5, 3)
    answer = fk(ur5, Q, links="all", verify=True)
    v = answer.verification
    assert isinstance(v, Verification)
    assert v.reference.startswith("pinocchio") and v.reference == REFERENCE_NAME
    assert v.max_position_error < AGREEMENT_TOLERANCE
    assert v.max_rotation_error < AGREEMENT_TOLERANCE
    assert v.max_jacobian_error is None
    assert set(v.as_dict()) == {"reference", "max_position_error", "max_rotation_error"}
    # with a base, the poses move but the comparison (in the root frame) still agrees
    moved = fk(ur5, Q, base={"xyz": [1.0, 2.0, 3.0], "rpy": [0.5, 0.2, -1.0]}, verify=True)
    assert moved.verification.max_position_error < AGREEMENT_TOLERANCE
    assert moved.verification.max_rotation_error < AGREEMENT_TOLERANCE


@pytest.mark.parametrize("reference", REFERENCES)
def test_jacobian_verify(ur5, reference):
    Q = configurations(ur5, 3)
    base = {"xyz": [1.0, 2.0, 3.0], "rpy": [0.5, 0.2, -1.0]}
    v = jacobian(ur5, Q, link="tool0", reference=reference, base=base, verify=True).verification
    assert v.reference.startswith("pinocchio")
    assert v.max_jacobian_error < AGREEMENT_TOLERANCE
    assert v.max_position_error is None and v.max_rotation_error is None
    assert set(v.as_dict()) == {"reference", "max_jacobian_error"}


# ---------------------------------------------------------------------- joint_batch
def test_joint_batch_forms(ur5):
    Q, is_batch = joint_batch(ur5, [[0.1] * 6, [0.2] * 6])
    assert is_batch and Q.shape == (2, 6) and Q.dtype == np.float64
    np.testing.assert_array_equal(Q, [[0.1] * 6, [0.2] * 6])
    Q, is_batch = joint_batch(ur5, [0.3] * 6)
    assert not is_batch and Q.shape == (1, 6)


def test_joint_batch_ragged_names_the_configuration(ur5):
    with pytest.raises(JointValueError, match="configuration 1"):
        joint_batch(ur5, [[0.0] * 6, [0.0] * 5])
    with pytest.raises(JointValueError, match="configuration 2"):
        joint_batch(ur5, [[0.0] * 6, [0.0] * 6, [0.0] * 7])
    with pytest.raises(JointValueError, match="configuration 0"):
        joint_batch(ur5, [[0.0] * 5 + ["x"], [0.0] * 6])


def test_joint_batch_refuses_an_empty_batch(ur5):
    with pytest.raises(JointValueError):
        joint_batch(ur5, [])
    with pytest.raises(JointValueError, match="no configuration"):
        joint_batch(ur5, np.zeros((0, 6)))
    with pytest.raises(JointValueError):
        fk(ur5, [])


def test_joint_batch_refuses_non_finite_values(ur5):
    with pytest.raises(JointValueError, match="configuration 1.*wrist_1_joint"):
        joint_batch(ur5, [[0.0] * 6, [0.0, 0.0, 0.0, float("nan"), 0.0, 0.0]])


# ---------------------------------------------------------------------- load_model
def test_load_model_requires_exactly_one_source():
    with pytest.raises(KinematicsError, match="exactly one"):
        load_model()
    with pytest.raises(KinematicsError, match="exactly one"):
        load_model(model_id="ur5", urdf=str(FIXTURES / "planar_2r.urdf"))
    with pytest.raises(KinematicsError, match="exactly one"):
        load_model(urdf=str(FIXTURES / "planar_2r.urdf"), dh=str(REPO / "kinematics/io/presets/planar_2r.yaml"))


def test_load_model_from_dh_preset():
    model = load_model(dh=str(REPO / "kinematics" / "io" / "presets" / "planar_2r.yaml"))
    assert model.dof == 2
    # a1 = 0.5, a2 = 0.4: the tool at (a1 c1 + a2 c12, a1 s1 + a2 s12, 0)
    q1, q2 = np.pi / 6, np.pi / 3
    p = fk(model, [q1, q2], links=["tool"]).poses[0, 0, :3, 3]
    np.testing.assert_allclose(p, [0.5 * np.cos(q1) + 0.4 * np.cos(q1 + q2), 0.5 * np.sin(q1) + 0.4 * np.sin(q1 + q2), 0.0],
                               atol=1e-12)


def test_load_model_from_urdf_and_catalogue(ur5):
    model = load_model(urdf=str(FIXTURES / "planar_2r.urdf"))
    assert model.name == "planar_2r" and model.joint_names == ("q1", "q2")
    q1, q2 = 0.4, -1.1
    p = fk(model, [q1, q2], links=["tool"]).poses[0, 0, :3, 3]
    np.testing.assert_allclose(p, [0.7 * np.cos(q1) + 0.5 * np.cos(q1 + q2), 0.7 * np.sin(q1) + 0.5 * np.sin(q1 + q2), 0.0],
                               atol=1e-12)
    assert load_model(model_id="ur5") is ur5
    with pytest.raises(kinematics.UnknownModelError):
        load_model(model_id="no_such_robot")


# ---------------------------------------------------------------------- the small ones
def test_warm_up_runs():
    assert warm_up() is None


def test_screws_reference_name_and_dh_form(ur5):
    assert screws(ur5) is compile_model(ur5)
    assert reference_name() == REFERENCE_NAME
    assert reference_name().startswith("pinocchio ")
    planar = load_model(urdf=str(FIXTURES / "planar_2r.urdf"))
    table = dh_form(planar, tip="tool")
    assert table.convention == "standard"
    assert table.dof == 2 and tuple(table.joint_names) == ("q1", "q2")
    with pytest.raises(kinematics.NoDHFormError):
        dh_form(load_model(urdf=str(FIXTURES / "tree_mimic.urdf")))  # a tree with a mimic joint
