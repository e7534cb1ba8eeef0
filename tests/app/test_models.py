"""REST API: health, the model registry (list, upload, DH, info, URDF, delete), persistence."""

from __future__ import annotations

import json
import logging
import os

import numpy as np
import pytest

from app.registry import urdf_id
from app.schemas import DH_EXAMPLE_TABLE, TWO_LINK_URDF
from kinematics import compile_model, default_catalogue
from kinematics.algorithms.dh import dh_tool_pose
from kinematics.io import dh_table as dh

PROBLEM = "application/problem+json"

MIMIC_URDF = """<robot name="gripper">
  <link name="base"/><link name="finger_a"/><link name="finger_b"/>
  <joint name="a" type="prismatic"><parent link="base"/><child link="finger_a"/>
    <axis xyz="0 1 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/></joint>
  <joint name="b" type="prismatic"><parent link="base"/><child link="finger_b"/>
    <axis xyz="0 1 0"/><limit lower="-0.04" upper="0" effort="1" velocity="1"/>
    <mimic joint="a" multiplier="-1" offset="0"/></joint>
</robot>"""




def test_health(api_client):
    import pinocchio

    r = api_client.get("/health")
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "ok"
    assert body["pinocchio_version"] == pinocchio.__version__
    assert body["bundled_models"] == len(default_catalogue().ids())


def test_list_models_has_every_bundled_model_with_dof(api_client):
    r = api_client.get("/models")
    assert r.status_code == 200
    listing = {m["id"]: m for m in r.json()}
    cat = default_catalogue()
    assert set(cat.ids()) <= set(listing)
    assert listing["ur5"]["dof"] == 6 and listing["ur5"]["source"] == "example-robot-data"
    assert listing["panda"]["dof"] == cat.get("panda").dof
    # the catalogue lists only what loads: the file without a robot name is left out
    assert "ur3_unnamed" not in listing and all(m["dof"] is not None for m in listing.values() if m["id"] in cat)


def test_model_info_of_ur5(api_client):
    r = api_client.get("/models/ur5")
    assert r.status_code == 200
    info = r.json()
    model = default_catalogue().get("ur5")
    assert info["id"] == "ur5" and info["dof"] == 6 and info["root"] == model.root
    assert info["joint_names"] == list(model.joint_names)
    assert info["links"] == list(model.links) and info["leaf_links"] == list(model.leaf_links)
    joints = {j["name"]: j for j in info["joints"]}
    shoulder = joints["shoulder_pan_joint"]
    src = model.joint_map["shoulder_pan_joint"]
    assert shoulder["limits"] == {"lower": src.limits.lower, "upper": src.limits.upper,
                                  "effort": src.limits.effort, "velocity": src.limits.velocity}
    assert shoulder["mimic"] is None
    np.testing.assert_allclose(shoulder["axis"], src.axis)
    np.testing.assert_allclose(shoulder["origin"]["xyz"], src.origin[:3, 3])
    assert info["urdf_sha256"] == model.content_hash


def test_model_info_mimic_and_continuous(api_client):
    r = api_client.post("/models", content=MIMIC_URDF, headers={"content-type": "application/xml"})
    assert r.status_code == 201
    joints = {j["name"]: j for j in r.json()["joints"]}
    assert joints["b"]["mimic"] == {"joint": "a", "multiplier": -1.0, "offset": 0.0}
    assert r.json()["joint_names"] == ["a"] and r.json()["dof"] == 1
    # continuous joints have no limits object (Talos has none; tiago's wheels are continuous)
    info = api_client.get("/models/tiago").json()
    continuous = [j for j in info["joints"] if j["type"] == "continuous"]
    assert continuous and all(j["limits"] is None for j in continuous)


def test_get_urdf(api_client):
    r = api_client.get("/models/ur5/urdf")
    assert r.status_code == 200
    assert r.headers["content-type"].startswith("application/xml")
    assert r.text == default_catalogue().get("ur5").urdf


