"""REST API settings: KIN_* environment variables, CORS, data directory default."""

from __future__ import annotations

from pathlib import Path

from app.settings import MIB, Settings


def test_settings_from_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("KIN_DATA_DIR", str(tmp_path / "store"))
    monkeypatch.setenv("KIN_MAX_BATCH", "123")
    monkeypatch.setenv("KIN_CORS_ORIGINS", "http://a.example, http://b.example")
    monkeypatch.setenv("KIN_API_KEY", "zq-secret-91")
    monkeypatch.setenv("KIN_API_KEY_FOR_READS", "true")
    s = Settings()
    assert s.resolved_data_dir() == (tmp_path / "store").resolve()
    assert s.max_batch == 123 and s.api_key.get_secret_value() == "zq-secret-91" and s.api_key_for_reads
    assert s.cors_origins == ["http://a.example", "http://b.example"]
    assert "zq-secret-91" not in repr(s)  # the key is never printed
    monkeypatch.setenv("KIN_CORS_ORIGINS", '["http://c.example"]')
    monkeypatch.setenv("KIN_API_KEY", "")
    s = Settings()
    assert s.cors_origins == ["http://c.example"] and s.api_key is None


def test_defaults_follow_the_contract(monkeypatch, tmp_path):
    for var in ("KIN_DATA_DIR", "KIN_MAX_BATCH", "KIN_API_KEY", "KIN_CORS_ORIGINS"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.chdir(tmp_path)
    s = Settings()
    assert s.resolved_data_dir() == Path(tmp_path, "data").resolve()
    assert (s.max_model_bytes, s.max_request_bytes, s.max_batch, s.max_links) == (8 * MIB, 64 * MIB, 1_000_000, 10_000)
    assert s.api_key is None and not s.api_key_for_reads


def test_cors_origins_answer_preflight(make_client):
    c = make_client(cors_origins=["http://viewer.example"])
    r = c.options("/models/ur5/fk", headers={"origin": "http://viewer.example", "access-control-request-method": "POST"})
    assert r.status_code == 200 and r.headers["access-control-allow-origin"] == "http://viewer.example"
    r = c.get("/health", headers={"origin": "http://other.example"})
    assert "access-control-allow-origin" not in r.headers


def test_max_links_setting_reaches_the_parser(make_client):
    c = make_client(max_links=2)
    three = ('<robot name="r"><link name="a"/><link name="b"/><link name="c"/>'
             '<joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>'
             '<joint name="j2" type="fixed"><parent link="b"/><child link="c"/></joint></robot>')
    r = c.post("/models", content=three, headers={"content-type": "application/xml"})
    assert r.status_code == 413 and "limit" in r.json()["detail"]  # docs/design.md: over a limit, 413
