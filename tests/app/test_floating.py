"""The service with floating and planar joints: floating_base and normalize on fk, jacobian,
velocity and ik (JSON and .npy), model info with nq, nv and q_layout, 422 naming the joint."""

from __future__ import annotations

import io

import numpy as np
import pytest

from tests.paths import FIXTURES
from tests.helpers import npy_bytes


UR5_Q = [0.1, -0.5, 0.7, 0.2, -0.3, 0.4]
ROOT = [0.3, -0.2, 0.5, 0.0, 0.0, float(np.sin(0.2)), float(np.cos(0.2))]


def test_model_info_shows_nq_nv_and_the_layout(api_client):
    info = api_client.get("/models/ur5").json()
    assert (info["dof"], info["nq"], info["nv"], info["floating_base"]) == (6, 6, 6, False)
    assert info["q_layout"][0] == {"name": "shoulder_pan_joint", "type": "revolute", "q": [0, 1], "v": [0, 1]}
    fb = api_client.get("/models/ur5", params={"floating_base": "true"}).json()
    assert (fb["dof"], fb["nq"], fb["nv"], fb["root"], fb["floating_base"]) == (12, 13, 12, "universe", True)
    assert fb["q_layout"][0] == {"name": "root_joint", "type": "floating", "q": [0, 7], "v": [0, 6]}
    assert fb["joints"][0]["type"] == "floating" and fb["joint_names"][0] == "root_joint"


def test_fk_jacobian_velocity_with_a_floating_base_verified(api_client):
    q = ROOT + UR5_Q
    r = api_client.post("/models/ur5/fk", json={"q": q, "floating_base": True, "links": ["base_link", "tool0"],
                                               "verify": True})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["joint_names"][0] == "root_joint" and body["poses"]["base_link"]["position"] == pytest.approx(ROOT[:3])
    assert body["verification"]["max_position_error"] < 1e-9
    for reference in ("world", "local", "local_world_aligned"):
        r = api_client.post("/models/ur5/jacobian", json={"q": q, "floating_base": True, "reference": reference,
                                                         "verify": True})
        assert r.status_code == 200 and np.shape(r.json()["jacobian"]) == (6, 12)
        assert r.json()["verification"]["max_jacobian_error"] < 1e-9
    r = api_client.post("/models/ur5/velocity", json={"q": q, "qdot": [0.1] * 12, "floating_base": True,
                                                     "verify": True})
    assert r.status_code == 200 and r.json()["verification"]["max_velocity_error"] < 1e-9


def test_a_floating_joint_may_be_a_pose_object_in_a_name_map(api_client):
    names = api_client.get("/models/ur5").json()["joint_names"]
    as_list = {"root_joint": ROOT, **dict(zip(names, UR5_Q))}
    as_pose = {"root_joint": {"position": ROOT[:3], "quaternion": {"w": ROOT[6], "x": 0, "y": 0, "z": ROOT[5]}},
               **dict(zip(names, UR5_Q))}
    as_rpy = {"root_joint": {"xyz": ROOT[:3], "rpy": [0, 0, 0.4]}, **dict(zip(names, UR5_Q))}
    poses = [api_client.post("/models/ur5/fk", json={"q": q, "floating_base": True, "format": "matrix"}).json()["poses"]
             for q in (as_list, as_pose, as_rpy)]
    for p in poses[1:]:
        np.testing.assert_allclose(p["tool0"], poses[0]["tool0"], atol=1e-12)


def test_non_unit_quaternion_is_422_naming_the_joint_unless_normalize(api_client):
    q = ROOT[:6] + [2 * ROOT[6]] + UR5_Q
    r = api_client.post("/models/ur5/fk", json={"q": q, "floating_base": True})
    assert r.status_code == 422
    problem = r.json()
    assert problem["type"].endswith("non-unit-joint-values") and problem["joint"] == "root_joint"
    assert "norm" in problem["detail"] and "normalize" in problem["detail"]
    r = api_client.post("/models/ur5/fk", json={"q": q, "floating_base": True, "normalize": True})
    assert r.status_code == 200


def test_npy_shapes_follow_nq_and_nv(api_client):
    q = np.array([ROOT + UR5_Q] * 3)
    r = api_client.post("/models/ur5/jacobian?floating_base=true", content=npy_bytes(q),
                        headers={"content-type": "application/x-npy", "accept": "application/x-npy"})
    assert r.status_code == 200 and np.load(io.BytesIO(r.content)).shape == (3, 6, 12)
    r = api_client.post("/models/ur5/velocity?floating_base=true", content=npy_bytes(np.hstack([q, np.zeros((3, 12))])),
                        headers={"content-type": "application/x-npy", "accept": "application/x-npy"})
    assert r.status_code == 200 and np.load(io.BytesIO(r.content)).shape == (3, 12, 3, 6)
    r = api_client.post("/models/ur5/velocity?floating_base=true", content=npy_bytes(np.zeros((3, 24))),
                        headers={"content-type": "application/x-npy"})
    assert r.status_code == 422 and "nq 13, nv 12" in r.json()["detail"]


def test_uploaded_model_with_floating_and_planar_joints(api_client):
    text = (FIXTURES / "floating_planar_tree.urdf").read_text()
    r = api_client.post("/models", content=text, headers={"content-type": "application/xml"})
    assert r.status_code == 201, r.text
    info = r.json()
    assert (info["nq"], info["nv"], info["dof"]) == (15, 13, 13)
    model_id = info["id"]
    q = {"shoulder": 0.3, "float": ROOT, "plane": [0.1, 0.2, 0.0, 1.0], "wrist_roll": 1.0, "finger_slide": 0.1,
         "side_joint": 0.2}
    r = api_client.post(f"/models/{model_id}/jacobian", json={"q": q, "link": "finger", "verify": True})
    assert r.status_code == 200 and np.shape(r.json()["jacobian"]) == (6, 13)
    assert r.json()["verification"]["max_jacobian_error"] < 1e-9
    bad = dict(q, plane=[0.1, 0.2, 0.5, 0.5])
    r = api_client.post(f"/models/{model_id}/fk", json={"q": bad})
    assert r.status_code == 422 and r.json()["joint"] == "plane"
    r = api_client.post(f"/models/{model_id}/workspace", json={"samples": 10})
    assert r.status_code == 422 and "floating or planar" in r.json()["detail"]


def test_ik_with_a_floating_base(api_client):
    target = {"xyz": [1.0, 2.0, 0.5], "rpy": [0.1, 0.2, 0.3]}
    r = api_client.post("/models/ur5/ik", json={"target": target, "link": "tool0", "floating_base": True,
                                               "verify": True})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["success"] and len(body["q"]) == 13 and body["joint_names"][0] == "root_joint"
    assert body["verification"]["position_error"] < 1e-6
