"""POST /models/{id}/velocity (JSON and .npy), and ``point`` / ``tool`` on the FK, Jacobian and IK routes."""

from __future__ import annotations

import io

import numpy as np
import pytest

from kinematics import api, compile_model
from kinematics.tolerances import AGREEMENT_TOLERANCE
from tests.helpers import npy_bytes

PROBLEM = "application/problem+json"
NPY = "application/x-npy"
Q = [0.1, -1.2, 1.0, 0.3, 0.8, -0.2]
QD = [0.5, -0.3, 0.2, 0.0, 1.0, 0.4]


def test_one_configuration(api_client, ur5):
    r = api_client.post("/models/ur5/velocity", json={"q": Q, "qdot": QD, "links": ["tool0"], "verify": True})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["links"] == ["tool0"] and body["joint_names"] == list(ur5.joint_names)
    v = body["velocities"]["tool0"]
    expected = api.velocity(ur5, Q, QD, links=["tool0"])
    np.testing.assert_allclose(v["linear"], expected.linear[0, 0], atol=1e-15)
    np.testing.assert_allclose(v["angular"], expected.angular[0, 0], atol=1e-15)
    assert set(v["twist"]) == {"world", "local", "local_world_aligned"}
    J = compile_model(ur5).jacobian(np.array([Q]), "tool0", "world")[0]
    np.testing.assert_allclose(v["twist"]["world"], J @ QD, atol=1e-14)
    np.testing.assert_allclose(v["twist"]["local_world_aligned"], v["linear"] + v["angular"], atol=1e-15)
    assert body["verification"]["max_velocity_error"] <= AGREEMENT_TOLERANCE
    assert body["out_of_limits"] == []


def test_batch_every_link_by_default(api_client, ur5):
    r = api_client.post("/models/ur5/velocity", json={"q": [Q, [0.0] * 6], "qdot": [QD, QD]})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["links"] == list(ur5.links)
    assert isinstance(body["velocities"], list) and len(body["velocities"]) == 2
    assert set(body["velocities"][1]) == set(ur5.links)
    assert body["out_of_limits"] == [[], []]


def test_point_tool_and_base(api_client, ur5):
    base = {"xyz": [1, 0, 0.5], "rpy": [0, 0, 0.3]}
    r = api_client.post("/models/ur5/velocity", json={"q": Q, "qdot": QD, "links": ["tool0"], "point": [0, 0, 0.1],
                                                       "base": base, "verify": True})
    assert r.status_code == 200, r.text
    expected = api.velocity(ur5, Q, QD, links=["tool0"], point=[0, 0, 0.1], base=base)
    np.testing.assert_allclose(r.json()["velocities"]["tool0"]["linear"], expected.linear[0, 0], atol=1e-15)
    assert r.json()["verification"]["max_velocity_error"] <= AGREEMENT_TOLERANCE
    tool = {"position": [0, 0, 0.1], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}}
    r2 = api_client.post("/models/ur5/velocity", json={"q": Q, "qdot": QD, "links": ["tool0"], "tool": tool})
    np.testing.assert_allclose(r2.json()["velocities"]["tool0"]["linear"],
                               api.velocity(ur5, Q, QD, links=["tool0"], point=[0, 0, 0.1]).linear[0, 0], atol=1e-15)


def test_npy_in_and_out(api_client, ur5):
    rng = np.random.default_rng(0)
    q = ur5.sample_configurations(300, rng)
    qd = rng.uniform(-1, 1, q.shape)
    r = api_client.post("/models/ur5/velocity?links=tool0,wrist_1_link&verify=true", content=npy_bytes(np.hstack([q, qd])),
                        headers={"Content-Type": NPY, "Accept": NPY})
    assert r.status_code == 200, r.text
    assert r.headers["x-twist-references"] == "world,local,local_world_aligned"
    assert r.headers["x-links"] == "tool0,wrist_1_link"
    assert float(r.headers["x-max-velocity-error"]) <= AGREEMENT_TOLERANCE
    V = np.load(io.BytesIO(r.content))
    assert V.shape == (300, 2, 3, 6)
    expected = api.velocity(ur5, q, qd, links=["tool0", "wrist_1_link"]).twists
    for c, ref in enumerate(("world", "local", "local_world_aligned")):
        np.testing.assert_array_equal(V[:, :, c], expected[ref])
    # an .npy body with a JSON answer, and a point as a query parameter
    r = api_client.post("/models/ur5/velocity?links=tool0&point=0,0,0.1", content=npy_bytes(np.hstack([q[0], qd[0]])),
                        headers={"Content-Type": NPY})
    assert r.status_code == 200, r.text
    np.testing.assert_allclose(r.json()["velocities"]["tool0"]["linear"],
                               api.velocity(ur5, q[0], qd[0], links=["tool0"], point=[0, 0, 0.1]).linear[0, 0],
                               atol=1e-15)


