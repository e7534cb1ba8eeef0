"""Link velocities (algorithms/velocity.py, api.velocity): closed forms, J(q) qdot with a base,
Pinocchio's getFrameVelocity (with points and tools), validation and budgets."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import api
from kinematics.algorithms.jacobian import jacobian
from kinematics.algorithms.velocity import velocities
from kinematics.errors import BudgetError, JointValueError, PoseError, UnknownLinkError
from kinematics.io.poses import base_poses
from kinematics.spatial.reference import REFERENCES, Reference
from kinematics.tolerances import AGREEMENT_TOLERANCE


def test_planar_2r_closed_form(catalogue, rng):
    """Tip of the 2R arm: v = [-a1 s1 - a2 s12, a1 c1 + a2 c12] qd1 + [-a2 s12, a2 c12] qd2, ω_z = qd1 + qd2."""
    model = catalogue.get("planar_2r")
    a1, a2 = 0.5, 0.4
    Q = rng.uniform(-np.pi, np.pi, (50, 2))
    Qd = rng.uniform(-2, 2, (50, 2))
    V = velocities(model, Q, Qd, ["tool"])["local_world_aligned"][:, 0]
    q1, q12 = Q[:, 0], Q.sum(axis=1)
    vx = (-a1 * np.sin(q1) - a2 * np.sin(q12)) * Qd[:, 0] - a2 * np.sin(q12) * Qd[:, 1]
    vy = (a1 * np.cos(q1) + a2 * np.cos(q12)) * Qd[:, 0] + a2 * np.cos(q12) * Qd[:, 1]
    expected = np.stack([vx, vy, 0 * vx, 0 * vx, 0 * vx, Qd.sum(axis=1)], axis=1)
    np.testing.assert_allclose(V, expected, atol=1e-14)


def test_scara_prismatic_joint_adds_linear_velocity(catalogue):
    """SCARA at rest but its prismatic joint: the tool moves along z at qd3, without turning."""
    model = catalogue.get("scara")
    V = velocities(model, [[0.3, -0.4, 0.1, 0.2]], [[0, 0, 0.25, 0]], ["tool"])["local_world_aligned"][0, 0]
    np.testing.assert_allclose(V, [0, 0, 0.25, 0, 0, 0], atol=1e-15)


@pytest.mark.parametrize("model_id", ["ur5", "panda", "talos_reduced", "scara", "romeo"])
def test_with_a_base_equals_jacobian_times_qdot(catalogue, rng, model_id):
    model = catalogue.get(model_id)
    Q = model.sample_configurations(6, rng)
    Qd = rng.uniform(-1, 1, Q.shape)
    B = base_poses([{"xyz": list(rng.uniform(-1, 1, 3)), "rpy": list(rng.uniform(-3, 3, 3))} for _ in range(6)], 6)
    leaves = list(model.leaf_links)
    V = velocities(model, Q, Qd, leaves, base=B)
    for ref in REFERENCES:
        for k, leaf in enumerate(leaves):
            J = jacobian(model, Q, leaf, ref, base=B)
            np.testing.assert_allclose(V[ref][:, k], np.einsum("nij,nj->ni", J, Qd), atol=1e-12)


@pytest.mark.parametrize("model_id", ["ur5", "panda", "pr2", "tiago_dual", "double_pendulum_continuous", "baxter"])
def test_api_velocity_verified_with_pinocchio(catalogue, rng, model_id):
    """Every link, three references, continuous joints beyond +-pi, mimic joints: Pinocchio agrees."""
    model = catalogue.get(model_id)
    Q = model.sample_configurations(4, rng)
    Qd = rng.uniform(-2, 2, Q.shape)
    answer = api.velocity(model, Q, Qd, verify=True)
    assert answer.links == list(model.links)
    assert answer.verification.max_velocity_error <= AGREEMENT_TOLERANCE
    assert answer.linear.shape == answer.angular.shape == (4, len(model.links), 3)


@pytest.mark.parametrize("tool", [{"point": [0.0, 0.05, 0.12]},
                                  {"tool": {"xyz": [0.02, -0.1, 0.2], "rpy": [0.4, -0.3, 1.2]}}])
def test_point_and_tool_velocities_follow_pinocchio_frames(catalogue, rng, tool):
    model = catalogue.get("ur5")
    Q = model.sample_configurations(5, rng)
    Qd = rng.uniform(-2, 2, Q.shape)
    answer = api.velocity(model, Q, Qd, links=["tool0", "wrist_1_link"], verify=True, **tool)
    assert answer.verification.max_velocity_error <= AGREEMENT_TOLERANCE
    # the tool origin's velocity is the link origin's plus ω x (p_tool - p_link)
    plain = api.velocity(model, Q, Qd, links=["tool0", "wrist_1_link"])
    T = api.fk(model, Q, links=["tool0", "wrist_1_link"]).poses
    Tt = api.fk(model, Q, links=["tool0", "wrist_1_link"], **tool).poses
    expected = plain.linear + np.cross(plain.angular, Tt[..., :3, 3] - T[..., :3, 3])
    np.testing.assert_allclose(answer.linear, expected, atol=1e-13)
    np.testing.assert_allclose(answer.angular, plain.angular, atol=0)


def test_verify_with_a_base_compares_root_frame_twists(catalogue, rng):
    model = catalogue.get("panda")
    Q = model.sample_configurations(3, rng)
    answer = api.velocity(model, Q, rng.uniform(-1, 1, Q.shape), base={"xyz": [1, 2, 3], "rpy": [0.1, 0.2, 0.3]},
                          verify=True)
    assert answer.verification.max_velocity_error <= AGREEMENT_TOLERANCE


def test_forms_of_q_and_qdot(catalogue):
    model = catalogue.get("ur5")
    names = model.joint_names
    q = [0.1, -1.0, 1.2, 0.0, 0.8, 0.0]
    qd = [0.3, 0.0, 0.0, 0.1, 0.0, 0.0]
    one = api.velocity(model, q, qd, links=["tool0"])
    assert not one.is_batch and one.twists[Reference.WORLD].shape == (1, 1, 6)
    mapped = api.velocity(model, dict(zip(names, q)), dict(zip(names, qd)), links=["tool0"])
    np.testing.assert_array_equal(mapped.linear, one.linear)
    batch = api.velocity(model, [q, q], [qd, [0.0] * 6], links="all")
    assert batch.is_batch and batch.links == list(model.links)
    np.testing.assert_array_equal(batch.linear[0, -1], api.velocity(model, q, qd).linear[0, -1])
    assert np.all(batch.linear[1] == 0.0)


def test_bad_qdot_is_named(catalogue):
    model = catalogue.get("ur5")
    q = [0.0] * 6
    with pytest.raises(JointValueError, match="^qdot: .*not finite"):
        api.velocity(model, q, [0.0, float("nan"), 0, 0, 0, 0])
    with pytest.raises(JointValueError, match="^qdot: expected 6"):
        api.velocity(model, q, [0.0] * 5)
    with pytest.raises(JointValueError, match="qdot: 2 velocity vector"):
        api.velocity(model, q, [[0.0] * 6, [0.0] * 6])
    with pytest.raises(JointValueError, match="qdot: 1 velocity vector"):
        api.velocity(model, [q, q], [0.0] * 6)
    with pytest.raises(UnknownLinkError):
        api.velocity(model, q, q, links=["nope"])
    with pytest.raises(PoseError, match="not both"):
        api.velocity(model, q, q, point=[0, 0, 0.1], tool=np.eye(4))
    with pytest.raises(PoseError, match="point"):
        api.velocity(model, q, q, point=[0, 0])


def test_budgets(catalogue):
    model = catalogue.get("ur5")
    q = [[0.0] * 6] * 5
    with pytest.raises(BudgetError) as exc:
        api.velocity(model, q, q, budget=api.Budget(max_batch=4))
    assert exc.value.budget == "batch"
    with pytest.raises(BudgetError) as exc:
        api.velocity(model, q, q, budget=api.Budget(max_result_values=5 * 11 * 18 - 1))
    assert exc.value.budget == "result"
    api.velocity(model, q, q, budget=api.Budget(max_result_values=5 * 11 * 18))
    with pytest.raises(BudgetError) as exc:
        api.velocity(model, q, q, verify=True, budget=api.Budget(max_verify=4))
    assert exc.value.budget == "verify"
