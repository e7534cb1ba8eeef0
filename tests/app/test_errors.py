"""REST API: problem+json for every error (404/405/413/415/422/401/403), API keys, offline docs, OpenAPI."""

from __future__ import annotations

import json
import re

import pytest

from app.schemas import TWO_LINK_URDF

PROBLEM = "application/problem+json"
KEY = "s3cret-key"


def assert_problem(r, status: int) -> dict:
    assert r.status_code == status, r.text
    assert r.headers["content-type"] == PROBLEM
    body = r.json()
    assert body["status"] == status and body["title"] and body["detail"] and body["type"].startswith("urn:")
    return body


def test_unknown_route_and_method(api_client):
    assert "/nowhere" in assert_problem(api_client.get("/nowhere"), 404)["detail"]
    r = api_client.put("/models/ur5")
    assert "PUT" in assert_problem(r, 405)["detail"]
    # Allow names every method of the path (GET and DELETE are two routes), not the first route's
    assert r.headers["allow"] == "GET, DELETE"
    r = api_client.get("/models/ur5/fk")
    assert_problem(r, 405)
    assert r.headers["allow"] == "POST"
    assert api_client.options("/models").headers["allow"] == "GET, POST"


def test_validation_error_is_problem(api_client):
    body = assert_problem(api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "format": "xml"}), 422)
    assert body["field"] == "format" and body["errors"][0]["field"] == "format"
    assert_problem(api_client.post("/models/ur5/fk", content=b"{not json", headers={"content-type": "application/json"}), 422)
    assert_problem(api_client.post("/models/ur5/fk", content=b"", headers={"content-type": "application/json"}), 422)
    assert_problem(api_client.post("/models/ur5/fk", content=b"q=1", headers={"content-type": "text/plain"}), 415)


def test_body_limits_are_413(make_client):
    c = make_client(max_model_bytes=1000, max_request_bytes=4000)
    big_urdf = TWO_LINK_URDF.replace("</robot>", "<!--" + "x" * 2000 + "--></robot>")
    body = assert_problem(c.post("/models", content=big_urdf, headers={"content-type": "application/xml"}), 413)
    assert body["limit"] == 1000
    assert_problem(c.post("/models", json={"urdf": big_urdf}), 413)
    assert_problem(c.post("/models/dh", json={"name": "x" * 2000, "joints": []}), 413)
    # over the request limit: refused by Content-Length before any handler
    assert_problem(c.post("/models/ur5/fk", json={"q": [[0.0] * 6] * 200}), 413)

    # a chunked body (no Content-Length) is counted while it arrives
    def chunks():
        for _ in range(10):
            yield b"[" + b"0.0," * 200 + b"0.0]"

    assert_problem(c.post("/models/ur5/fk", content=chunks(), headers={"content-type": "application/json"}), 413)
    assert_problem(c.post("/models", content=chunks(), headers={"content-type": "application/xml"}), 413)


def test_api_key_guards_writes(make_client):
    c = make_client(api_key=KEY)
    body = assert_problem(c.post("/models", content=TWO_LINK_URDF, headers={"content-type": "application/xml"}), 401)
    assert "X-API-Key" in body["detail"]
    assert "www-authenticate" in c.post("/models", json={"urdf": TWO_LINK_URDF}).headers
    assert_problem(c.post("/models", json={"urdf": TWO_LINK_URDF}, headers={"x-api-key": "wrong"}), 403)
    assert_problem(c.post("/models", json={"urdf": TWO_LINK_URDF}, headers={"authorization": "Bearer wrong"}), 403)
    r = c.post("/models", json={"urdf": TWO_LINK_URDF}, headers={"x-api-key": KEY})
    assert r.status_code == 201
    mid = r.json()["id"]
    assert_problem(c.delete(f"/models/{mid}"), 401)
    assert_problem(c.post("/models/dh", json={"joints": []}), 401)
    # reads stay open unless configured
    assert c.get(f"/models/{mid}").status_code == 200
    assert c.post(f"/models/{mid}/fk", json={"q": [0, 0]}).status_code == 200
    assert c.delete(f"/models/{mid}", headers={"authorization": f"Bearer {KEY}"}).status_code == 204


