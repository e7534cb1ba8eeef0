"""What the viewer opens a model on (app/static/viewer/defaults.js, run with node as the page runs
it): the tool link selected, and a pose that POST /collision says is free of self-collision."""

from __future__ import annotations

import json
import shutil
import subprocess

import pytest

from tests.paths import REPO

DEFAULTS = REPO / "app" / "static" / "viewer" / "defaults.js"
NODE = shutil.which("node")
pytestmark = pytest.mark.skipif(NODE is None, reason="node is not installed (it runs the viewer's defaults.js)")


def run_defaults(info: dict) -> dict:
    """``defaultLink`` and ``openingCandidates`` of ``info`` (GET /models/{id}), computed by defaults.js."""
    script = (f"import {{ defaultLink, openingCandidates }} from {json.dumps(DEFAULTS.as_uri())};\n"
              f"const info = {json.dumps(info)};\n"
              "console.log(JSON.stringify({ link: defaultLink(info), candidates: openingCandidates(info) }));")
    proc = subprocess.run([NODE, "--input-type=module", "-e", script], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def opening_pose(client, model_id: str, info: dict, candidates: list) -> list[float]:
    """The pose the viewer opens on: the first candidate /collision says is free (``openingPose``)."""
    answer = client.post(f"/models/{model_id}/collision", json={"q": candidates}).json()
    free = [k for k, c in enumerate(answer["colliding"]) if not c]
    return candidates[free[0]] if free else candidates[0]


@pytest.mark.parametrize("model_id, link", [("panda", "panda_hand_tcp"), ("ur5", "tool0")])
def test_a_model_opens_on_its_tool_link_in_a_free_pose(api_client, model_id, link):
    info = api_client.get(f"/models/{model_id}").json()
    got = run_defaults(info)
    assert got["link"] == link
    q = opening_pose(api_client, model_id, info, got["candidates"])
    check = api_client.post(f"/models/{model_id}/collision", json={"q": q}).json()
    assert check["colliding"] is False and check["checked_pairs"] > 0, check
    fk = api_client.post(f"/models/{model_id}/fk", json={"q": q, "limits": "refuse"})
    assert fk.status_code == 200, fk.text  # inside the limits


def test_the_panda_s_old_opening_pose_collides_and_is_passed_over(api_client):
    """q = 0 clamped into the limits (what the viewer opened on) has the hand against link5."""
    info = api_client.get("/models/panda").json()
    candidates = run_defaults(info)["candidates"]
    first = api_client.post("/models/panda/collision", json={"q": candidates[0]}).json()
    assert first["colliding"] is True
    assert opening_pose(api_client, "panda", info, candidates) != candidates[0]


def test_a_model_without_a_tool_name_opens_on_its_farthest_leaf(api_client):
    info = api_client.get("/models/planar_2r").json()
    got = run_defaults(info)
    leaves = set(info["links"]) - {j["parent"] for j in info["joints"]}
    assert got["link"] in leaves and got["candidates"][0] == [0.0, 0.0]


def test_the_page_uses_these_defaults():
    loader = (REPO / "app" / "static" / "viewer" / "loader.js").read_text()
    assert 'from "./defaults.js"' in loader and "openingCandidates(info)" in loader and "openingPose(" in loader
