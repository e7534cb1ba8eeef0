"""POST /models/{id}/collision and GET /models/{id}/collision/matrix."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from fastapi.testclient import TestClient

from kinematics.algorithms import self_collision
from tests.helpers import cube_stl, package_zip


@pytest.fixture
def client(api_data_dir, monkeypatch):
    monkeypatch.setenv("KIN_DATA_DIR", str(api_data_dir))
    monkeypatch.setenv("KIN_COLLISION_SAMPLES", "400")
    from app.main import create_app

    with TestClient(create_app()) as c:
        yield c


FOLDED = [0, -1.0, 2.9, 0, 0, 0]
READY = [0, -1.57, 0, -1.57, 0, 0]


def test_one_configuration_and_a_batch(client, catalogue):
    one = client.post("/models/ur5/collision", json={"q": FOLDED})
    assert one.status_code == 200, one.text
    body = one.json()
    assert body["colliding"] is True and ["upper_arm_link", "wrist_1_link"] in body["pairs"]
    assert "min_distance" not in body and body["warnings"] == [] and len(body["links"]) == 8
    batch = client.post("/models/ur5/collision", json={"q": [READY, FOLDED], "distance": True}).json()
    assert batch["colliding"] == [False, True] and batch["pairs"][0] == [] and batch["pairs"][1] == body["pairs"]
    # the same answer as the library, on the same matrix
    lib = self_collision.check(catalogue.get("ur5"), np.array([READY, FOLDED], dtype=float), samples=400,
                               distance=True)
    assert batch["min_distance"] == pytest.approx(lib.min_distance.tolist(), abs=1e-12)
    assert batch["min_distance"][1] < 0 < batch["min_distance"][0]
    closest = batch["closest"][0]
    assert tuple(closest["links"]) == lib.closest[0] and np.allclose(closest["points"], lib.points[0])


def test_margin(client):
    free = client.post("/models/ur5/collision", json={"q": READY, "distance": True}).json()
    d = free["min_distance"]
    assert client.post("/models/ur5/collision", json={"q": READY, "margin": d * 0.9}).json()["colliding"] is False
    assert client.post("/models/ur5/collision", json={"q": READY, "margin": d * 1.1}).json()["colliding"] is True


@pytest.mark.parametrize("body, status", [
    ({"q": [0, 0]}, 422), ({"q": READY, "margin": -0.1}, 422), ({"q": READY, "margin": "1"}, 422),
    ({"q": READY, "distance": "yes"}, 422), ({"q": READY, "extra": 1}, 422), ({}, 422),
])
def test_bad_requests_are_4xx(client, body, status):
    r = client.post("/models/ur5/collision", json=body)
    assert r.status_code == status and r.headers["content-type"].startswith("application/problem+json")


def test_unknown_model_is_404(client):
    assert client.post("/models/nope/collision", json={"q": [0]}).status_code == 404
    assert client.get("/models/nope/collision/matrix").status_code == 404


def test_matrix_json_and_srdf_kept_in_the_data_directory(client, api_data_dir):
    r = client.get("/models/panda/collision/matrix")
    assert r.status_code == 200
    m = r.json()
    assert m["samples"] == 400 and m["links"][0] == "panda_link0"
    reasons = {tuple(d["links"]): d["reason"] for d in m["disabled"]}
    assert reasons[("panda_link0", "panda_link1")] == "adjacent"
    assert reasons[("panda_link7", "panda_hand")] == "adjacent"  # through panda_link8, which has no geometry
    assert set(reasons.values()) <= {"adjacent", "never", "always", "user"}
    assert list((api_data_dir / "derived" / "collision").glob("collision-matrix-*.json"))
    srdf = client.get("/models/panda/collision/matrix?format=srdf")
    assert srdf.status_code == 200 and srdf.headers["content-type"].startswith("application/xml")
    rows = {(e.get("link1"), e.get("link2")): e.get("reason") for e in ET.fromstring(srdf.text).iter("disable_collisions")}
    assert {k: v.lower() for k, v in rows.items()} == reasons
    assert client.get("/models/panda/collision/matrix?format=yaml").status_code == 422


def test_a_plain_upload_names_the_meshes_it_does_not_open(client, catalogue):
    text = catalogue.get("ur5").urdf
    r = client.post("/models", content=text.encode(), headers={"Content-Type": "application/xml"})
    assert r.status_code in (200, 201), r.text
    mid = r.json()["id"]
    info = client.get(f"/models/{mid}").json()
    assert any("collision/base.stl" in w and "not opened" in w for w in info["warnings"])
    body = client.post(f"/models/{mid}/collision", json={"q": FOLDED}).json()
    assert body["links"] == ["ee_link"]  # only the box primitive; the meshes were never read
    assert body["colliding"] is False and any("not opened" in w for w in body["warnings"])


def test_an_archive_upload_brings_its_meshes(client):
    cube = cube_stl()
    urdf = """<robot name="pair">
      <link name="a"><collision><geometry><mesh filename="package://pair/meshes/cube.stl"/></geometry></collision></link>
      <link name="b"><collision><geometry><mesh filename="package://pair/meshes/cube.stl"/></geometry></collision></link>
      <link name="m"/>
      <joint name="j0" type="fixed"><parent link="a"/><child link="m"/></joint>
      <joint name="x" type="prismatic"><parent link="m"/><child link="b"/><axis xyz="1 0 0"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""
    archive = package_zip("pair", urdf, {"cube.stl": cube})
    r = client.post("/models", content=archive, headers={"Content-Type": "application/zip"})
    assert r.status_code in (200, 201), r.text
    mid = r.json()["id"]
    body = client.post(f"/models/{mid}/collision", json={"q": [[0.05], [0.2]], "distance": True}).json()
    assert body["links"] == ["a", "b"]
    # a and b are adjacent (through the geometry-less m): never checked, and the answer says so
    assert body["checked_pairs"] == 0 and body["colliding"] == [False, False]
    assert len(body["warnings"]) == 1 and "no pair was checked" in body["warnings"][0]


