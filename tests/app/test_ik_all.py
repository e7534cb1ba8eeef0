"""Every IK solution over HTTP: POST /models/{id}/ik with solutions "all" (JSON, .npy in with
locked query parameters, .npz out), GET /models/{id}/ik/family, POST /models/{id}/ik/path, and the
4xx answers for bad locked joints."""

from __future__ import annotations

import io

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue
from kinematics.algorithms.ik import pose_errors
from kinematics.spatial.transforms import pose_components

PROBLEM = "application/problem+json"
Q0 = [0.3, -1.0, 1.2, -0.5, 0.8, 0.2]


@pytest.fixture(scope="module")
def ur5():
    return default_catalogue().get("ur5")


def _pose(T):
    c = pose_components(T)
    w, x, y, z = c["quaternion"].tolist()
    return {"position": c["position"].tolist(), "quaternion": {"w": w, "x": x, "y": y, "z": z}}


def _T(model, q, link="tool0"):
    return compile_model(model).fk(np.atleast_2d(np.asarray(q, float)), [link])[:, 0]


def test_all_solutions_json(api_client, ur5):
    T = _T(ur5, Q0)
    r = api_client.post("/models/ur5/ik", json={"link": "tool0", "target": _pose(T[0]), "solutions": "all",
                                                 "limits": "ignore", "seed": Q0, "verify": True})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["family"] == "three_parallel" and body["method"] == "analytic" and body["count"] == 8
    assert len(body["solutions"]) == 8
    first = body["solutions"][0]
    assert set(first) == {"q", "position_error", "rotation_error", "within_limits", "singular"}
    np.testing.assert_allclose(first["q"], Q0, atol=1e-9)  # nearest the seed first
    Q = np.array([s["q"] for s in body["solutions"]])
    p, rot = pose_errors(compile_model(ur5).fk(Q, ["tool0"])[:, 0], np.repeat(T, 8, 0))
    assert p.max() < 1e-9 and rot.max() < 1e-9
    assert body["verification"]["max_position_error"] < 1e-9


def test_batch_json_and_respect(api_client, ur5):
    T = _T(ur5, [Q0, [0.1, -1.5, 1.0, 0.2, 1.1, -0.4]])
    r = api_client.post("/models/ur5/ik", json={"link": "tool0", "target": [_pose(t) for t in T], "solutions": "all"})
    assert r.status_code == 200, r.text
    body = r.json()
    assert isinstance(body["count"], list) and len(body["solutions"]) == 2
    assert all(c > 8 for c in body["count"])  # UR's ±2π joints: copies of each branch
    assert all(s["within_limits"] for sols in body["solutions"] for s in sols)


def test_npy_in_npz_out_with_locked(api_client):
    panda = default_catalogue().get("panda")
    q = np.array([0.1, -0.4, 0.2, -2.0, 0.3, 1.5, 0.7, 0.02])
    T = _T(panda, q, "panda_link8")
    buf = io.BytesIO(); np.save(buf, T)
    r = api_client.post("/models/panda/ik?link=panda_link8&solutions=all&limits=ignore&locked=panda_joint7:0.7",
                        content=buf.getvalue(),
                        headers={"Content-Type": "application/x-npy", "Accept": "application/x-npz"})
    assert r.status_code == 200, r.text
    npz = np.load(io.BytesIO(r.content), allow_pickle=False)
    assert set(npz.files) == {"q", "count", "within_limits", "singular", "position_error", "rotation_error"}
    k = int(npz["count"][0])
    assert npz["q"].shape[0] == 1 and npz["q"].shape[2] == panda.dof and k >= 1
    assert np.all(npz["q"][0, :k, 6] == 0.7)
    d = np.abs(np.mod(npz["q"][0, :k, :6] - q[:6] + np.pi, 2 * np.pi) - np.pi).max(axis=1)
    assert d.min() < 1e-9
    assert r.headers["X-Family"] == "spherical_shoulder_intersecting_12"


@pytest.mark.parametrize("locked, joint", [({"panda_joint9": 0.1}, "panda_joint9"), ({"panda_joint7": 9.0}, "panda_joint7")])
def test_bad_locked_joints_are_422_naming_them(api_client, locked, joint):
    r = api_client.post("/models/panda/ik", json={"link": "panda_link8", "target": np.eye(4).tolist(),
                                                   "solutions": "all", "locked": locked})
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM
    assert r.json()["joint"] == joint and r.json()["field"] == "locked" and joint in r.json()["detail"]
    r = api_client.get(f"/models/panda/ik/family?link=panda_link8&locked={joint}:{list(locked.values())[0]}")
    assert r.status_code == 422 and r.json()["joint"] == joint
    r = api_client.get("/models/panda/ik/family?locked=nonsense")
    assert r.status_code == 422 and r.json()["field"].startswith("locked")  # the schema's joint:value pattern


def test_redundant_chain_all_is_422(api_client):
    r = api_client.post("/models/panda/ik", json={"link": "panda_link8", "target": np.eye(4).tolist(), "solutions": "all"})
    assert r.status_code == 422 and "infinitely many" in r.json()["detail"]


def test_family_endpoint(api_client):
    r = api_client.get("/models/ur5/ik/family?link=tool0")
    assert r.status_code == 200
    body = r.json()
    assert {k: body[k] for k in ("link", "family", "closed_form", "max_solutions", "locked")} == {
        "link": "tool0", "family": "three_parallel", "closed_form": True, "max_solutions": 8, "locked": {}}
    assert len(body["joints"]) == 6
    r = api_client.get("/models/panda/ik/family?link=panda_link8&locked=panda_joint7:0")
    assert r.json()["family"] == "spherical_shoulder_intersecting_12" and r.json()["locked"] == {"panda_joint7": 0.0}
    assert api_client.get("/models/ur5/ik/family?link=nope").status_code == 404


def test_path_complete_and_stopped(api_client, ur5):
    T0 = _T(ur5, Q0)[0]
    T1 = T0.copy(); T1[:3, 3] += [0.05, 0.05, -0.05]
    r = api_client.post("/models/ur5/ik/path", json={"link": "tool0", "waypoints": [T0.tolist(), T1.tolist()],
                                                      "seed": Q0, "step": {"position": 0.01, "rotation": 0.05}})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["complete"] is True and body["stopped"] is None and body["fraction"] == 1.0
    assert len(body["q"]) == len(body["targets"]) >= 9 and body["max_joint_step"] <= 0.3
    np.testing.assert_allclose(body["q"][0], Q0, atol=1e-9)
    assert max(body["position_error"]) < 1e-9
    far = T0.copy(); far[:3, 3] = [2.0, 0.0, 0.3]
    r = api_client.post("/models/ur5/ik/path", json={"link": "tool0", "waypoints": [T0.tolist(), far.tolist()],
                                                      "seed": Q0})
    body = r.json()
    assert body["complete"] is False and body["stopped"]["reason"] == "unreachable"
    assert 0 < body["fraction"] < 1 and len(body["q"]) == body["stopped"]["index"]
    r = api_client.post("/models/ur5/ik/path", json={"waypoints": [T0.tolist()]})
    assert r.status_code == 422
