"""Points and tool frames (``point`` / ``tool``) on FK, Jacobians and IK: poses are
``T_world_link @ T_link_tool``, Jacobians follow Pinocchio's frame semantics (checked against a
frame added to Pinocchio's model), IK targets the tool frame through a modified constant factor."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import api, compile_model
from kinematics.errors import PoseError
from kinematics.io.poses import tool_offset
from kinematics.spatial.reference import REFERENCES
from kinematics.tolerances import AGREEMENT_TOLERANCE
from kinematics.verify.pinocchio import compare_fk, compare_jacobian

TOOLS = [
    {"point": [0.0, 0.0, 0.1]},
    {"tool": {"xyz": [0.03, -0.02, 0.15], "rpy": [0.2, -0.4, 0.9]}},
    {"tool": {"position": [0.1, 0.0, 0.0], "quaternion": {"w": 0.7071067811865476, "x": 0.0, "y": 0.7071067811865476, "z": 0.0}}},
    {"tool": [[0, -1, 0, 0.01], [1, 0, 0, 0.02], [0, 0, 1, 0.03], [0, 0, 0, 1]]},
]


@pytest.mark.parametrize("options", TOOLS)
@pytest.mark.parametrize("model_id", ["ur5", "panda", "scara", "pr2"])
def test_fk_and_jacobians_of_a_tool_agree_with_pinocchio(catalogue, rng, options, model_id):
    model = catalogue.get(model_id)
    Q = model.sample_configurations(5, rng)
    link = model.leaf_links[-1]
    T_tool = tool_offset(**options)
    fk = api.fk(model, Q, links=[link], verify=True, **options)
    assert fk.verification.max_position_error <= AGREEMENT_TOLERANCE
    assert fk.verification.max_rotation_error <= AGREEMENT_TOLERANCE
    plain = api.fk(model, Q, links=[link]).poses
    np.testing.assert_allclose(fk.poses, plain @ T_tool, atol=1e-14)
    for reference in REFERENCES:
        answer = api.jacobian(model, Q, link=link, reference=reference, verify=True, **options)
        assert answer.verification.max_jacobian_error <= AGREEMENT_TOLERANCE, reference
    assert compare_jacobian(model, Q, link, tool=T_tool) <= AGREEMENT_TOLERANCE
    assert compare_fk(model, Q, list(model.links), tool=T_tool).worst <= AGREEMENT_TOLERANCE


def test_tool_jacobian_semantics(catalogue, rng):
    """world rows do not depend on the tool; local_world_aligned moves the reference point; local
    also rotates into the tool's axes."""
    model = catalogue.get("ur5")
    Q = model.sample_configurations(4, rng)
    T_tool = tool_offset(tool={"xyz": [0.05, 0.1, 0.2], "rpy": [0.5, 0.1, -0.7]})
    poe = compile_model(model)
    world = poe.jacobian(Q, "tool0", "world")
    np.testing.assert_array_equal(poe.jacobian(Q, "tool0", "world", tool=T_tool), world)
    lwa = poe.jacobian(Q, "tool0", "local_world_aligned")
    T = poe.fk(Q, ["tool0"])[:, 0]
    r = (T @ T_tool)[:, :3, 3] - T[:, :3, 3]
    moved = lwa.copy()
    moved[:, :3] += np.cross(lwa[:, 3:], r[:, :, None], axisa=1, axisb=1, axisc=1)
    np.testing.assert_allclose(poe.jacobian(Q, "tool0", "local_world_aligned", tool=T_tool), moved, atol=1e-14)
    R = (T @ T_tool)[:, :3, :3]
    local = np.concatenate([np.swapaxes(R, 1, 2) @ moved[:, :3], np.swapaxes(R, 1, 2) @ moved[:, 3:]], axis=1)
    np.testing.assert_allclose(poe.jacobian(Q, "tool0", "local", tool=T_tool), local, atol=1e-14)


def test_tool_with_a_base(catalogue, rng):
    model = catalogue.get("panda")
    Q = model.sample_configurations(3, rng)
    base = {"xyz": [0.5, -0.2, 1.0], "rpy": [0.0, 0.0, 1.0]}
    tool = {"xyz": [0, 0, 0.1], "rpy": [0, 0, 0.785]}
    T = api.fk(model, Q, links=["panda_link8"], base=base, tool=tool, verify=True)
    plain = api.fk(model, Q, links=["panda_link8"], base=base).poses
    np.testing.assert_allclose(T.poses, plain @ tool_offset(tool=tool), atol=1e-14)
    J = api.jacobian(model, Q, link="panda_link8", reference="local_world_aligned", base=base, tool=tool, verify=True)
    assert J.verification.max_jacobian_error <= AGREEMENT_TOLERANCE


@pytest.mark.parametrize("options", TOOLS[:2])
def test_ik_reaches_tool_targets(catalogue, rng, options):
    """Targets are poses of the tool frame: FK of the answer with the same tool lands on them
    (checked with Pinocchio's added frame too); without the tool it does not."""
    model = catalogue.get("ur5")
    Q = model.sample_configurations(8, rng)
    targets = api.fk(model, Q, links=["tool0"], **options).poses[:, 0]
    answer = api.ik(model, targets, link="tool0", verify=True, **options)
    assert answer.solution.success.all()
    assert np.max(answer.verification["position_error"]) <= 1e-6 + AGREEMENT_TOLERANCE
    assert np.max(answer.verification["rotation_error"]) <= 1e-6 + AGREEMENT_TOLERANCE
    reached = api.fk(model, answer.solution.q, links=["tool0"], **options).poses[:, 0]
    np.testing.assert_allclose(reached[:, :3, 3], targets[:, :3, 3], atol=1e-6)
    link_poses = api.fk(model, answer.solution.q, links=["tool0"]).poses[:, 0]
    assert np.min(np.linalg.norm(link_poses[:, :3, 3] - targets[:, :3, 3], axis=1)) > 0.05


def test_ik_position_mode_with_a_point(catalogue):
    model = catalogue.get("planar_2r")
    target = np.eye(4)
    target[:3, 3] = [0.3, 0.6, 0.0]
    answer = api.ik(model, target, link="tool", mode="position", point=[0.1, 0.0, 0.0])
    assert answer.solution.success[0]
    q1, q2 = answer.solution.q[0]
    tip = np.array([0.5 * np.cos(q1) + 0.5 * np.cos(q1 + q2), 0.5 * np.sin(q1) + 0.5 * np.sin(q1 + q2)])
    np.testing.assert_allclose(tip, [0.3, 0.6], atol=1e-6)  # a2 = 0.4 plus the 0.1 point along x


def test_bad_points_and_tools_are_named(catalogue):
    model = catalogue.get("ur5")
    q = [0.0] * 6
    with pytest.raises(PoseError, match="not both"):
        api.fk(model, q, point=[0, 0, 0], tool=np.eye(4))
    with pytest.raises(PoseError, match=r"^point: expected 3 numbers"):
        api.jacobian(model, q, point=[0, 0, 0, 1])
    with pytest.raises(PoseError, match="point"):
        api.fk(model, q, point=[0, float("inf"), 0])
    with pytest.raises(PoseError, match="^tool: not a rigid transform"):
        api.fk(model, q, tool=[[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    with pytest.raises(PoseError, match="^tool: give one pose"):
        api.ik(model, np.eye(4), tool=[np.eye(4).tolist(), np.eye(4).tolist()])
    with pytest.raises(PoseError, match=r"^tool\.quaternion"):
        api.fk(model, q, tool={"position": [0, 0, 0], "quaternion": {"w": 2, "x": 0, "y": 0, "z": 0}})