def test_upload_201_then_200_same_id(api_client):
    r1 = api_client.post("/models", content=TWO_LINK_URDF, headers={"content-type": "application/xml"})
    assert r1.status_code == 201
    mid = r1.json()["id"]
    assert mid == urdf_id(TWO_LINK_URDF.encode())
    assert r1.headers["location"] == f"/models/{mid}"
    assert r1.json()["source"] == "upload" and r1.json()["dof"] == 2
    # the same document in the JSON form: same bytes, same id, 200
    r2 = api_client.post("/models", json={"urdf": TWO_LINK_URDF, "name": "other name"})
    assert r2.status_code == 200 and r2.json()["id"] == mid
    # a new name is applied to the stored model, and the answer says so
    assert r2.json()["name"] == "other name"
    assert r2.json()["note"] == f"already registered as {mid} (same content); renamed from 'two_link' to 'other name'"
    assert api_client.get(f"/models/{mid}").json()["name"] == "other name"
    assert mid in {m["id"] for m in api_client.get("/models").json()}
    assert api_client.get(f"/models/{mid}/urdf").text == TWO_LINK_URDF


def test_upload_json_name_and_bad_urdf(api_client):
    doc = TWO_LINK_URDF.replace("two_link", "named_arm")
    r = api_client.post("/models", json={"urdf": doc, "name": "My arm"})
    assert r.status_code == 201 and r.json()["name"] == "My arm"
    bad = api_client.post("/models", content="<robot name='x'><link name='a'/><joint", headers={"content-type": "text/xml"})
    assert bad.status_code == 422 and bad.headers["content-type"] == PROBLEM
    assert "well-formed" in bad.json()["detail"]
    cycle = api_client.post("/models", content=b"<robot name='x'><link name='a'/><link name='b'/>"
                            b"<joint name='j' type='fixed'><parent link='a'/><child link='c'/></joint></robot>",
                            headers={"content-type": "application/xml"})
    assert cycle.status_code == 422 and "'c'" in cycle.json()["detail"]
    planar = TWO_LINK_URDF.replace('type="revolute"', 'type="planar"', 1).replace('xyz="0 0 1"', 'xyz="1 0 0"', 1)
    r = api_client.post("/models", content=planar, headers={"content-type": "application/xml"})
    assert r.status_code == 422 and "planar joint" in r.json()["detail"]
    bomb = ('<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;">]>'
            '<robot name="x"><link name="&b;"/></robot>')
    r = api_client.post("/models", content=bomb, headers={"content-type": "application/xml"})
    assert r.status_code == 422 and "DTD" in r.json()["detail"]
    r = api_client.post("/models", json={"name": "no urdf"})
    assert r.status_code == 422 and r.json()["field"] == "urdf"
    r = api_client.post("/models", content=TWO_LINK_URDF, headers={"content-type": "text/plain"})
    assert r.status_code == 415 and r.headers["content-type"] == PROBLEM


def test_delete_uploaded_and_bundled_is_read_only(api_client):
    mid = api_client.post("/models", content=TWO_LINK_URDF, headers={"content-type": "application/xml"}).json()["id"]
    assert api_client.delete(f"/models/{mid}").status_code == 204
    r = api_client.get(f"/models/{mid}")
    assert r.status_code == 404 and r.json()["model"] == mid
    assert api_client.delete(f"/models/{mid}").status_code == 404
    assert mid not in {m["id"] for m in api_client.get("/models").json()}
    r = api_client.delete("/models/ur5")
    assert r.status_code == 403 and r.headers["content-type"] == PROBLEM and "read-only" in r.json()["detail"]
    assert r.json()["type"] == "urn:kinematics:problem:read-only-model" and r.json()["model"] == "ur5"
    assert api_client.get("/models/ur5").status_code == 200


@pytest.mark.parametrize("path", ["/models/..", "/models/..%2F..%2Fetc%2Fpasswd", "/models/a..b",
                                  "/models/u-..%2F..%2Fpasswd", "/models/" + "x" * 129, "/models/bad%20id",
                                  "/models/..%2Fdata/urdf"])
def test_path_like_ids_never_touch_files(api_client, path):
    r = api_client.get(path, follow_redirects=False)
    if r.status_code == 307:  # the client resolved "/models/.." to "/": the front door, a redirect to /docs
        assert r.request.url.path == "/" and r.headers["location"] == "/docs"
    else:
        assert r.status_code in (404, 422)
        assert r.headers["content-type"] == PROBLEM
    r = api_client.delete(path)
    assert r.status_code in (403, 404, 422) or (r.status_code == 405 and r.request.url.path == "/")


