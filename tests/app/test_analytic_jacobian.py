"""POST /models/{id}/jacobian with ``representation``: the analytic Jacobian J_r = dr/dq and r,
in JSON and .npy, equal to POST /models/{id}/task and to central finite differences of r."""

from __future__ import annotations

import io

import numpy as np
import pytest

from kinematics import default_catalogue
from tests.helpers import npy_bytes

PROBLEM = "application/problem+json"
NPY = "application/x-npy"
REPRESENTATIONS = ["rpy", "zyx", "zyz", "quaternion", "rotvec"]


def _configurations(rng, n=6):
    return default_catalogue().get("ur5").sample_configurations(n, rng)


def _task_r(client, Q, rep, **extra):
    r = client.post("/models/ur5/task", json={"q": Q.tolist(), "link": "tool0", "representation": rep, **extra})
    assert r.status_code == 200, r.text
    return np.array(r.json()["r"]), np.array(r.json()["J_r"])


def _central_differences(client, Q, rep, h=1e-6, **extra):
    """dr/dq by central differences of r from the task route (angles unwrapped)."""
    n = Q.shape[1]
    out = []
    for q in Q:
        plus = np.array([q + h * e for e in np.eye(n)])
        minus = np.array([q - h * e for e in np.eye(n)])
        rp, _ = _task_r(client, plus, rep, **extra)
        rm, _ = _task_r(client, minus, rep, **extra)
        d = rp - rm
        if rep in ("rpy", "zyx", "zyz"):
            d[:, 3:] = (d[:, 3:] + np.pi) % (2 * np.pi) - np.pi
        out.append(d.T / (2 * h))
    return np.array(out)


@pytest.mark.parametrize("rep", REPRESENTATIONS)
def test_json_equals_the_task_route_and_finite_differences(api_client, rng, rep):
    Q = _configurations(rng)
    r = api_client.post("/models/ur5/jacobian", json={"q": Q.tolist(), "link": "tool0", "representation": rep})
    assert r.status_code == 200, r.text
    body = r.json()
    J_r, rv = np.array(body["jacobian"]), np.array(body["r"])
    assert J_r.shape == (len(Q), 7 if rep == "quaternion" else 6, 6)
    assert body["representation"] == rep and body["reference"] == "local_world_aligned"
    assert body["components"][:3] == ["px", "py", "pz"] and len(body["components"]) == J_r.shape[1]
    r_task, J_task = _task_r(api_client, Q, rep)
    np.testing.assert_array_equal(J_r, J_task)  # the same use case: the same bits
    np.testing.assert_array_equal(rv, r_task)
    fd = _central_differences(api_client, Q, rep)
    worst = np.abs(J_r - fd).max()
    print(f"{rep}: analytic vs central differences (h = 1e-6), worst |dJ| = {worst:.2e}")
    assert worst < 1e-7
    assert len(body["singular_values"]) == len(Q) and len(body["condition_number"]) == len(Q)


def test_one_configuration_components_and_a_point(api_client, rng):
    q = _configurations(rng, 1)[0]
    req = {"q": q.tolist(), "link": "tool0", "representation": "zyx", "components": ["px", "py", "alpha_z"],
           "point": [0, 0, 0.1]}
    r = api_client.post("/models/ur5/jacobian", json=req)
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["components"] == ["px", "py", "alpha_z"] and np.shape(body["jacobian"]) == (3, 6)
    assert np.shape(body["r"]) == (3,) and isinstance(body["manipulability"], float)
    h = 1e-6  # central differences of the FK route's pose of the point frame
    cols = []
    for e in np.eye(6):
        ends = []
        for sign in (1, -1):
            f = api_client.post("/models/ur5/fk", json={"q": (q + sign * h * e).tolist(), "links": ["tool0"],
                                                        "point": [0, 0, 0.1]}).json()["poses"]["tool0"]
            ends.append(np.array([*f["position"][:2], f["rpy"][2]]))
        d = ends[0] - ends[1]
        d[2] = (d[2] + np.pi) % (2 * np.pi) - np.pi
        cols.append(d / (2 * h))
    np.testing.assert_allclose(body["jacobian"], np.array(cols).T, atol=1e-7)
    f0 = api_client.post("/models/ur5/fk", json={"q": q.tolist(), "links": ["tool0"], "point": [0, 0, 0.1]}).json()
    pose = f0["poses"]["tool0"]
    np.testing.assert_allclose(body["r"], [*pose["position"][:2], pose["rpy"][2]], atol=1e-12)


@pytest.mark.parametrize("rep", ["rpy", "quaternion"])
def test_npy_equals_json(api_client, rng, rep):
    Q = _configurations(rng, 5)
    r = api_client.post(f"/models/ur5/jacobian?link=tool0&representation={rep}", content=npy_bytes(Q),
                        headers={"Content-Type": NPY, "Accept": NPY})
    assert r.status_code == 200, r.text
    out = np.load(io.BytesIO(r.content), allow_pickle=False)
    m = 7 if rep == "quaternion" else 6
    assert out.shape == (5, m, 7)  # [J_r | r]
    body = api_client.post("/models/ur5/jacobian", json={"q": Q.tolist(), "link": "tool0",
                                                         "representation": rep}).json()
    np.testing.assert_array_equal(out[:, :, :6], body["jacobian"])
    np.testing.assert_array_equal(out[:, :, 6], body["r"])
    assert r.headers["X-Representation"] == rep and r.headers["X-Components"] == ",".join(body["components"])
    assert r.headers["X-Link"] == "tool0" and r.headers["X-Reference"] == "local_world_aligned"
    # components, repeated or comma-separated
    r = api_client.post("/models/ur5/jacobian?link=tool0&representation=rpy&components=pz,yaw&components=px",
                        content=npy_bytes(Q), headers={"Content-Type": NPY, "Accept": NPY})
    assert r.status_code == 200, r.text
    assert np.load(io.BytesIO(r.content)).shape == (5, 3, 7) and r.headers["X-Components"] == "pz,yaw,px"


