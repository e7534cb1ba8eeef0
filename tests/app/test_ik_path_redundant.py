"""POST /models/{id}/ik/path with redundancy on a 7-joint arm: the Panda line that stops with
joint_jump when q7 is locked goes through along the self-motion (rows exact against Pinocchio,
continuous); bad redundancy on a path is a 422 naming it."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from kinematics import compile_model, default_catalogue
from tests.kinematics.algorithms.test_ik_path_redundant import LINK, MOVE, START
from tests.kinematics.algorithms.test_ik_redundant import _exact
from tests.paths import REPO

PROBLEM = "application/problem+json"


@pytest.fixture(scope="module")
def panda_line():
    panda = default_catalogue().get("panda")
    a = compile_model(panda).fk(START[None], [LINK])[0, 0]
    b = a.copy()
    b[:3, 3] += MOVE
    return panda, [a.tolist(), b.tolist()]


def test_a_path_along_the_self_motion_where_q7_locked_jumps(api_client, panda_line):
    panda, waypoints = panda_line
    body = {"link": LINK, "waypoints": waypoints, "seed": START.tolist()}
    r = api_client.post("/models/panda/ik/path", json={**body, "locked": {"panda_joint7": START[6]}})
    assert r.status_code == 200, r.text
    assert r.json()["stopped"] == {"index": 5, "reason": "joint_jump"}
    r = api_client.post("/models/panda/ik/path", json={**body, "redundancy": {"select": "nearest"}})
    assert r.status_code == 200, r.text
    ans = r.json()
    assert ans["complete"] and ans["stopped"] is None and ans["max_joint_step"] < 0.03
    Q = np.array(ans["q"])
    np.testing.assert_allclose(Q[0], START, atol=1e-9)
    _exact(panda, LINK, Q[:, None], np.ones(len(Q), int), np.array(ans["targets"]))
    assert np.abs(np.diff(Q, axis=0)).max() <= 0.3 and np.ptp(Q[:, 6]) > 5e-3


@pytest.mark.parametrize("model, link, redundancy, words", [
    ("ur5", "tool0", {"select": "nearest"}, "not redundant"),
    ("panda", LINK, {"select": "fastest"}, "redundancy.select"),
    ("panda", LINK, {"select": "nearest", "values": [0.1]}, "redundancy.values"),
    ("panda", LINK, {}, "redundancy.select"),
    ("panda", LINK, {"select": "margin", "parameter": {"joint": "panda_joint9"}}, "panda_joint9"),
])
def test_bad_redundancy_on_a_path_is_a_422_naming_it(api_client, panda_line, model, link, redundancy, words):
    _, waypoints = panda_line
    if model == "ur5":
        ur5 = default_catalogue().get("ur5")
        T = compile_model(ur5).fk(np.array([[0.3, -1.0, 1.2, -0.5, 0.8, 0.2]]), ["tool0"])[0, 0]
        waypoints = [T.tolist(), T.tolist()]
    r = api_client.post(f"/models/{model}/ik/path", json={"link": link, "waypoints": waypoints,
                                                            "redundancy": redundancy})
    assert r.status_code == 422 and r.headers["content-type"].startswith(PROBLEM), r.text
    assert words in r.json()["detail"], r.text


def test_the_documented_request_goes_through_and_its_q7_locked_twin_stops(api_client):
    page = (REPO / "docs" / "operations" / "redundancy.md").read_text()
    body = json.loads(re.search(r"ik/path -H 'Content-Type: application/json' -d '(\{.*?\})'", page, re.S).group(1))
    ans = api_client.post("/models/panda/ik/path", json=body).json()
    assert ans["complete"] and ans["max_joint_step"] < 0.03
    np.testing.assert_allclose(ans["q"][0], body["seed"], atol=1e-9)  # the seed reaches the first waypoint
    locked = {k: v for k, v in body.items() if k != "redundancy"} | {"locked": {"panda_joint7": body["seed"][6]}}
    assert api_client.post("/models/panda/ik/path", json=locked).json()["stopped"]["reason"] == "joint_jump"
