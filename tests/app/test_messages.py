"""Messages that point to the fix: a misspelt field names the field meant, a union names what the
input nearly was (never an internal class), a request is done as asked or refused, an empty check
says so, NaN reads alike everywhere, and the front door and the CLI's help say where to go."""

from __future__ import annotations

import io

import numpy as np
import pytest

from kinematics.cli import build_parser

POSE = {"position": [0.3, 0.1, 0.4], "quaternion": {"w": 1.0, "x": 0.0, "y": 0.0, "z": 0.0}}
NO_GEOMETRY = """<robot name="bare"><link name="a"/><link name="b"/>
  <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""


@pytest.mark.parametrize("path, body, typo, meant", [
    ("/models/ur5/fk", {"q": [0.0] * 6, "link": ["tool0"]}, "link", "links"),
    ("/models/ur5/collision", {"q": [0.0] * 6, "distances": True}, "distances", "distance"),
    ("/models/ur5/ik", {"target": POSE, "seeds": [0.0] * 6}, "seeds", "seed"),
    ("/models/ur5/task", {"q": [0.0] * 6, "representaton": "zyz"}, "representaton", "representation"),
])
def test_a_misspelt_field_names_the_field_meant(api_client, path, body, typo, meant):
    r = api_client.post(path, json=body)
    assert r.status_code == 422, r.text
    problem = r.json()
    assert problem["field"] == typo
    assert f"did you mean {meant!r}" in problem["detail"], problem["detail"]


def test_an_unknown_field_without_a_near_name_lists_the_fields(api_client):
    r = api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "base": {"xyz": [0, 0, 0], "rpy": [0, 0, 0],
                                                                            "quaternion": [0, 0, 0, 1]}})
    assert r.status_code == 422
    assert r.json()["detail"] == "base.quaternion: unknown field 'quaternion'; the fields are rpy, xyz"


def test_a_quaternion_given_as_a_list_is_named_without_internal_classes(api_client):
    r = api_client.post("/models/ur5/ik", json={"target": {"position": [0.3, 0.1, 0.4], "quaternion": [0, 0, 0, 1]}})
    assert r.status_code == 422
    problem = r.json()
    assert problem["field"] == "target.quaternion"
    assert problem["detail"] == "target.quaternion: should be an object with the fields w, x, y, z, got a list"
    text = r.text
    assert "BaseXyzRpy" not in text and "BasePositionQuaternion" not in text and "Quaternion." not in text
    assert [e["field"] for e in problem["errors"]] == ["target.quaternion"]  # the other members' noise left out


def test_the_analytic_jacobian_refuses_another_reference(api_client):
    body = {"q": [0.0] * 6, "link": "tool0", "representation": "rpy"}
    r = api_client.post("/models/ur5/jacobian", json={**body, "reference": "local"})
    assert r.status_code == 422 and "reference 'local' with representation" in r.json()["detail"], r.text
    buf = io.BytesIO()
    np.save(buf, np.zeros((2, 6)))
    r = api_client.post("/models/ur5/jacobian?reference=world&representation=zyz&link=tool0", content=buf.getvalue(),
                        headers={"Content-Type": "application/x-npy"})
    assert r.status_code == 422 and "reference 'world' with representation" in r.json()["detail"], r.text
    # left out, or the frame J_r is built from: answered, and the answer names that frame
    for extra in ({}, {"reference": "local_world_aligned"}):
        r = api_client.post("/models/ur5/jacobian", json={**body, **extra})
        assert r.status_code == 200 and r.json()["reference"] == "local_world_aligned", r.text
    # without representation every reference is the geometric Jacobian in it
    r = api_client.post("/models/ur5/jacobian", json={"q": [0.0] * 6, "link": "tool0", "reference": "local"})
    assert r.status_code == 200 and r.json()["reference"] == "local"


def test_a_collision_check_of_nothing_says_so(api_client):
    model = api_client.post("/models", content=NO_GEOMETRY, headers={"Content-Type": "application/xml"}).json()["id"]
    body = api_client.post(f"/models/{model}/collision", json={"q": [0.0]}).json()
    assert body["colliding"] is False and body["checked_pairs"] == 0
    assert len(body["warnings"]) == 1 and "no collision geometry" in body["warnings"][0]
    # a model with geometry and checked pairs: no such warning
    assert api_client.post("/models/ur5/collision", json={"q": [0.0] * 6}).json()["warnings"] == []


@pytest.mark.parametrize("literal, shown", [("NaN", "nan"), ("Infinity", "inf"), ("-Infinity", "-inf")])
def test_a_nan_literal_reads_alike_in_fk_and_in_a_dh_table(api_client, literal, shown):
    fk = api_client.post("/models/ur5/fk", content=f'{{"q": [{literal}, 0, 0, 0, 0, 0]}}',
                         headers={"Content-Type": "application/json"})
    assert fk.status_code == 422 and "not finite" in fk.json()["detail"], fk.text
    dh = api_client.post("/models/dh", content=f'{{"joints": [{{"type": "revolute", "a": {literal}, "alpha": 0, '
                                               f'"d": 0, "theta": 0}}]}}', headers={"Content-Type": "application/json"})
    assert dh.status_code == 422, dh.text
    assert dh.json()["detail"] == f"joints[0].a: {shown} is not finite"
    bad = api_client.post("/models/dh", content='{"joints": [', headers={"Content-Type": "application/json"})
    assert bad.status_code == 422 and "not valid JSON" in bad.json()["detail"]


def test_the_front_door_leads_to_the_api_pages(api_client):
    r = api_client.get("/", follow_redirects=False)
    assert r.status_code in (301, 302, 307, 308) and r.headers["location"] == "/docs"
    assert api_client.get("/").status_code == 200


def test_the_cli_help_describes_every_command_family():
    text = build_parser().format_help()
    for words in ("inverse kinematics", "self-collision", "workspaces", "calibration", "closed forms", "serve"):
        assert words in text.replace("\n", " ").replace("  ", " "), words
