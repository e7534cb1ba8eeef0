"""docs/rest-api.md's "every endpoint with curl": every route of the service is there, and every
example whose body is written out answers as the page says (run on the service's TestClient), and
the documented workspace examples include one that converges."""

from __future__ import annotations

import json
import re
import shlex
from urllib.parse import urlsplit

import pytest

from tests.paths import REPO

PAGE = REPO / "docs" / "rest-api.md"
#: routes that are not endpoints a client calls (the viewer's page and files)
NOT_ENDPOINTS = ("/viewer", "/viewer/static/{path}", "/viewer/{model_id}")


def curl_lines() -> list[str]:
    text = PAGE.read_text()
    block = text[text.index("## Every endpoint with `curl`"):]
    block = block[block.index("```sh") + 5:]
    block = block[:block.index("```")].replace("\\\n", " ")
    commands, current = [], ""
    for line in block.splitlines():
        if current:  # a quoted body that goes on over lines
            current += "\n" + line
        elif line.startswith("curl "):
            current = line
        if current and current.split("  #")[0].count("'") % 2 == 0:  # (a comment's apostrophes aside)
            commands.append(current.split("  #")[0].strip())
            current = ""
    return commands


def curl_request(line: str) -> dict | None:
    """method, path, body and content type of a curl line; None when it reads a file or pipes."""
    if "@" in line or "|" in line:
        return None
    words = shlex.split(line)
    request = {"method": "GET", "body": None, "type": None}
    for k, word in enumerate(words):
        if word == "-X":
            request["method"] = words[k + 1]
        elif word == "-d":
            request["body"] = words[k + 1]
            request["method"] = request["method"] if "-X" in words else "POST"
        elif word == "-H" and words[k + 1].lower().startswith("content-type:"):
            request["type"] = words[k + 1].split(":", 1)[1].strip()
        elif word.startswith("$BASE"):
            request["path"] = word[len("$BASE"):]
    return request


def test_every_endpoint_has_a_curl_line(api_client):
    documented = " ".join(curl_lines())
    routes = api_client.get("/openapi.json").json()["paths"]
    missing = []
    for route in routes:
        if route in NOT_ENDPOINTS:
            continue
        pattern = re.sub(r"\\\{[^}]+\\\}", "[^/?\"' ]+", re.escape(route)) + r"(?=[?\"' ]|$)"
        if not re.search(r"\$BASE" + pattern, documented):
            missing.append(route)
    assert not missing, f"no curl line for {missing}"


@pytest.mark.parametrize("line", [line for line in curl_lines() if " -d " in line])
def test_every_written_out_body_is_answered(api_client, line):
    request = curl_request(line)
    if request is None or "DELETE" == request["method"]:
        pytest.skip("reads a file or deletes")
    json.loads(request["body"])  # the example is JSON as written
    parts = urlsplit(request["path"])
    r = api_client.request(request["method"], parts.path + (f"?{parts.query}" if parts.query else ""),
                           content=request["body"], headers={"Content-Type": request["type"] or "application/json"})
    assert r.status_code < 300, (line, r.text[:500])
    if parts.path.endswith("/workspace") and '"voxel": 0.15' in request["body"]:
        assert r.json()["converged"] is True
    if parts.path.endswith("/ik/path"):
        assert r.json()["complete"] is True


def test_the_openapi_page_shows_a_workspace_example_that_converges(api_client):
    from app.schemas.workspace import WORKSPACE_EXAMPLES

    example = WORKSPACE_EXAMPLES["ur5_converged"]["value"]
    r = api_client.post("/models/ur5/workspace", json=example)
    assert r.status_code == 200 and r.json()["converged"] is True and r.json()["advice"] is None, r.text
