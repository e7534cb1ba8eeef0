"""REST API: closed forms (POST /models/{id}/symbolic, POST /symbolic/dh), task vectors
(POST /models/{id}/task), and models from PoE screws and zero-configuration axes
(POST /models/poe, POST /models/axes)."""

from __future__ import annotations

import types

import numpy as np
import pytest
import sympy as sp

from kinematics import api, default_catalogue

PROBLEM = "application/problem+json"
MR_3R = {"name": "mr_3r", "M": [[0, 0, 1, 0.6], [0, 1, 0, 0], [-1, 0, 0, -0.4], [0, 0, 0, 1]],
         "joints": [{"S": [0, 0, 1, 0, 0, 0]}, {"S": [0, -1, 0, 0, 0, -0.6]}, {"S": [1, 0, 0, 0, -0.4, 0]}]}
WEN_SCARA = {"name": "wen_scara", "joints": [
    {"type": "R", "h": [0, 0, 1], "p": [0, 0, 0]}, {"type": "R", "h": [0, 0, 1], "p": [0, 0.4, 0]},
    {"type": "R", "h": [0, 0, 1], "p": [0, 0.3, 0]}, {"type": "P", "h": [0, 0, 1], "p": [0, 0, 0.1]}]}
SCARA_TABLE = {"joints": [
    {"type": "R", "a": "a1", "alpha": 0, "d": "d1", "theta": 0}, {"type": "R", "a": "a2", "alpha": 0, "d": 0, "theta": 0},
    {"type": "P", "a": 0, "alpha": 0, "d": 0, "theta": 0}, {"type": "R", "a": 0, "alpha": "pi", "d": "d4", "theta": 0}]}

RPR_T3_0 = (r"\begin{bmatrix}c_{1} c_{3} & - c_{1} s_{3} & s_{1} & s_{1} \left(q_{2} + \frac{1}{10}\right)\\"
            r"c_{3} s_{1} & - s_{1} s_{3} & - c_{1} & - c_{1} \left(q_{2} + \frac{1}{10}\right)\\"
            r"s_{3} & c_{3} & 0 & \frac{3}{10}\\0 & 0 & 0 & 1\end{bmatrix}")


def test_rpr_preset_in_latex(api_client):
    r = api_client.post("/models/rpr_example/symbolic", json={"what": ["transforms", "jacobian"]})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["T"] == RPR_T3_0  # Spong-convention RPR example: T3_0 with d1 = 0.3, d3 = 0.1, d2 = q2
    assert body["joint_variables"] == [{"symbol": "q1", "joint": "joint_1"}, {"symbol": "q2", "joint": "joint_2"},
                                       {"symbol": "q3", "joint": "joint_3"}]
    assert body["parameters"] == [] and body["simplified"] and len(body["A"]) == 3
    assert set(body["jacobian"]) == {"local_world_aligned", "world"} and "code" not in body
    assert body["frames"] == ["frame_1", "frame_2", "frame_3"] and body["tip"] == "tool"


def test_symbolic_dh_scara_task_vector_as_text(api_client):
    r = api_client.post("/symbolic/dh", json={"table": SCARA_TABLE, "what": ["task"], "representation": "scara",
                                              "format": "text"})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["r"] == [["a1*cos(q1) + a2*cos(q1 + q2)"], ["a1*sin(q1) + a2*sin(q1 + q2)"], ["d1 + d4 + q3"],
                         ["q1 + q2 + q4"]]
    assert body["J_r"][3] == ["1", "1", "0", "1"] and body["components"] == ["px", "py", "pz", "alpha_z"]
    assert body["parameters"] == ["a1", "a2", "d1", "d4"] and "model" not in body
    T = sp.Matrix([[sp.sympify(e) for e in row] for row in body["T"]])
    assert T[2, 2] == -1


def test_python_code_of_a_model_runs(api_client, rng):
    r = api_client.post("/models/ur5/symbolic", json={"tip": "tool0", "format": "python", "simplify": False})
    assert r.status_code == 200, r.text
    body = r.json()
    assert [f["name"] for f in body["functions"]][:2] == ["fk", "frames"] and "T" not in body
    module = types.ModuleType("ur5_closed_forms")
    exec(body["code"], module.__dict__)
    ur5 = default_catalogue().get("ur5")
    Q = ur5.sample_configurations(10, rng)
    np.testing.assert_allclose(module.fk(Q), api.fk(ur5, Q, links=["tool0"]).poses[:, 0], atol=1e-12)
    assert not body["simplified"] and not hasattr(module, "jacobian_world")


