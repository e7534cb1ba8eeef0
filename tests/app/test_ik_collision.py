"""Collision-free answers over HTTP: avoid_collisions on POST /models/{id}/ik (JSON, .npy in and
.npz out) and /ik/path, collision_free on /workspace; IK of a model the service calibrated."""

from __future__ import annotations

import io

import numpy as np
import pytest

from kinematics import usecases
from kinematics.engine.poe import compile_model

SAMPLES = 300


@pytest.fixture
def client(make_client):
    return make_client(collision_samples=SAMPLES)


def _pose(T):
    return [list(map(float, row)) for row in T]


def _ur5_targets(catalogue, n=30, seed=0):
    model = catalogue.get("ur5")
    Q = model.sample_configurations(n, np.random.default_rng(seed))
    return model, compile_model(model).fk(Q, ["tool0"])[:, 0]


def test_ik_all_lists_only_the_free_solutions(client, catalogue):
    model, T = _ur5_targets(catalogue)
    lib = usecases.ik(model, T, link="tool0", solutions="all", avoid_collisions=True, collision_samples=SAMPLES)
    assert lib.colliding.sum() > 0
    r = client.post("/models/ur5/ik", json={"link": "tool0", "target": [_pose(t) for t in T], "solutions": "all",
                                            "avoid_collisions": True})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["count"] == lib.count.tolist() and body["colliding"] == lib.colliding.tolist()
    for n in range(len(T)):
        got = np.array([s["q"] for s in body["solutions"][n]]).reshape(-1, model.dof)
        np.testing.assert_allclose(got, lib.q[n, :lib.count[n]], atol=1e-12)
    free = client.post("/models/ur5/collision", json={"q": [s["q"] for row in body["solutions"] for s in row]}).json()
    assert not any(free["colliding"])
    plain = client.post("/models/ur5/ik", json={"link": "tool0", "target": [_pose(t) for t in T], "solutions": "all"})
    assert plain.json()["colliding"] is None
    assert np.all(np.array(plain.json()["count"]) == lib.count + lib.colliding)


def test_npy_in_npz_out_with_the_query_parameter(client, catalogue):
    model, T = _ur5_targets(catalogue, 8)
    buf = io.BytesIO()
    np.save(buf, T)
    lib = usecases.ik(model, T, link="tool0", solutions="all", avoid_collisions=True, collision_samples=SAMPLES)
    r = client.post("/models/ur5/ik?link=tool0&solutions=all&avoid_collisions=true", content=buf.getvalue(),
                    headers={"Content-Type": "application/x-npy", "Accept": "application/x-npz"})
    assert r.status_code == 200, r.text
    npz = np.load(io.BytesIO(r.content), allow_pickle=False)
    assert npz["count"].tolist() == lib.count.tolist() and npz["colliding"].tolist() == lib.colliding.tolist()
    one = client.post("/models/ur5/ik?link=tool0&avoid_collisions=true", content=buf.getvalue(),
                      headers={"Content-Type": "application/x-npy", "Accept": "application/x-npz"})
    assert one.status_code == 200, one.text
    npz = np.load(io.BytesIO(one.content), allow_pickle=False)
    assert "collision_free" in npz.files and np.all(npz["success"] <= npz["collision_free"])


def test_one_answer_is_free(client, catalogue):
    model, T = _ur5_targets(catalogue, 10, seed=4)
    r = client.post("/models/ur5/ik", json={"link": "tool0", "target": [_pose(t) for t in T], "avoid_collisions": True})
    assert r.status_code == 200, r.text
    body = r.json()
    # a success wherever the full set holds a free solution inside the limits, none elsewhere
    full = usecases.ik(model, T, link="tool0", solutions="all", avoid_collisions=True, collision_samples=SAMPLES)
    assert body["success"] == (full.count > 0).tolist() and any(body["success"])
    assert all(f for f, ok in zip(body["collision_free"], body["success"]) if ok)
    check = client.post("/models/ur5/collision", json={"q": body["q"]}).json()
    assert [not c for c in check["colliding"]] == body["collision_free"]
    assert client.post("/models/ur5/ik", json={"link": "tool0", "target": _pose(T[0])}).json()["collision_free"] is None