def test_two_replicas_share_one_data_dir(make_client):
    a, b = make_client(), make_client()
    r = a.post("/models", content=TWO_LINK_URDF, headers={"content-type": "application/xml"})
    assert r.status_code == 201
    mid = r.json()["id"]
    # created on a: found by b on the very next request (b has never seen it)
    assert b.get(f"/models/{mid}").status_code == 200
    assert b.post(f"/models/{mid}/fk", json={"q": [0.1, 0.2]}).status_code == 200
    assert mid in {m["id"] for m in b.get("/models").json()}
    assert b.post("/models", json={"urdf": TWO_LINK_URDF}).status_code == 200  # already there
    # deleted on b: gone from a at once, although a has it cached
    assert a.get(f"/models/{mid}").status_code == 200
    assert b.delete(f"/models/{mid}").status_code == 204
    assert a.get(f"/models/{mid}").status_code == 404
    assert a.post(f"/models/{mid}/fk", json={"q": [0.1, 0.2]}).status_code == 404
    assert mid not in {m["id"] for m in a.get("/models").json()}


def test_restart_reloads_stored_models_and_skips_corrupt(make_client, api_data_dir, caplog):
    a = make_client()
    mid = a.post("/models", content=TWO_LINK_URDF, headers={"content-type": "application/xml"}).json()["id"]
    models_dir = api_data_dir / "models"
    # a corrupt upload (content no longer hashes to its id), a foreign file, junk names
    (models_dir / "u-0123456789abcdef.urdf").write_text("<robot name='x'><link name='a'/></robot>")
    (models_dir / "u-fedcba9876543210.urdf").write_bytes(b"\x00\xff garbage")
    (models_dir / "dh-0123456789abcdef.dh.json").write_text("{not json")
    (models_dir / "notes.txt").write_text("hello")
    (models_dir / f"{mid}.meta.json").write_text("{broken sidecar")
    with caplog.at_level(logging.WARNING, logger="app.registry"):
        b = make_client()
    assert "u-0123456789abcdef" in caplog.text and "dh-0123456789abcdef" in caplog.text
    info = b.get(f"/models/{mid}")
    assert info.status_code == 200 and info.json()["name"] == "two_link"  # sidecar unreadable: robot name
    assert b.get("/models/u-0123456789abcdef").status_code == 404
    ids = {m["id"] for m in b.get("/models").json()}
    assert mid in ids and "u-0123456789abcdef" not in ids and "u-fedcba9876543210" not in ids
    assert not any(p.name.startswith(".tmp-") for p in models_dir.iterdir())  # atomic writes left no temp file


def test_corrupt_file_is_logged_once_and_not_reread(make_client, api_data_dir, caplog):
    """A bad stored file is reported once per version of the file, not on every listing."""
    client = make_client()
    bad = api_data_dir / "models" / "u-0123456789abcdef.urdf"
    bad.write_text("<robot name='x'><link name='a'/></robot>")  # does not hash to its id
    with caplog.at_level(logging.WARNING, logger="app.registry"):
        for _ in range(3):
            assert "u-0123456789abcdef" not in {m["id"] for m in client.get("/models").json()}
        assert client.get("/models/u-0123456789abcdef").status_code == 404
    assert _warnings_about(caplog, "u-0123456789abcdef") == 1
    caplog.clear()
    bad.write_text("<robot name='y'><link name='b'/></robot>")  # a new version: checked and reported again
    os.utime(bad, ns=(bad.stat().st_atime_ns, bad.stat().st_mtime_ns + 10**9))
    with caplog.at_level(logging.WARNING, logger="app.registry"):
        client.get("/models")
    assert _warnings_about(caplog, "u-0123456789abcdef") == 1


def _warnings_about(caplog, model_id: str) -> int:
    return sum(r.levelno == logging.WARNING and model_id in r.getMessage() for r in caplog.records)


