"""POST /models with xacro text, MJCF and description archives: 201 then 200 (ids hash what was
sent), `format` and `upload` in the info, the URDF they became, persistence across replicas."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from tests.paths import FIXTURES

XACRO = (FIXTURES / "descriptions" / "two_link.urdf.xacro").read_bytes()
MJCF = b"""<mujoco model="pendulum"><compiler angle="radian"/><asset><mesh name="m" file="no/such/mesh.stl"/></asset>
<worldbody><body name="arm" pos="0 0 1"><joint name="swing" axis="0 1 0" range="-2 2"/><geom type="mesh" mesh="m"/>
<body name="tip" pos="0 0 -0.5"/></body></worldbody><actuator><motor joint="swing"/></actuator></mujoco>"""


def _zip(members: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return buf.getvalue()


ARCHIVE = _zip({"two_link_description/package.xml": b"<package><name>two_link_description</name></package>",
                "two_link_description/urdf/two_link.urdf.xacro": XACRO,
                "two_link_description/meshes/base.stl": b"solid base"})


@pytest.fixture
def client(make_client):
    return make_client()


def _lower_z(info) -> float:
    return next(j for j in info["joints"] if j["name"] == "lower_joint")["origin"]["xyz"][2]


def test_xacro_text_with_arguments(client):
    r = client.post("/models?arg=length:0.9", content=XACRO, headers={"Content-Type": "application/xml"})
    assert r.status_code == 201, r.text
    info = r.json()
    assert info["id"].startswith("x-") and info["format"] == "xacro" and info["source"] == "upload"
    assert info["upload"] == {"container": None, "entry": None, "args": {"length": "0.9"}}
    assert _lower_z(info) == pytest.approx(0.9) and r.headers["Location"] == f"/models/{info['id']}"
    # the same text and arguments, however sent: the same id, 200
    for kwargs in ({"params": {"args": json.dumps({"length": 0.9})}, "content": XACRO,
                    "headers": {"Content-Type": "application/xml"}},
                   {"json": {"urdf": XACRO.decode(), "args": {"length": 0.9}}}):
        again = client.post("/models", **kwargs)
        assert again.status_code == 200 and again.json()["id"] == info["id"], again.text
    # other arguments: another model
    other = client.post("/models", content=XACRO, headers={"Content-Type": "application/xml"})
    assert other.status_code == 201 and other.json()["id"] != info["id"] and _lower_z(other.json()) == pytest.approx(0.5)
    urdf = client.get(f"/models/{info['id']}/urdf")
    assert urdf.status_code == 200 and b"xacro" not in urdf.content and b"lower_joint" in urdf.content


def test_mjcf_upload_never_opens_its_mesh(client):
    r = client.post("/models", content=MJCF, headers={"Content-Type": "application/xml"})
    assert r.status_code == 201, r.text
    info = r.json()
    assert info["id"].startswith("m-") and info["format"] == "mjcf" and info["joint_names"] == ["swing"]
    fk = client.post(f"/models/{info['id']}/fk", json={"q": [np.pi / 2], "links": ["tip"], "verify": True})
    assert fk.status_code == 200, fk.text
    np.testing.assert_allclose(fk.json()["poses"]["tip"]["position"], [-0.5, 0, 1], atol=1e-12)
    assert fk.json()["verification"]["max_position_error"] < 1e-12


@pytest.mark.parametrize("content_type", ["application/zip", "application/octet-stream"])
def test_archive_upload(client, content_type):
    r = client.post("/models", params={"arg": "length=0.25"}, content=ARCHIVE, headers={"Content-Type": content_type})
    assert r.status_code == 201, r.text
    info = r.json()
    assert info["id"].startswith("a-") and info["format"] == "xacro"
    assert info["upload"] == {"container": "zip", "entry": "two_link_description/urdf/two_link.urdf.xacro",
                              "args": {"length": "0.25"}}
    assert _lower_z(info) == pytest.approx(0.25)
    named = client.post("/models", params={"arg": "length=0.25", "entry": "two_link_description/urdf/two_link.urdf.xacro"},
                        content=ARCHIVE, headers={"Content-Type": "application/zip"})
    assert named.status_code == 200 and named.json()["id"] == info["id"]  # the entry chosen is part of the id


def test_models_survive_a_restart_and_are_seen_by_another_replica(make_client):
    first = make_client()
    ids = {}
    for body, kind in ((XACRO, "xacro"), (MJCF, "mjcf"), (ARCHIVE, "archive")):
        ctype = "application/zip" if kind == "archive" else "application/xml"
        r = first.post("/models", content=body, headers={"Content-Type": ctype})
        assert r.status_code == 201, r.text
        ids[kind] = r.json()
    second = make_client()
    for kind, info in ids.items():
        again = second.get(f"/models/{info['id']}")
        assert again.status_code == 200, again.text
        assert again.json()["format"] == info["format"] and again.json()["warnings"] == info["warnings"]
        assert again.json()["upload"] == info["upload"]
    assert second.delete(f"/models/{ids['mjcf']['id']}").status_code == 204
    assert first.get(f"/models/{ids['mjcf']['id']}").status_code == 404


def test_a_stored_model_whose_urdf_was_changed_is_unreadable(make_client, api_data_dir):
    client = make_client()
    info = client.post("/models", content=MJCF, headers={"Content-Type": "application/xml"}).json()
    path = Path(api_data_dir) / "models" / f"{info['id']}.urdf"
    path.write_bytes(path.read_bytes().replace(b"swing", b"sw1ng"))
    assert make_client().get(f"/models/{info['id']}").status_code == 404


@pytest.mark.parametrize("params, message", [
    ({"args": "{not json"}, "args is not valid JSON"), ({"args": "[1]"}, "JSON object"),
    ({"arg": "novalue"}, "not name:value"), ({"args": json.dumps({"x": [1]})}, "string or a number"),
])
def test_bad_xacro_arguments(client, params, message):
    r = client.post("/models", params=params, content=XACRO, headers={"Content-Type": "application/xml"})
    assert r.status_code == 422 and message in r.json()["detail"], r.text


def test_unsupported_types_and_plain_urdf_ids_are_unchanged(client):
    r = client.post("/models", content=ARCHIVE, headers={"Content-Type": "image/png"})
    assert r.status_code == 415 and "application/zip" in r.json()["detail"]
    urdf = (FIXTURES / "planar_2r.urdf").read_bytes()
    r = client.post("/models", content=urdf, headers={"Content-Type": "application/xml"})
    assert r.status_code == 201 and r.json()["id"].startswith("u-") and r.json()["format"] == "urdf"
    assert r.json()["upload"] is None


def test_archives_have_their_own_size_limit(make_client):
    client = make_client(max_archive_bytes=1000)
    r = client.post("/models", content=ARCHIVE + bytes(1000), headers={"Content-Type": "application/zip"})
    assert r.status_code == 413 and "archive body" in r.json()["detail"]