def test_c_code_and_names_as_variables(api_client):
    r = api_client.post("/models/planar_2r/symbolic", json={"format": "c", "prefix": "p2r_", "variables": "names"})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["functions"][0]["signature"] == "void p2r_fk(const double *q, double *T)"
    assert body["joint_variables"][0] == {"symbol": "joint_1", "joint": "joint_1"}
    assert "#include <math.h>" in body["code"]


@pytest.mark.parametrize("path, payload, status, slug, field", [
    ("/models/ur5/symbolic", {}, 422, "invalid-symbolic-request", None),  # a tree: choose the tip
    ("/models/ur5/symbolic", {"tip": "nowhere"}, 404, "unknown-link", None),
    ("/models/nope/symbolic", {}, 404, "unknown-model", None),
    ("/models/ur5/symbolic", {"tip": "tool0", "format": "pdf"}, 422, "validation-error", "format"),
    ("/models/ur5/symbolic", {"tip": "tool0", "what": ["task"], "representation": "rpy", "components": ["qw"]},
     422, "invalid-task-representation", None),
    ("/symbolic/dh", {"table": {"joints": [{"type": "R", "a": "cos(x)", "alpha": 0, "d": 0, "theta": 0}]}}, 422,
     "invalid-dh-table", None),
    ("/symbolic/dh", {"table": {"joints": []}, "extra": 1}, 422, "validation-error", "extra"),
])
def test_symbolic_errors(api_client, path, payload, status, slug, field):
    r = api_client.post(path, json=payload)
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith(PROBLEM)
    assert r.json()["type"] == f"urn:kinematics:problem:{slug}"
    if field:
        assert r.json()["field"] == field


def test_time_limit_answers_the_time_budget_problem_naming_the_setting(make_client):
    """A derivation stopped by its time limit answers as every time budget does: 503
    time-budget-exceeded naming the setting and its limit (and suggesting simplify: false)."""
    client = make_client(symbolic_timeout=0.05)
    r = client.post("/models/panda/symbolic", json={"tip": "panda_hand_tcp", "what": ["transforms", "jacobian"]})
    assert r.status_code == 503, r.text
    body = r.json()
    assert body["type"] == "urn:kinematics:problem:time-budget-exceeded"
    assert "simplify: false" in body["detail"]
    assert body["setting"] == "KIN_SYMBOLIC_TIMEOUT" and body["limit"] == 0.05
    # a request may ask for less time than the service allows (then its field is named: the client's own
    # limit, a 422, not a fault of the server), not more
    r = make_client(symbolic_timeout=30).post("/models/panda/symbolic", json={
        "tip": "panda_hand_tcp", "what": ["transforms", "jacobian"], "timeout": 0.1})
    assert r.status_code == 422 and r.json()["setting"] == "timeout" and r.json()["limit"] == 0.1, r.text
    assert r.json()["type"] == "urn:kinematics:problem:time-budget-exceeded"
    r = client.post("/models/planar_2r/symbolic", json={"timeout": 1000, "simplify": False})
    assert r.status_code in (200, 503)


def test_task_endpoint(api_client):
    r = api_client.post("/models/planar_2r/task", json={"q": [0.0, np.pi / 2], "representation": "planar"})
    assert r.status_code == 200, r.text
    body = r.json()
    np.testing.assert_allclose(body["r"], [0.5, 0.4, np.pi / 2], atol=1e-12)
    np.testing.assert_allclose(body["J_r"], [[-0.4, -0.4], [0.5, 0.0], [1.0, 1.0]], atol=1e-12)
    assert body["components"] == ["px", "py", "phi"] and body["out_of_limits"] == []
    r = api_client.post("/models/planar_2r/task", json={"q": [[0, 0], [0.1, 0.2]], "representation": "rpy",
                                                        "components": ["yaw", "px"]})
    assert r.status_code == 200 and np.shape(r.json()["J_r"]) == (2, 2, 2)
    r = api_client.post("/models/scara/task", json={"q": [0, 0, 0, 0], "representation": "zyz"})
    assert r.status_code == 422 and r.json()["type"] == "urn:kinematics:problem:representation-singularity"
    r = api_client.post("/models/scara/task", json={"q": [0, 0, 0, 0], "representation": "rpy",
                                                    "components": ["theta"]})
    assert r.status_code == 422 and r.json()["type"] == "urn:kinematics:problem:invalid-task-representation"