def test_an_archive_s_meshes_survive_a_restart(api_data_dir, monkeypatch):
    """Another process (a worker, or the service after a restart) reads the same meshes."""
    monkeypatch.setenv("KIN_DATA_DIR", str(api_data_dir))
    monkeypatch.setenv("KIN_COLLISION_SAMPLES", "200")
    from app.main import create_app

    cube = cube_stl()
    urdf = """<robot name="trio">
      <link name="a"><collision><geometry><mesh filename="package://trio/meshes/cube.stl"/></geometry></collision></link>
      <link name="m"><collision><origin xyz="0 0 5"/><geometry><sphere radius="0.01"/></geometry></collision></link>
      <link name="b"><collision><geometry><mesh filename="package://trio/meshes/cube.stl"/></geometry></collision></link>
      <joint name="j0" type="fixed"><parent link="a"/><child link="m"/></joint>
      <joint name="x" type="prismatic"><parent link="m"/><child link="b"/><axis xyz="1 0 0"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""
    archive = package_zip("trio", urdf, {"cube.stl": cube})
    body = {"q": [[0.05], [0.5]], "distance": True}
    with TestClient(create_app()) as c:
        mid = c.post("/models", content=archive, headers={"Content-Type": "application/zip"}).json()["id"]
        first = c.post(f"/models/{mid}/collision", json=body).json()
    assert first["links"] == ["a", "m", "b"] and first["checked_pairs"] == 1  # (a, b): not adjacent
    assert first["colliding"] == [True, False]
    assert first["min_distance"][1] == pytest.approx(0.4, abs=1e-6)
    assert list((api_data_dir / "models").glob("*.meshes.zip"))
    with TestClient(create_app()) as c:  # a new process's registry, reading the data directory
        again = c.post(f"/models/{mid}/collision", json=body).json()
        assert again["links"] == first["links"] and again["colliding"] == first["colliding"]
        assert again["min_distance"] == pytest.approx(first["min_distance"], abs=1e-12)
        assert c.delete(f"/models/{mid}").status_code in (200, 204)
    assert not list((api_data_dir / "models").glob("*.meshes.zip"))
