"""POST /models/{id}/ik with redundancy and avoid_collisions: the best point free of self-collision,
and slices with the colliding solutions left out (colliding); intervals with it: 422."""

from __future__ import annotations

import numpy as np

import kinematics
from kinematics import default_catalogue
from kinematics.usecases.collision import collision_filter

LINK = "panda_link8"
Q = [0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.7, 0.03]


def test_redundancy_with_avoid_collisions(api_client):
    panda = default_catalogue().get("panda")
    T = kinematics.fk(panda, Q, links=[LINK]).poses[0, 0].tolist()
    body = {"link": LINK, "target": T, "seed": Q, "solutions": "all", "avoid_collisions": True}
    r = api_client.post("/models/panda/ik", json={**body, "redundancy": {"select": "manipulability"}})
    assert r.status_code == 200, r.text
    ans = r.json()
    assert ans["count"] == 1 and collision_filter(panda, "avoid_collisions")(np.array([ans["solutions"][0]["q"]]))[0]
    r = api_client.post("/models/panda/ik", json={**body, "redundancy": {"values": list(np.linspace(-2.8, 2.8, 30))}})
    assert r.status_code == 200, r.text
    assert r.json()["colliding"] > 0 and r.json()["count"] == len(r.json()["solutions"])
    r = api_client.post("/models/panda/ik", json={**body, "redundancy": {"intervals": True}})
    assert r.status_code == 422 and "avoid_collisions" in r.json()["detail"]