# ---------------------------------------------------------------------- PoE and axes models
def test_poe_model_is_registered_and_gives_its_screws_back(make_client):
    client = make_client()
    r = client.post("/models/poe", json=MR_3R)
    assert r.status_code == 201, r.text
    model_id = r.json()["id"]
    assert model_id.startswith("poe-") and r.headers["location"] == f"/models/{model_id}"
    assert r.json()["source"] == "poe" and r.json()["description"]["joints"][1]["S"] == [0, -1, 0, 0, 0, -0.6]
    again = client.post("/models/poe", json=MR_3R)
    assert again.status_code == 200 and again.json()["id"] == model_id
    screws = client.get(f"/models/{model_id}/screws").json()
    np.testing.assert_allclose([j["screw"] for j in screws["joints"]], [j["S"] for j in MR_3R["joints"]], atol=1e-15)
    np.testing.assert_allclose(screws["home_poses"]["tool"], MR_3R["M"], atol=1e-15)
    fk = client.post(f"/models/{model_id}/fk", json={"q": [0, np.pi / 2, 0], "format": "matrix"}).json()
    np.testing.assert_allclose(np.array(fk["poses"]["tool"])[:3, 3], [1.0, 0, 0], atol=1e-15)
    # a second replica on the same data directory finds it; the closed forms come from its URDF
    other = make_client()
    assert other.get(f"/models/{model_id}").json()["description"] == r.json()["description"]
    T = other.post(f"/models/{model_id}/symbolic", json={"format": "text"}).json()["T"]
    assert T[2][3] == "-2*cos(q2)/5"
    assert other.delete(f"/models/{model_id}").status_code == 204
    assert client.get(f"/models/{model_id}").status_code == 404


def test_axes_model_is_registered(make_client):
    client = make_client()
    r = client.post("/models/axes", json=WEN_SCARA)
    assert r.status_code == 201, r.text
    model_id = r.json()["id"]
    assert model_id.startswith("axes-") and r.json()["dof"] == 4
    assert [m["id"] for m in client.get("/models").json() if m["source"] == "axes"] == [model_id]
    assert client.post("/models/axes", json={**WEN_SCARA, "angles": "radians"}).json()["id"] == model_id
    q = [0.1, 0.2, 0.3, 0.05]
    fk = client.post(f"/models/{model_id}/fk", json={"q": q, "format": "matrix"}).json()["poses"]["tool"]
    c = np.cos
    s = np.sin
    p = [-0.4 * s(q[0]) - 0.3 * s(q[0] + q[1]), 0.4 * c(q[0]) + 0.3 * c(q[0] + q[1]), 0.1 + q[3]]
    np.testing.assert_allclose(np.array(fk)[:3, 3], p, atol=1e-12)


@pytest.mark.parametrize("path, payload, slug, detail", [
    ("/models/poe", {"M": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
                     "joints": [{"S": [0, 0, 1, 0, 0, 1]}]}, "invalid-poe-model", "joints[0].S: pitch"),
    ("/models/poe", {"joints": [{"S": [0, 0, 1, 0, 0, 0]}]}, "invalid-poe-model", "M: missing"),
    ("/models/axes", {"joints": [{"type": "R", "h": [1, 1, 0]}]}, "invalid-axes-model", "joints[0].h"),
    ("/models/axes", [1, 2], "validation-error", "must be a JSON object"),
])
def test_description_errors(api_client, path, payload, slug, detail):
    r = api_client.post(path, json=payload)
    assert r.status_code == 422, r.text
    assert r.json()["type"] == f"urn:kinematics:problem:{slug}" and detail in r.json()["detail"]


def test_openapi_documents_the_new_routes(api_client):
    paths = api_client.get("/openapi.json").json()["paths"]
    assert {"/models/poe", "/models/axes", "/symbolic/dh", "/models/{model_id}/symbolic",
            "/models/{model_id}/task"} <= set(paths)