def test_a_path_stops_with_reason_collision(client, catalogue):
    model = catalogue.get("ur5")
    q0, q1 = [0, -1.0, 1.5, 0, 0, 0], [0, -1.0, 2.9, 0, 0, 0]
    W = compile_model(model).fk(np.array([q0, q1], dtype=float), ["tool0"])[:, 0]
    req = {"link": "tool0", "seed": q0, "waypoints": [_pose(W[0]), _pose(W[1])], "step": {"position": 0.01}}
    plain = client.post("/models/ur5/ik/path", json=req).json()
    r = client.post("/models/ur5/ik/path", json={**req, "avoid_collisions": True})
    assert r.status_code == 200, r.text
    body = r.json()
    lib = usecases.ik_path(model, W, link="tool0", seed=q0, step={"position": 0.01}, avoid_collisions=True,
                           collision_samples=SAMPLES)
    assert body["stopped"] == {"index": lib.stopped["index"], "reason": "collision"} and not body["complete"]
    k = body["stopped"]["index"]
    assert len(body["q"]) == k and plain["complete"] and np.allclose(body["q"], plain["q"][:k])
    assert client.post("/models/ur5/collision", json={"q": plain["q"][k]}).json()["colliding"] is True


def test_workspace_collision_free(client):
    plain = client.post("/models/ur5/workspace", json={"link": "tool0", "samples": 2000}).json()
    r = client.post("/models/ur5/workspace", json={"link": "tool0", "samples": 2000, "collision_free": True})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["collision_free"] and body["dropped"] > 0 and body["samples"] + body["dropped"] == 2000
    assert plain["collision_free"] is False and plain["dropped"] == 0 and plain["samples"] == 2000
    npz = client.post("/models/ur5/workspace", json={"link": "tool0", "samples": 2000, "collision_free": True},
                      headers={"Accept": "application/x-npz"})
    arrays = np.load(io.BytesIO(npz.content), allow_pickle=False)
    assert arrays["points"].shape == (body["samples"], 3) and int(arrays["dropped"]) == body["dropped"]


@pytest.mark.parametrize("path, extra", [
    ("ik", {"target": {"xyz": [0.4, 0.1, 0.3], "rpy": [3.14159, 0, 0]}, "avoid_collisions": True}),
    ("ik", {"target": {"xyz": [0.4, 0.1, 0.3], "rpy": [3.14159, 0, 0]}, "avoid_collisions": True, "solutions": "all"}),
    ("ik/path", {"waypoints": [{"xyz": [0.4, 0.1, 0.3], "rpy": [0, 0, 0]}, {"xyz": [0.4, 0.1, 0.31], "rpy": [0, 0, 0]}],
                 "avoid_collisions": True}),
    ("workspace", {"samples": 10, "collision_free": True}),
])
def test_a_model_without_collision_geometry_is_a_422_naming_it(client, path, extra):
    r = client.post(f"/models/puma560_standard/{path}", json=extra)
    assert r.status_code == 422 and r.headers["content-type"].startswith("application/problem+json"), r.text
    assert "no collision geometry" in r.json()["detail"] and "puma560_standard" in r.json()["detail"]


def test_bad_flags_are_422(client):
    r = client.post("/models/ur5/ik", json={"target": {"xyz": [0.4, 0.1, 0.3], "rpy": [0, 0, 0]},
                                            "avoid_collisions": "yes"})
    assert r.status_code == 422


def test_a_model_calibrated_by_the_service_gets_every_solution(client, catalogue):
    """POST /models/ur5/calibrate, then every IK solution of the new model: each generating
    configuration listed, each solution exact for Pinocchio."""
    from kinematics.algorithms.calibration.synthetic import experiment

    model = catalogue.get("ur5")
    rng = np.random.default_rng(11)
    truth, Q, P = experiment(model, "tool0", "position", 60, rng)
    r = client.post("/models/ur5/calibrate", json={
        "link": "tool0", "measurements": [{"q": q.tolist(), "position": p.tolist()} for q, p in zip(Q, P)]})
    assert r.status_code == 201, r.text
    new = r.json()["model"]
    fam = client.get(f"/models/{new}/ik/family", params={"link": "tool0"}).json()
    assert fam["family"] == "three_parallel" and fam["near"]
    Qg = model.sample_configurations(20, np.random.default_rng(2))
    poses = client.post(f"/models/{new}/fk", json={"q": Qg.tolist(), "links": ["tool0"]}).json()["poses"]
    targets = [{"position": p["tool0"]["position"], "quaternion": p["tool0"]["quaternion"]} for p in poses]
    ik = client.post(f"/models/{new}/ik", json={"link": "tool0", "target": targets, "solutions": "all",
                                                  "verify": True})
    assert ik.status_code == 200, ik.text
    body = ik.json()
    assert body["verification"]["max_position_error"] < 1e-9 and body["verification"]["max_rotation_error"] < 1e-9
    for q, sols in zip(Qg, body["solutions"]):
        got = np.array([s["q"] for s in sols])
        assert np.abs(got - q).max(axis=1).min() < 1e-7  # the generating configuration is listed
        assert all(s["position_error"] < 1e-9 and s["rotation_error"] < 1e-9 for s in sols)
