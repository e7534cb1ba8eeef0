"""Access control: with ``KIN_API_KEY`` set, writes need the key; reads per ``KIN_API_KEY_FOR_READS``.

- writes (``POST /models``, ``POST /models/dh``, ``DELETE /models/{id}``): 401 without a key
  (with ``WWW-Authenticate``), 403 with a wrong one, done with the right one given as
  ``X-API-Key`` or ``Authorization: Bearer``;
- reads stay open by default, and need the key when read protection is on; ``/health``
  is always open (liveness probes carry no key);
- the comparison is constant-time (:func:`hmac.compare_digest`), the key never appears in
  an answer, and the OpenAPI document lists 401/403 on every protected operation;
- with no key configured, everything is open.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from tests.paths import CORPUS

KEY = "s3cret-key-for-tests-0123456789"
ARM = (CORPUS / "fixture_arm.urdf").read_bytes()
DH = {"name": "ac_2r", "convention": "standard",
      "joints": [{"type": "revolute", "a": 0.5, "alpha": 0, "d": 0, "theta": 0},
                 {"type": "revolute", "a": 0.3, "alpha": 0, "d": 0, "theta": 0}]}
XML = {"Content-Type": "application/xml"}
GOOD = [{"X-API-Key": KEY}, {"Authorization": f"Bearer {KEY}"}]
WRONG = [{"X-API-Key": KEY[:-1]}, {"X-API-Key": KEY + "x"}, {"Authorization": "Bearer nope"}, {"X-API-Key": KEY.upper()}]
#: headers that carry no key at all (401, like no header)
EMPTY = [{"X-API-Key": ""}, {"Authorization": "Bearer "}, {"Authorization": f"Basic {KEY}"}]


def _client(tmp_path, **settings) -> TestClient:
    return TestClient(create_app(Settings(data_dir=tmp_path / "data", **settings)), raise_server_exceptions=False)


def _assert_problem(r, status):
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    assert KEY not in r.text


def _reads(c: TestClient, model_id: str, headers: dict) -> list:
    return [
        c.get("/models", headers=headers),
        c.get(f"/models/{model_id}", headers=headers),
        c.get(f"/models/{model_id}/urdf", headers=headers),
        c.post(f"/models/{model_id}/fk", json={"q": [0.1, 0.2, 0.3]}, headers=headers),
        c.post(f"/models/{model_id}/jacobian", json={"q": [0.1, 0.2, 0.3]}, headers=headers),
        c.post("/models/ur5/fk", json={"q": [0.0] * 6}, headers=headers),
    ]


def test_writes_need_the_key_reads_stay_open(tmp_path):
    with _client(tmp_path, api_key=KEY) as c:
        # no key: 401 with a challenge; wrong key: 403; nothing is written either way
        r = c.post("/models", content=ARM, headers=XML)
        _assert_problem(r, 401)
        assert "Bearer" in r.headers["www-authenticate"]
        _assert_problem(c.post("/models/dh", json=DH), 401)
        for wrong in WRONG:
            _assert_problem(c.post("/models", content=ARM, headers={**XML, **wrong}), 403)
            _assert_problem(c.post("/models/dh", json=DH, headers=wrong), 403)
        for empty in EMPTY:
            _assert_problem(c.post("/models", content=ARM, headers={**XML, **empty}), 401)
        assert [m for m in c.get("/models").json() if m["source"] in ("upload", "dh")] == []
        # the right key, in either header
        r = c.post("/models", content=ARM, headers={**XML, **GOOD[0]})
        assert r.status_code == 201
        arm = r.json()["id"]
        r = c.post("/models/dh", json=DH, headers=GOOD[1])
        assert r.status_code == 201
        dh_id = r.json()["id"]
        # reads are open
        for r in _reads(c, arm, {}):
            assert r.status_code == 200, r.text
        assert c.get("/health").status_code == 200
        # deletes need the key too
        _assert_problem(c.delete(f"/models/{arm}"), 401)
        for wrong in WRONG:
            _assert_problem(c.delete(f"/models/{arm}", headers=wrong), 403)
        assert c.get(f"/models/{arm}").status_code == 200
        assert c.delete(f"/models/{arm}", headers=GOOD[1]).status_code == 204
        assert c.delete(f"/models/{dh_id}", headers=GOOD[0]).status_code == 204
        assert c.get(f"/models/{arm}").status_code == 404


def test_reads_need_the_key_when_protected(tmp_path):
    with _client(tmp_path, api_key=KEY, api_key_for_reads=True) as c:
        arm = c.post("/models", content=ARM, headers={**XML, **GOOD[0]}).json()["id"]
        for r in _reads(c, arm, {}):
            _assert_problem(r, 401)
        for r in _reads(c, arm, WRONG[0]):
            _assert_problem(r, 403)
        for good in GOOD:
            for r in _reads(c, arm, good):
                assert r.status_code == 200, r.text
        # liveness and the docs stay open
        assert c.get("/health").status_code == 200
        assert c.get("/openapi.json").status_code == 200


def test_no_key_configured_means_open(tmp_path):
    with _client(tmp_path) as c:
        r = c.post("/models", content=ARM, headers=XML)
        assert r.status_code == 201
        arm = r.json()["id"]
        for r in _reads(c, arm, {}):
            assert r.status_code == 200
        # a key sent to a keyless service is ignored, not an error
        assert c.delete(f"/models/{arm}", headers={"X-API-Key": "anything"}).status_code == 204


def test_key_comparison_is_constant_time(tmp_path, monkeypatch):
    import app.deps as deps

    calls = []
    real = deps.hmac.compare_digest

    def spy(a, b):
        calls.append((a, b))
        return real(a, b)

    monkeypatch.setattr(deps.hmac, "compare_digest", spy)
    with _client(tmp_path, api_key=KEY) as c:
        assert c.post("/models", content=ARM, headers={**XML, "X-API-Key": "guess"}).status_code == 403
        assert c.post("/models", content=ARM, headers={**XML, "X-API-Key": KEY}).status_code == 201
    assert calls == [(b"guess", KEY.encode()), (KEY.encode(), KEY.encode())]


def test_key_from_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("KIN_API_KEY", KEY)
    monkeypatch.setenv("KIN_API_KEY_FOR_READS", "false")
    monkeypatch.setenv("KIN_DATA_DIR", str(tmp_path / "data"))
    with TestClient(create_app(), raise_server_exceptions=False) as c:
        _assert_problem(c.post("/models", content=ARM, headers=XML), 401)
        assert c.post("/models", content=ARM, headers={**XML, "X-API-Key": KEY}).status_code == 201
        assert c.get("/models").status_code == 200


def test_openapi_documents_the_key(tmp_path):
    with _client(tmp_path, api_key=KEY, api_key_for_reads=True) as c:
        doc = c.get("/openapi.json").json()
    schemes = doc["components"]["securitySchemes"]
    assert any(s.get("type") == "apiKey" and s.get("name") == "X-API-Key" for s in schemes.values())
    assert any(s.get("type") == "http" and s.get("scheme", "").lower() == "bearer" for s in schemes.values())
    protected = {("post", "/models"), ("post", "/models/dh"), ("delete", "/models/{model_id}"),
                 ("get", "/models"), ("post", "/models/{model_id}/fk"), ("post", "/models/{model_id}/jacobian")}
    for method, path in protected:
        op = doc["paths"][path][method]
        assert op.get("security"), (method, path)
        for status in ("401", "403"):
            content = op["responses"][status]["content"]
            assert "application/problem+json" in content, (method, path, status)
    assert not doc["paths"]["/health"]["get"].get("security")