def test_screws(api_client):
    r = api_client.get("/models/ur5/screws")
    assert r.status_code == 200
    body = r.json()
    poe = compile_model(default_catalogue().get("ur5"))
    assert body["twist_order"] == "angular_first"
    assert [j["name"] for j in body["joints"]] == list(poe.joint_names)
    np.testing.assert_allclose([j["screw"] for j in body["joints"]], poe.S, atol=0)
    # v = -w x r for a revolute joint
    for j in body["joints"]:
        np.testing.assert_allclose(j["screw"][3:], -np.cross(j["axis"], j["point"]), atol=1e-12)
    np.testing.assert_allclose(body["home_poses"]["tool0"], poe.M[poe.link_indices(["tool0"])[0]], atol=0)


def test_screws_of_mimic_model(api_client):
    mid = api_client.post("/models", content=MIMIC_URDF, headers={"content-type": "application/xml"}).json()["id"]
    joints = {j["name"]: j for j in api_client.get(f"/models/{mid}/screws").json()["joints"]}
    assert joints["b"]["q_index"] == 0 and joints["b"]["multiplier"] == -1.0
    assert joints["a"]["type"] == "prismatic" and joints["a"]["screw"][:3] == [0, 0, 0]


def test_dh_upload_fk_and_persistence(make_client):
    a = make_client()
    r = a.post("/models/dh", json=DH_EXAMPLE_TABLE)
    assert r.status_code == 201
    mid = r.json()["id"]
    assert mid.startswith("dh-") and r.json()["source"] == "dh" and r.json()["dof"] == 3
    assert r.json()["name"] == "example_rrp" and r.json()["dh_table"]["angles"] == "radians"
    # the same table in radians is the same model
    rad = json.loads(json.dumps(DH_EXAMPLE_TABLE))
    rad["angles"] = "radians"
    for row in rad["joints"]:
        row["alpha"], row["theta"] = np.radians(row["alpha"]), np.radians(row["theta"])
        if row["type"] == "revolute" and "limits" in row:
            row["limits"] = list(np.radians(row["limits"]))
    r2 = a.post("/models/dh", json=rad)
    assert r2.status_code == 200 and r2.json()["id"] == mid
    # FK of the tool link equals the direct product of the DH matrices
    q = [0.3, -0.7, 0.5]
    fk = a.post(f"/models/{mid}/fk", json={"q": q, "links": ["tool"]}).json()
    expected = dh_tool_pose(dh.table_from_dict(DH_EXAMPLE_TABLE), np.array([q]))[0]
    np.testing.assert_allclose(fk["poses"]["tool"]["matrix"], expected, atol=1e-12)
    urdf = a.get(f"/models/{mid}/urdf")
    assert urdf.status_code == 200 and urdf.text == dh.table_to_urdf(dh.table_from_dict(DH_EXAMPLE_TABLE))
    # a second replica, started afterwards, loads it from the data directory
    b = make_client()
    assert b.get(f"/models/{mid}").json()["joint_names"] == r.json()["joint_names"]
    assert b.delete(f"/models/{mid}").status_code == 204
    assert a.get(f"/models/{mid}").status_code == 404