def test_api_key_for_reads(make_client):
    c = make_client(api_key=KEY, api_key_for_reads=True)
    assert_problem(c.get("/models"), 401)
    assert_problem(c.post("/models/ur5/fk", json={"q": [0.0] * 6}), 401)
    assert_problem(c.get("/models/ur5", headers={"x-api-key": "nope"}), 403)
    assert c.get("/models/ur5", headers={"x-api-key": KEY}).status_code == 200
    assert c.get("/health").status_code == 200  # liveness stays open for probes


def test_no_key_configured_means_open(make_client):
    c = make_client(api_key="")
    assert c.post("/models", json={"urdf": TWO_LINK_URDF}).status_code == 201


EXTERNAL_URL = re.compile(r"""(?:src|href)\s*=\s*["']?\s*(?:https?:)?//""", re.I)
ANY_URL = re.compile(r"https?://", re.I)


@pytest.mark.parametrize("page", ["/docs", "/redoc"])
def test_docs_are_offline(api_client, page):
    r = api_client.get(page)
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    html = r.text
    assert not ANY_URL.search(html), ANY_URL.findall(html)
    assert not EXTERNAL_URL.search(html)
    assets = re.findall(r"""(?:src|href)\s*=\s*["']([^"']+)["']""", html)
    assets += re.findall(r"""url:\s*['"]([^'"]+)['"]""", html)  # Swagger UI's spec URL
    assets += re.findall(r"""spec-url=["']([^"']+)["']""", html)  # ReDoc's spec URL
    assert any(a.endswith(".js") for a in assets)
    for asset in assets:
        assert asset.startswith("/"), asset
        a = api_client.get(asset)
        assert a.status_code == 200 and len(a.content) > 100, asset
    assert api_client.get("/openapi.json").status_code == 200


def test_openapi_describes_bodies_and_examples(api_client):
    spec = api_client.get("/openapi.json").json()
    fk = spec["paths"]["/models/{model_id}/fk"]["post"]
    content = fk["requestBody"]["content"]
    assert content["application/json"]["schema"]["$ref"] == "#/components/schemas/FKRequest"
    assert "application/x-npy" in content
    assert {"ur5_single", "ur5_batch"} <= set(content["application/json"]["examples"])
    schemas = spec["components"]["schemas"]
    for name in ("FKRequest", "FKResponse", "JacobianRequest", "JacobianResponse", "ModelInfo", "DHTable", "Pose"):
        assert name in schemas, name
    assert "q" in schemas["FKRequest"]["properties"]
    dh = spec["paths"]["/models/dh"]["post"]["requestBody"]["content"]["application/json"]
    assert dh["examples"]["rrp_standard"]["value"]["joints"]
    # every $ref resolves
    refs = re.findall(r'"\$ref":\s*"#/components/schemas/([^"]+)"', json.dumps(spec))
    assert refs and not [r for r in refs if r not in schemas]


def test_openapi_examples_work_as_is(api_client):
    """Every request example shown on the docs page answers 2xx."""
    spec = api_client.get("/openapi.json").json()
    checked = 0
    for path, ops in spec["paths"].items():
        for method, op in ops.items():
            content = op.get("requestBody", {}).get("content", {}).get("application/json", {})
            for ex in content.get("examples", {}).values():
                url = path.replace("{model_id}", "ur5")
                r = api_client.request(method.upper(), url, json=ex["value"])
                assert r.status_code in (200, 201), (path, ex["summary"], r.text)
                checked += 1
    assert checked >= 7


def test_a_real_bug_is_a_logged_problem_500(get_with_a_bug, caplog):
    r = get_with_a_bug("/models/ur5")
    assert_problem(r, 500)
    assert "simulated bug" not in r.text  # internals are logged, not sent
    assert "simulated bug" in caplog.text