@pytest.mark.parametrize("body, status, fragment", [
    ({"q": Q}, 422, "qdot"),
    ({"q": Q, "qdot": QD[:5]}, 422, "qdot: expected 6"),
    ({"q": Q, "qdot": [QD, QD]}, 422, "qdot: 2 velocity vector"),
    ({"q": Q, "qdot": QD, "links": ["nope"]}, 404, "nope"),
    ({"q": Q, "qdot": QD, "point": [0, 0]}, 422, "point"),
    ({"q": Q, "qdot": QD, "point": [0, 0, 0], "tool": {"xyz": [0, 0, 0], "rpy": [0, 0, 0]}}, 422, "not both"),
    ({"q": Q, "qdot": QD, "limits": "refuse", "links": ["tool0"]}, 422, "shoulder_lift"),
])
def test_bad_requests_name_the_problem(api_client, body, status, fragment):
    if body.get("limits") == "refuse":
        body = {**body, "q": [0, -7, 0, 0, 0, 0]}
    r = api_client.post("/models/ur5/velocity", json=body)
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith(PROBLEM)
    assert fragment in r.text


def test_npy_of_the_wrong_width_and_budgets(make_client, ur5):
    client = make_client(max_batch=3, max_result_values=500)
    r = client.post("/models/ur5/velocity", content=npy_bytes(np.zeros((2, 6))), headers={"Content-Type": NPY})
    assert r.status_code == 422 and "[q | qdot]" in r.json()["detail"]
    r = client.post("/models/ur5/velocity", json={"q": [Q] * 4, "qdot": [QD] * 4})
    assert r.status_code == 413 and r.json()["type"].endswith("batch-too-large")
    r = client.post("/models/ur5/velocity", json={"q": [Q] * 3, "qdot": [QD] * 3})  # 3 x 11 links x 18 > 500
    assert r.status_code == 413 and r.json()["type"].endswith("result-too-large")
    r = client.post("/models/ur5/velocity", content=b"x", headers={"Content-Type": "text/plain"})
    assert r.status_code == 415


def test_openapi_documents_velocity(api_client):
    spec = api_client.get("/openapi.json").json()
    op = spec["paths"]["/models/{model_id}/velocity"]["post"]
    assert "application/x-npy" in op["requestBody"]["content"]
    assert "VelocityRequest" in spec["components"]["schemas"]


# ---------------------------------------------------------------------- point / tool on other routes
def test_fk_jacobian_and_ik_routes_take_point_and_tool(api_client, ur5):
    tool = {"xyz": [0.0, 0.02, 0.12], "rpy": [0.1, 0.2, 0.3]}
    r = api_client.post("/models/ur5/fk", json={"q": Q, "links": ["tool0"], "tool": tool, "verify": True})
    assert r.status_code == 200, r.text
    T = np.array(r.json()["poses"]["tool0"]["matrix"])
    np.testing.assert_allclose(T, api.fk(ur5, Q, links=["tool0"], tool=tool).poses[0, 0], atol=1e-15)
    assert r.json()["verification"]["max_position_error"] <= AGREEMENT_TOLERANCE
    r = api_client.post("/models/ur5/jacobian", json={"q": Q, "link": "tool0", "reference": "local", "point": [0, 0, 0.1],
                                                       "verify": True})
    assert r.status_code == 200, r.text
    assert r.json()["verification"]["max_jacobian_error"] <= AGREEMENT_TOLERANCE
    np.testing.assert_allclose(r.json()["jacobian"],
                               api.jacobian(ur5, Q, link="tool0", reference="local", point=[0, 0, 0.1]).jacobians[0])
    r = api_client.post("/models/ur5/ik", json={"link": "tool0", "target": T.tolist(), "tool": tool, "verify": True})
    assert r.status_code == 200, r.text
    assert r.json()["success"] is True
    assert r.json()["verification"]["position_error"] <= 1e-6 + AGREEMENT_TOLERANCE
    # .npy bodies take a point as a query parameter
    r = api_client.post("/models/ur5/fk?links=tool0&point=0,0,0.1", content=npy_bytes([Q]),
                        headers={"Content-Type": NPY, "Accept": NPY})
    np.testing.assert_allclose(np.load(io.BytesIO(r.content))[0, 0],
                               api.fk(ur5, Q, links=["tool0"], point=[0, 0, 0.1]).poses[0, 0], atol=1e-15)
    r = api_client.post("/models/ur5/jacobian?link=tool0&point=0,0,a", content=npy_bytes([Q]), headers={"Content-Type": NPY})
    assert r.status_code == 422 and r.json()["field"] == "point"
    r = api_client.post("/models/ur5/fk", json={"q": Q, "tool": {"xyz": [0, 0, 0]}})
    assert r.status_code == 422
