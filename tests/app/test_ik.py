"""POST /models/{id}/ik: JSON and .npy/.npz transports, honest success, 4xx for bad input, 413 for work."""

from __future__ import annotations

import io

import numpy as np
import pytest

from kinematics import compile_model
from kinematics.algorithms.ik import pose_errors
from kinematics.spatial.transforms import pose_components

PROBLEM = "application/problem+json"


def _targets(model, n, seed=3):
    Q = model.sample_configurations(n, np.random.default_rng(seed))
    return compile_model(model).fk(Q, ["tool0"])[:, 0]


def _pose(T):
    c = pose_components(T)
    w, x, y, z = c["quaternion"].tolist()
    return {"position": c["position"].tolist(), "quaternion": {"w": w, "x": x, "y": y, "z": z}}


def test_one_target_json(api_client, ur5):
    T = _targets(ur5, 1)
    r = api_client.post("/models/ur5/ik", json={"link": "tool0", "target": _pose(T[0]), "verify": True})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["success"] is True and body["joint_names"] == list(ur5.joint_names) and len(body["q"]) == 6
    assert body["position_error"] <= 1e-6 and body["rotation_error"] <= 1e-6 and body["iterations"] >= 0
    position, rotation = pose_errors(compile_model(ur5).fk(np.array([body["q"]]), ["tool0"])[:, 0], T)
    assert position[0] <= 1e-6 and rotation[0] <= 1e-6
    assert body["verification"]["position_error"] <= 1e-6 and body["verification"]["reference"].startswith("pinocchio")


def test_batch_json_with_an_unreachable_target(api_client, ur5):
    T = _targets(ur5, 3)
    targets = [_pose(T[0]), T[1].tolist(), {"xyz": [4.0, 0.0, 0.0], "rpy": [0, 0, 0]}, _pose(T[2])]
    r = api_client.post("/models/ur5/ik", json={"target": targets, "max_iterations": 50, "restarts": 2})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["success"] == [True, True, False, True]
    assert len(body["q"]) == 4 and all(np.isfinite(body["q"][2]))
    assert body["position_error"][2] > 2.5 and 0 < body["iterations"][2] <= 3 * 50


def test_npy_in_npz_out(api_client, ur5):
    T = _targets(ur5, 5)
    buf = io.BytesIO()
    np.save(buf, T)
    r = api_client.post("/models/ur5/ik?link=tool0&random_seed=4", content=buf.getvalue(),
                        headers={"Content-Type": "application/x-npy", "Accept": "application/x-npz"})
    assert r.status_code == 200 and r.headers["content-type"] == "application/x-npz"
    npz = np.load(io.BytesIO(r.content), allow_pickle=False)
    assert npz["q"].shape == (5, 6) and npz["success"].dtype == bool and npz["success"].all()
    assert r.headers["X-Link"] == "tool0" and r.headers["X-Joint-Names"].split(",")[0] == "shoulder_pan_joint"
    # the same answers as the JSON route (same inputs, same random seed)
    js = api_client.post("/models/ur5/ik", json={"link": "tool0", "target": T.tolist(), "random_seed": 4}).json()
    np.testing.assert_array_equal(npz["q"], np.array(js["q"]))


@pytest.mark.parametrize("body, status, fragment", [
    ({"target": {"xyz": [0.1, 0.2], "rpy": [0, 0, 0]}}, 422, "target"),
    ({"target": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 3, 0], [0, 0, 0, 1]]}, 422, "rigid"),
    ({"target": {"xyz": [0.4, 0.1, 0.3], "rpy": [0, 0, 0]}, "seed": [0, 0]}, 422, "seed"),
    ({"target": {"xyz": [0.4, 0.1, 0.3], "rpy": [0, 0, 0]}, "link": "nope"}, 404, "nope"),
    ({"target": {"xyz": [0.4, 0.1, 0.3], "rpy": [0, 0, 0]}, "mode": "twist"}, 422, "mode"),
    ({"target": {"xyz": [0.4, 0.1, 0.3], "rpy": [0, 0, 0]}, "tolerance": {"position": 0}}, 422, "tolerance"),
    ({"target": {"xyz": [0.4, 0.1, 0.3], "rpy": [0, 0, 0]}, "max_iterations": 0}, 422, "max_iterations"),
    ({}, 422, "target"),
])
def test_bad_requests_are_4xx_naming_the_problem(api_client, body, status, fragment):
    r = api_client.post("/models/ur5/ik", json=body)
    assert r.status_code == status and r.headers["content-type"] == PROBLEM, r.text
    assert fragment in r.text


def test_nan_in_npy_targets_is_refused(api_client):
    buf = io.BytesIO()
    np.save(buf, np.full((2, 4, 4), np.nan))
    r = api_client.post("/models/ur5/ik", content=buf.getvalue(), headers={"Content-Type": "application/x-npy"})
    assert r.status_code == 422 and "target[0]" in r.json()["detail"]
    buf = io.BytesIO()
    np.save(buf, np.zeros((2, 3, 3)))
    r = api_client.post("/models/ur5/ik", content=buf.getvalue(), headers={"Content-Type": "application/x-npy"})
    assert r.status_code == 422 and "(N, 4, 4)" in r.json()["detail"]


def test_work_over_the_budget_is_413_naming_the_setting(make_client):
    client = make_client(max_ik_work=1000)
    target = {"xyz": [0.4, 0.1, 0.3], "rpy": [0, 0, 0]}
    r = client.post("/models/ur5/ik", json={"target": [target] * 3, "max_iterations": 100, "restarts": 3})
    assert r.status_code == 413 and r.json()["type"].endswith("ik-work-too-large")
    assert "max_ik_work" in r.json()["detail"] and r.json()["limit"] == 1000
    assert client.post("/models/ur5/ik", json={"target": target, "max_iterations": 100, "restarts": 9}).status_code == 200
