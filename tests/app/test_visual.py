"""GET /models/{id}/visual and GET /models/{id}/visual/meshes/{index}: the robot as it looks."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.io.collision_geometry import mesh_source
from tests.helpers import cube_stl, package_zip, refuse_files


@pytest.mark.parametrize("model_id", ["ur5", "panda"])
def test_catalogue_meshes_are_served_as_the_package_files(api_client, catalogue, model_id):
    model = catalogue.get(model_id)
    root = mesh_source(model).root
    body = api_client.get(f"/models/{model_id}/visual").json()
    assert set(body["links"]) == set(model.links) and body["meshes"] > 0
    meshes = [v for vs in body["links"].values() for v in vs if v["kind"] == "mesh"]
    assert len(meshes) == body["meshes"] and all(v["url"] for v in meshes)
    for v in meshes:
        r = api_client.get(v["url"])
        assert r.status_code == 200
        assert r.headers["content-type"] == {"dae": "model/vnd.collada+xml", "stl": "model/stl",
                                             "obj": "model/obj"}[v["format"]]
        rel = v["source"].removeprefix("package://example-robot-data/robots/")
        assert r.content == (root / rel).read_bytes()
        assert len(v["origin"]) == 4 and v["scale"] == [1.0, 1.0, 1.0] or len(v["scale"]) == 3
    # the origins are the URDF's T_link_visual
    from kinematics.io.visual_geometry import visual_geometry

    g = visual_geometry(model)
    for link, elements in g.visuals.items():
        for got, want in zip(body["links"][link], elements):
            np.testing.assert_array_equal(got["origin"], want.origin)


def test_primitives_carry_their_size_and_colour(api_client):
    urdf = """<robot name="prims"><material name="blue"><color rgba="0 0 1 1"/></material>
      <link name="a"><visual><origin xyz="0 0 0.5"/><geometry><box size="0.1 0.2 0.3"/></geometry>
        <material name="blue"/></visual>
        <visual><geometry><cylinder radius="0.05" length="0.4"/></geometry>
        <material name="c"><color rgba="1 0.5 0 0.8"/></material></visual></link>
      <link name="b"><visual><geometry><sphere radius="0.07"/></geometry></visual></link>
      <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""
    mid = api_client.post("/models", content=urdf.encode(), headers={"Content-Type": "application/xml"}).json()["id"]
    links = api_client.get(f"/models/{mid}/visual").json()["links"]
    box, cyl = links["a"]
    assert (box["kind"], box["size"], box["color"]) == ("box", [0.1, 0.2, 0.3], [0.0, 0.0, 1.0, 1.0])
    assert box["origin"][2][3] == 0.5 and box["url"] is None
    assert (cyl["kind"], cyl["size"], cyl["color"]) == ("cylinder", [0.05, 0.4], [1.0, 0.5, 0.0, 0.8])
    assert links["b"][0]["kind"] == "sphere" and links["b"][0]["color"] is None


def test_a_plain_upload_naming_meshes_gets_no_url_and_nothing_is_opened(api_client, catalogue, monkeypatch):
    text = catalogue.get("ur5").urdf  # names the catalogue's own package:// meshes
    r = api_client.post("/models", content=text.encode(), headers={"Content-Type": "application/xml"})
    mid = r.json()["id"]
    hostile = """<robot name="h"><link name="a">
      <visual><geometry><mesh filename="/etc/passwd.stl"/></geometry></visual>
      <visual><geometry><mesh filename="file:///etc/hostname.dae"/></geometry></visual>
      <visual><geometry><mesh filename="package://example-robot-data/robots/../../../../etc/x.obj"/></geometry></visual>
      </link></robot>"""
    hid = api_client.post("/models", content=hostile.encode(), headers={"Content-Type": "application/xml"}).json()["id"]
    api_client.get(f"/models/{mid}")  # registered models are in memory: later reads open nothing
    refuse_files(monkeypatch)
    for model_id, count in ((mid, 6), (hid, 3)):
        body = api_client.get(f"/models/{model_id}/visual").json()
        meshes = [v for vs in body["links"].values() for v in vs if v["kind"] == "mesh"]
        assert len(meshes) >= count and body["meshes"] == 0
        assert all(v["url"] is None and v["format"] is None for v in meshes)
        assert sum("not opened" in w for w in body["warnings"]) == len(meshes)
        for index in ("0", "1", "2"):
            r = api_client.get(f"/models/{model_id}/visual/meshes/{index}")
            assert r.status_code == 404 and r.json()["type"].endswith("unknown-mesh")


@pytest.mark.parametrize("index", ["..%2F..%2Fetc%2Fpasswd", "%2Fetc%2Fpasswd", "-1", "1e3", "0x1", "999999",
                                   "9" * 30, "%00", " 1", "base.dae", "%2E%2E", "0.dae"])
def test_bad_or_hostile_mesh_indices_are_404(api_client, index):
    r = api_client.get(f"/models/ur5/visual/meshes/{index}")
    assert r.status_code == 404, (index, r.status_code, r.text[:200])


def test_hostile_paths_after_the_index_are_404(api_client):
    for path in ("/models/ur5/visual/meshes/0/../../../../etc/passwd", "/models/ur5/visual/meshes/../../etc/passwd",
                 "/models/ur5/visual/meshes/0/x", "/models/..%2F..%2Fetc/visual/meshes/0"):
        assert api_client.get(path).status_code == 404, path


def test_unknown_model_is_404(api_client):
    assert api_client.get("/models/nope/visual").status_code == 404
    assert api_client.get("/models/nope/visual/meshes/0").status_code == 404


def test_an_archive_upload_serves_its_own_meshes(api_client):
    cube = cube_stl()
    urdf = """<robot name="pair">
      <link name="a"><visual><geometry><mesh filename="package://pair/meshes/cube.stl" scale="2 2 2"/></geometry>
        </visual><visual><geometry><mesh filename="package://pair/meshes/missing.stl"/></geometry></visual></link>
      <link name="b"><visual><geometry><mesh filename="/etc/passwd.stl"/></geometry></visual></link>
      <joint name="x" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="1 0 0"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""
    r = api_client.post("/models", content=package_zip("pair", urdf, {"cube.stl": cube}),
                        headers={"Content-Type": "application/zip"})
    assert r.status_code in (200, 201), r.text
    mid = r.json()["id"]
    body = api_client.get(f"/models/{mid}/visual").json()
    served, missing = body["links"]["a"]
    assert body["meshes"] == 1 and served["scale"] == [2.0, 2.0, 2.0] and served["format"] == "stl"
    assert missing["url"] is None and body["links"]["b"][0]["url"] is None
    mesh = api_client.get(served["url"])
    assert mesh.status_code == 200 and mesh.content == cube and mesh.headers["content-type"] == "model/stl"
    assert api_client.get(f"/models/{mid}/visual/meshes/1").status_code == 404