def test_dh_upload_errors_name_the_field(api_client):
    bad = json.loads(json.dumps(DH_EXAMPLE_TABLE))
    bad["joints"][2]["alpha"] = "ninety"
    r = api_client.post("/models/dh", json=bad)
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM
    assert "joints[2].alpha" in r.json()["detail"]
    r = api_client.post("/models/dh", content=b"[1, 2]", headers={"content-type": "application/json"})
    assert r.status_code == 422
    r = api_client.post("/models/dh", content=b"{oops", headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["field"] == "body"


def test_dh_extraction_endpoint(api_client):
    mid = api_client.post("/models/dh", json=DH_EXAMPLE_TABLE).json()["id"]
    r = api_client.get(f"/models/{mid}/dh")
    assert r.status_code == 200
    table = dh.table_from_dict(r.json())
    assert table.dof == 3
    # the extracted table reproduces the model's tool pose
    q = np.array([[0.2, 0.4, 0.6]])
    fk = api_client.post(f"/models/{mid}/fk", json={"q": q[0].tolist(), "links": ["tool"]}).json()
    np.testing.assert_allclose(dh_tool_pose(table, q)[0], fk["poses"]["tool"]["matrix"], atol=1e-9)
    r = api_client.get(f"/models/{mid}/dh", params={"convention": "modified"})
    assert r.status_code == 200 and r.json()["convention"] == "modified"
    # a tree (Talos) has no single DH chain without a tip; an unknown tip is named
    r = api_client.get("/models/talos_reduced/dh")
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM
    # UR5 to tool0 is a chain: its DH table reproduces the PoE pose of tool0 (base/tool absorb the rest)
    r = api_client.get("/models/ur5/dh", params={"tip": "tool0"})
    assert r.status_code == 200
    ur5_table = dh.table_from_dict(r.json())
    q = np.array([[0.1, -0.5, 0.9, 0.3, -1.1, 0.4]])
    fk = api_client.post("/models/ur5/fk", json={"q": q[0].tolist(), "links": ["tool0"]}).json()
    np.testing.assert_allclose(dh_tool_pose(ur5_table, q)[0], fk["poses"]["tool0"]["matrix"], atol=1e-9)
    r = api_client.get("/models/ur5/dh", params={"tip": "no_such_link"})
    assert r.status_code == 404 and r.json()["link"] == "no_such_link"
    r = api_client.get("/models/ur5/dh", params={"convention": "sideways"})
    assert r.status_code == 422 and r.json()["field"] == "convention"


def test_dh_preset_is_listed_with_its_table_and_matches_the_closed_form(api_client):
    presets = {m["id"]: m for m in api_client.get("/models").json() if m["source"] == "preset"}
    assert presets["planar_2r"]["dof"] == 2
    info = api_client.get("/models/planar_2r").json()
    rows = info["dh_table"]["joints"]
    l1, l2 = rows[0]["a"], rows[1]["a"]
    q1, q2 = 0.4, -1.1
    fk = api_client.post("/models/planar_2r/fk", json={"q": [q1, q2], "links": ["tool"]}).json()
    # De Luca's 2R planar arm: p = (l1 c1 + l2 c12, l1 s1 + l2 s12, 0)
    np.testing.assert_allclose(fk["poses"]["tool"]["position"],
                               [l1 * np.cos(q1) + l2 * np.cos(q1 + q2), l1 * np.sin(q1) + l2 * np.sin(q1 + q2), 0.0],
                               atol=1e-12)
    assert api_client.delete("/models/planar_2r").status_code == 403


MESH_SUBSTITUTION_URDF = """<robot name="pkg_arm">
  <link name="a"><visual><geometry><mesh filename="$(find pkg_arm_description)/meshes/a.stl"/></geometry></visual></link>
  <link name="b"><visual><geometry><mesh filename="package://$(arg robot)/b.dae"/></geometry></visual></link>
  <joint name="j" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""


def test_a_urdf_with_substitutions_only_in_mesh_names_loads_with_a_warning(make_client):
    client = make_client()
    for kwargs in ({"content": MESH_SUBSTITUTION_URDF, "headers": {"Content-Type": "application/xml"}},
                   {"json": {"urdf": MESH_SUBSTITUTION_URDF}}):
        r = client.post("/models", **kwargs)
        assert r.status_code in (200, 201), r.text
        body = r.json()
        assert body["format"] == "urdf" and body["joint_names"] == ["j"]
        (warning,) = body["warnings"]
        assert "link 'a' <visual> <mesh filename='$(find pkg_arm_description)/meshes/a.stl'>" in warning
        assert "link 'b' <visual> <mesh filename='package://$(arg robot)/b.dae'>" in warning
    model_id = body["id"]
    r = client.post(f"/models/{model_id}/fk", json={"q": [0.5], "links": ["b"]})
    assert r.status_code == 200, r.text
    # stored as given: a restarted service reads it again, warning included
    again = make_client().get(f"/models/{model_id}")
    assert again.status_code == 200 and again.json()["warnings"] == body["warnings"]


def test_a_substitution_in_an_origin_beside_mesh_names_is_still_xacro(api_client):
    text = MESH_SUBSTITUTION_URDF.replace('xyz="0 0 0.3"', 'xyz="0 0 $(arg height)"')
    r = api_client.post("/models", content=text, headers={"Content-Type": "application/xml"})
    assert r.status_code == 422 and r.headers["content-type"].startswith("application/problem+json")
    assert "xacro" in r.json()["detail"]
    r = api_client.post("/models", json={"urdf": text})
    assert r.status_code == 422 and "xacro" in r.json()["detail"]