def test_rpy_gimbal_lock_is_a_problem_as_on_the_task_route(api_client, rng):
    """A base pose that turns the UR5's tool0 to pitch = +90 degrees at the first configuration."""
    from kinematics import api

    Q = _configurations(rng, 2)
    R0 = api.fk(default_catalogue().get("ur5"), Q[0], links=["tool0"]).poses[0, 0, :3, :3]
    base = np.eye(4)
    base[:3, :3] = np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]) @ R0.T  # Ry(pi/2) R0^-1
    req = {"q": Q.tolist(), "link": "tool0", "representation": "rpy", "base": base.tolist()}
    r = api_client.post("/models/ur5/jacobian", json=req)
    t = api_client.post("/models/ur5/task", json=req)
    assert r.status_code == t.status_code == 422 and r.headers["content-type"] == PROBLEM
    assert r.json()["type"] == t.json()["type"] == "urn:kinematics:problem:representation-singularity"
    assert "configuration 0" in r.json()["detail"] and "gimbal lock" in r.json()["detail"]
    assert r.json()["detail"] == t.json()["detail"]
    # yaw needs E^-1 too; the position rows alone are fine there
    r = api_client.post("/models/ur5/jacobian", json={**req, "components": ["px", "yaw"]})
    assert r.status_code == 422
    r = api_client.post("/models/ur5/jacobian", json={**req, "components": ["px", "py", "pz"]})
    assert r.status_code == 200 and np.isfinite(r.json()["jacobian"]).all()
    # .npy: ZYZ at theta = 0 (the SCARA's tool at q = 0)
    n = api_client.post("/models/scara/jacobian?representation=zyz", content=npy_bytes([[0.1, 0.2, 0.0, 0.3], [0] * 4]),
                        headers={"Content-Type": NPY, "Accept": NPY})
    assert n.status_code == 422 and n.json()["type"].endswith("representation-singularity")


def test_every_schema_valid_combination_is_answered(api_client):
    """J_r = dr/dq is built from the local_world_aligned Jacobian: another ``reference`` is refused; ``components``
    alone asks the default task (rpy, as /task); ``verify`` checks the geometric Jacobian J_r is
    built from; ``floating_base`` is refused by the library (task vectors need one-dof joints)."""
    q = {"q": [0.1] * 6}
    base = api_client.post("/models/ur5/jacobian", json={**q, "representation": "rpy"}).json()
    r = api_client.post("/models/ur5/jacobian", json={**q, "representation": "rpy", "reference": "local_world_aligned"})
    assert r.status_code == 200 and r.json()["jacobian"] == base["jacobian"]
    assert base["reference"] == r.json()["reference"] == "local_world_aligned"
    for reference in ("world", "local"):  # asked for, so refused rather than changed quietly
        r = api_client.post("/models/ur5/jacobian", json={**q, "representation": "rpy", "reference": reference})
        assert r.status_code == 422 and f"reference {reference!r} with representation" in r.json()["detail"]
    alone = api_client.post("/models/ur5/jacobian", json={**q, "components": ["px", "yaw"]}).json()
    assert alone["representation"] == "rpy" and alone["components"] == ["px", "yaw"]
    assert alone["jacobian"] == [base["jacobian"][0], base["jacobian"][5]]
    checked = api_client.post("/models/ur5/jacobian", json={**q, "representation": "rpy", "verify": True}).json()
    assert checked["jacobian"] == base["jacobian"]
    assert checked["verification"]["max_jacobian_error"] < 1e-9
    n = api_client.post("/models/ur5/jacobian?representation=rpy&verify=true", content=npy_bytes([0.1] * 6),
                        headers={"Content-Type": NPY, "Accept": NPY})
    assert n.status_code == 200 and float(n.headers["X-Max-Jacobian-Error"]) < 1e-9
    fb = api_client.post("/models/ur5/jacobian", json={**q, "representation": "rpy", "floating_base": True,
                                                       "q": [0, 0, 0, 0, 0, 0, 1] + [0.1] * 6})
    assert fb.status_code == 422 and "floating" in fb.json()["detail"], fb.text


def test_explicit_local_world_aligned_and_bad_components(api_client):
    ok = api_client.post("/models/ur5/jacobian", json={"q": [0.1] * 6, "representation": "rotvec",
                                                       "reference": "local_world_aligned"})
    assert ok.status_code == 200
    bad = api_client.post("/models/ur5/jacobian", json={"q": [0.1] * 6, "representation": "rpy",
                                                        "components": ["qw"]})
    assert bad.status_code == 422 and bad.json()["type"].endswith("invalid-task-representation")
    bad = api_client.post("/models/ur5/jacobian?representation=euler", content=npy_bytes([0.1] * 6),
                          headers={"Content-Type": NPY})
    assert bad.status_code == 422
    plain = api_client.post("/models/ur5/jacobian", json={"q": [0.1] * 6})
    assert plain.json()["reference"] == "world" and "representation" not in plain.json()
