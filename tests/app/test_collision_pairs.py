"""The link pairs a user allows and forbids: per request (``allow`` / ``forbid`` of
``/collision``, ``/collision/matrix`` and collision-avoiding IK) and per model
(``PUT /models/{id}/collision/pairs``), reported as ``user`` and exported in the SRDF."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from fastapi.testclient import TestClient

from kinematics.algorithms import self_collision

SAMPLES = 400
#: a configuration where (base_link, upper_arm_link) collides (MoveIt's UR5 SRDF calls the pair "never")
BASE_UPPER_ARM = [-3.58, 1.75, 1.92, 5.83, -4.39, -0.22]
FOLDED = [0, -1.0, 2.9, 0, 0, 0]


@pytest.fixture
def client(api_data_dir, monkeypatch):
    monkeypatch.setenv("KIN_DATA_DIR", str(api_data_dir))
    monkeypatch.setenv("KIN_COLLISION_SAMPLES", str(SAMPLES))
    from app.main import create_app

    with TestClient(create_app()) as c:
        yield c


def _never_pair_that_collides(model):
    """A pair the matrix (SAMPLES configurations) calls never, and a configuration where it collides."""
    matrix = self_collision.matrix(model, SAMPLES)
    cm = self_collision.geometry(model)
    Q = model.sample_configurations(4000, np.random.default_rng(3), continuous_range=np.pi)
    for pair, reason in matrix.disabled.items():
        if reason == "never":
            hit = np.nonzero(cm.check(Q, [pair]).colliding)[0]
            if hit.size:
                return pair, Q[hit[0]].tolist()
    pytest.fail("no never pair of the sampled matrix collides in 4000 configurations")


def test_a_request_allows_and_forbids_pairs(client, catalogue):
    plain = client.post("/models/ur5/collision", json={"q": BASE_UPPER_ARM}).json()
    assert ["base_link", "upper_arm_link"] in plain["pairs"]
    allowed = client.post("/models/ur5/collision", json={"q": BASE_UPPER_ARM,
                                                         "allow": [["upper_arm_link", "base_link"]]}).json()
    assert ["base_link", "upper_arm_link"] not in allowed["pairs"]
    assert allowed["checked_pairs"] == plain["checked_pairs"] - 1
    pair, q = _never_pair_that_collides(catalogue.get("ur5"))
    unseen = client.post("/models/ur5/collision", json={"q": q}).json()
    assert list(pair) not in unseen["pairs"]
    seen = client.post("/models/ur5/collision", json={"q": q, "forbid": [list(pair)]}).json()
    assert list(pair) in seen["pairs"] and seen["checked_pairs"] == unseen["checked_pairs"] + 1


def test_the_matrix_reports_user_pairs_and_exports_them(client):
    r = client.get("/models/ur5/collision/matrix", params={"allow": "base_link,upper_arm_link",
                                                           "forbid": "wrist_1_link,wrist_2_link"})
    assert r.status_code == 200, r.text
    m = r.json()
    reasons = {tuple(d["links"]): d["reason"] for d in m["disabled"]}
    assert reasons[("base_link", "upper_arm_link")] == "user"
    assert ("wrist_1_link", "wrist_2_link") not in reasons  # an adjacent pair a user wants checked
    assert m["enabled"] == [{"links": ["wrist_1_link", "wrist_2_link"], "reason": "user"}]
    srdf = ET.fromstring(client.get("/models/ur5/collision/matrix", params={
        "format": "srdf", "allow": "base_link,upper_arm_link", "forbid": "wrist_1_link,wrist_2_link"}).text)
    disabled = {(e.get("link1"), e.get("link2")): e.get("reason") for e in srdf.iter("disable_collisions")}
    enabled = {(e.get("link1"), e.get("link2")): e.get("reason") for e in srdf.iter("enable_collisions")}
    assert disabled[("base_link", "upper_arm_link")] == "User" and enabled == {("wrist_1_link", "wrist_2_link"): "User"}
    assert {k: v.lower() for k, v in disabled.items()} == reasons


@pytest.mark.parametrize("body, named", [
    ({"allow": [["base_link", "nope_link"]]}, "nope_link"),
    ({"forbid": [["tool0", "base_link"]]}, "tool0"),  # a link without collision geometry
    ({"allow": [["base_link", "base_link"]]}, "twice"),
    ({"allow": [["base_link", "ee_link"]], "forbid": [["ee_link", "base_link"]]}, "both allowed and forbidden"),
    ({"allow": [["base_link"]]}, "allow"),
])
def test_bad_pairs_are_422_naming_the_problem(client, body, named):
    r = client.post("/models/ur5/collision", json={"q": FOLDED, **body})
    assert r.status_code == 422 and r.headers["content-type"].startswith("application/problem+json")
    assert named in r.text
    put = client.put("/models/ur5/collision/pairs", json=body)
    assert put.status_code == 422 and named in put.text
    assert client.get("/models/ur5/collision/pairs").json() == {"model": "ur5", "allow": [], "forbid": []}


def test_a_bad_query_pair_is_422(client):
    for params in ({"allow": "base_link"}, {"forbid": "base_link,nope_link"}):
        r = client.get("/models/ur5/collision/matrix", params=params)
        assert r.status_code == 422 and params[next(iter(params))].split(",")[-1] in r.text


def test_a_model_s_settings_apply_to_every_check_and_a_request_overrides_them(client, api_data_dir):
    put = client.put("/models/ur5/collision/pairs", json={"allow": [["base_link", "upper_arm_link"]]})
    assert put.status_code == 200, put.text
    assert {tuple(d["links"]): d["reason"] for d in put.json()["disabled"]}[("base_link", "upper_arm_link")] == "user"
    assert client.get("/models/ur5/collision/pairs").json()["allow"] == [["base_link", "upper_arm_link"]]
    assert ["base_link", "upper_arm_link"] not in client.post("/models/ur5/collision",
                                                             json={"q": BASE_UPPER_ARM}).json()["pairs"]
    # the request's choice wins over the model's
    over = client.post("/models/ur5/collision", json={"q": BASE_UPPER_ARM, "forbid": [["base_link", "upper_arm_link"]]})
    assert ["base_link", "upper_arm_link"] in over.json()["pairs"]
    reasons = {tuple(d["links"]): d["reason"] for d in client.get("/models/ur5/collision/matrix").json()["disabled"]}
    assert reasons[("base_link", "upper_arm_link")] == "user"
    # kept in the data directory: a new service on it sees them
    from app.main import create_app

    with TestClient(create_app()) as again:
        assert again.get("/models/ur5/collision/pairs").json()["allow"] == [["base_link", "upper_arm_link"]]
    assert client.put("/models/ur5/collision/pairs", json={}).status_code == 200  # cleared
    assert ["base_link", "upper_arm_link"] in client.post("/models/ur5/collision",
                                                         json={"q": BASE_UPPER_ARM}).json()["pairs"]


def test_collision_avoiding_ik_takes_the_pairs(client, catalogue):
    model = catalogue.get("ur5")
    target = client.post("/models/ur5/fk", json={"q": FOLDED, "links": ["tool0"]}).json()["poses"]["tool0"]["matrix"]
    body = {"link": "tool0", "target": target, "solutions": "all", "avoid_collisions": True}
    strict = client.post("/models/ur5/ik", json=body)
    assert strict.status_code == 200, strict.text
    assert strict.json()["colliding"] > 0
    every = [list(p) for p in self_collision.matrix(model, SAMPLES).enabled()]
    loose = client.post("/models/ur5/ik", json={**body, "allow": every}).json()
    assert loose["colliding"] == 0 and loose["count"] == strict.json()["count"] + strict.json()["colliding"]
    bad = client.post("/models/ur5/ik", json={**body, "allow": [["tool0", "base_link"]]})
    assert bad.status_code == 422 and "tool0" in bad.text
