"""Base pose (T_world_root): FK and the three Jacobians equal those of the same model mounted
on a fixed joint at that pose, computed independently; malformed base poses are refused."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import compile_model, load_urdf, parse_urdf
from kinematics.algorithms.base import jacobian_in_world, poses_in_world
from kinematics.io.poses import base_poses
from kinematics.errors import BasePoseError
from kinematics.spatial.transforms import pose_components

from tests.paths import FIXTURES

XYZ, RPY = [0.3, -1.2, 0.8], [0.4, -0.7, 2.1]


def mounted(model, xyz, rpy):
    """The model's URDF with a new root link and a fixed joint placing the old root at (xyz, rpy)."""
    extra = (f'<link name="mount_world"/><joint name="mount" type="fixed"><parent link="mount_world"/>'
             f'<child link="{model.root}"/><origin xyz="{" ".join(map(repr, xyz))}" rpy="{" ".join(map(repr, rpy))}"/></joint>')
    return parse_urdf(model.urdf.replace("</robot>", extra + "</robot>"))


@pytest.mark.parametrize("name,link", [("tree_mimic", "right_finger"), ("spatial_3r", "tool")])
def test_base_pose_equals_a_fixed_mount(name, link, rng):
    model = load_urdf(FIXTURES / f"{name}.urdf")
    ref = mounted(model, XYZ, RPY)
    Q = model.sample_configurations(6, rng)
    B = base_poses({"xyz": XYZ, "rpy": RPY}, len(Q))
    T = poses_in_world(compile_model(model).fk(Q), B)
    np.testing.assert_allclose(T, compile_model(ref).fk(Q, list(model.links)), atol=1e-12)
    for reference in ("world", "local", "local_world_aligned"):
        J = jacobian_in_world(compile_model(model).jacobian(Q, link, reference), B, reference)
        np.testing.assert_allclose(J, compile_model(ref).jacobian(Q, link, reference), atol=1e-12, err_msg=reference)


def test_base_pose_forms_agree_and_per_configuration_list(rng):
    T = base_poses({"xyz": XYZ, "rpy": RPY}, 1)[0]
    q = pose_components(T)["quaternion"]
    as_quat = {"position": XYZ, "quaternion": dict(zip("wxyz", q.tolist()))}
    np.testing.assert_allclose(base_poses(as_quat, 1)[0], T, atol=1e-12)
    np.testing.assert_allclose(base_poses(T.tolist(), 1)[0], T, atol=0)
    per_config = base_poses([T.tolist(), {"xyz": [0, 0, 0], "rpy": [0, 0, 0]}], 2)
    np.testing.assert_allclose(per_config[0], T, atol=0)
    np.testing.assert_allclose(per_config[1], np.eye(4), atol=0)
    assert base_poses(None, 3) is None


@pytest.mark.parametrize("value,needle", [
    ({"xyz": [0, 0], "rpy": [0, 0, 0]}, "base.xyz: expected 3 numbers"),
    ({"xyz": [0, 0, "a"], "rpy": [0, 0, 0]}, "base.xyz"),
    ({"xyz": [0, 0, float("nan")], "rpy": [0, 0, 0]}, "non-finite"),
    ({"xyz": [0, 0, 1e9], "rpy": [0, 0, 0]}, "beyond"),
    ({"position": [0, 0, 0], "quaternion": {"w": 2, "x": 0, "y": 0, "z": 0}}, "not a unit quaternion"),
    ({"position": [0, 0, 0], "quaternion": [1, 0, 0, 0]}, "base.quaternion"),
    ({"translation": [0, 0, 0]}, "got the keys ['translation']"),
    ([[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "not a rigid transform"),
    ([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0]], "base[0]: expected 4 numbers"),
    ("identity", "expected a pose"),
])
def test_bad_base_pose_is_refused_naming_it(value, needle):
    with pytest.raises(BasePoseError) as exc:
        base_poses(value, 2)
    assert needle in str(exc.value)


def test_per_configuration_list_must_match_the_batch():
    with pytest.raises(BasePoseError, match="3 poses given for 2 configurations"):
        base_poses([{"xyz": [0, 0, 0], "rpy": [0, 0, 0]}] * 3, 2)
