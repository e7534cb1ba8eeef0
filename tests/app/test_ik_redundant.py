"""A 7-joint arm's self-motion over HTTP: POST /models/{id}/ik with solutions "all" and redundancy
(slices at values, .npz parameter, the best point with intervals), GET /models/{id}/ik/family's
redundancy fields, and the 4xx answers naming bad redundancy requests."""

from __future__ import annotations

import io

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue
from kinematics.algorithms.ik import pose_errors
from kinematics.spatial.transforms import pose_components

PROBLEM = "application/problem+json"
Q0 = [0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.7, 0.0]
LINK = "panda_link8"


def _pose(T):
    c = pose_components(T)
    w, x, y, z = c["quaternion"].tolist()
    return {"position": c["position"].tolist(), "quaternion": {"w": w, "x": x, "y": y, "z": z}}


@pytest.fixture(scope="module")
def panda_target():
    model = default_catalogue().get("panda")
    return model, compile_model(model).fk(np.array([Q0]), [LINK])[:, 0]


def test_slices_each_with_its_parameter(api_client, panda_target):
    model, T = panda_target
    r = api_client.post("/models/panda/ik", json={"link": LINK, "target": _pose(T[0]), "solutions": "all",
                                                  "redundancy": {"values": [0.7, 1.2]}})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["parameter"] == {"joint": "panda_joint7"} and body["count"] == len(body["solutions"]) > 0
    values = {s["parameter"] for s in body["solutions"]}
    assert values <= {0.7, 1.2} and 0.7 in values
    for s in body["solutions"]:
        assert s["q"][6] == s["parameter"] and s["within_limits"]
        p, rot = pose_errors(compile_model(model).fk(np.array([s["q"]]), [LINK])[:, 0], T)
        assert p[0] < 1e-9 and rot[0] < 1e-9
    # the generating configuration is among them
    assert min(np.abs(np.array(s["q"][:7]) - Q0[:7]).max() for s in body["solutions"]) < 1e-8


def test_npz_carries_the_parameter(api_client, panda_target):
    _, T = panda_target
    r = api_client.post("/models/panda/ik", json={"link": LINK, "target": [_pose(T[0])] * 2, "solutions": "all",
                                                  "redundancy": {"parameter": {"joint": "panda_joint7"},
                                                                 "values": [[0.7], [1.2]]}},
                        headers={"Accept": "application/x-npz"})
    assert r.status_code == 200, r.text
    npz = np.load(io.BytesIO(r.content), allow_pickle=False)
    assert npz["parameter"].shape == npz["q"].shape[:2]
    for n, v in enumerate((0.7, 1.2)):
        k = int(npz["count"][n])
        assert k > 0 and np.all(npz["parameter"][n, :k] == v) and np.all(np.isnan(npz["parameter"][n, k:]))


def test_family_names_the_redundancy(api_client):
    body = api_client.get(f"/models/panda/ik/family?link={LINK}").json()
    assert body["redundant"] is True and body["default_parameter"] == {"joint": "panda_joint7"}
    assert {"joint": "panda_joint7", "family": "spherical_shoulder_intersecting_12"} in body["parameters"]
    assert api_client.get("/models/ur5/ik/family?link=tool0").json()["redundant"] is False


@pytest.mark.parametrize("redundancy, status, words", [
    ({"parameter": {"joint": "nope"}, "values": [0.1]}, 422, "nope"),
    ({"parameter": {"joint": "panda_finger_joint1"}, "values": [0.1]}, 422, "not a free joint"),
    ({"values": [0.1], "select": "best"}, 422, "select"),
    ({"values": [[0.1], [0.2], [0.3]]}, 422, "3 lists for 1 targets"),
    ({}, 422, "give values"),
    ({"parameter": "sew", "values": [0.1]}, 422, "sew"),
])
def test_bad_redundancy_is_a_4xx_naming_it(api_client, panda_target, redundancy, status, words):
    _, T = panda_target
    r = api_client.post("/models/panda/ik", json={"link": LINK, "target": _pose(T[0]), "solutions": "all",
                                                  "redundancy": redundancy})
    assert r.status_code == status, r.text
    assert words in r.text


def test_redundancy_on_a_chain_that_is_not_redundant(api_client):
    T = compile_model(default_catalogue().get("ur5")).fk(np.zeros((1, 6)), ["tool0"])[:, 0]
    r = api_client.post("/models/ur5/ik", json={"link": "tool0", "target": _pose(T[0]), "solutions": "all",
                                                "redundancy": {"values": [0.1]}})
    assert r.status_code == 422 and "not redundant" in r.text


def test_too_many_values_is_413(api_client, panda_target, monkeypatch):
    from kinematics.algorithms import ik_redundant

    monkeypatch.setattr(ik_redundant, "MAX_PAIRS", 10)
    _, T = panda_target
    r = api_client.post("/models/panda/ik", json={"link": LINK, "target": _pose(T[0]), "solutions": "all",
                                                  "redundancy": {"values": list(np.linspace(-1, 1, 11))}})
    assert r.status_code == 413 and "redundancy.values" in r.text
