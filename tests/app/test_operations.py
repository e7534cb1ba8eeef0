"""Operations: ``GET /metrics`` (Prometheus), ``X-Request-ID``, "did you mean" in 404/422 problems."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from kinematics.errors import did_you_mean

PROBLEM = "application/problem+json"


def sample(text: str, name: str, **labels) -> float:
    """The value of one sample of the exposition (0 when absent)."""
    for line in text.splitlines():
        if line.startswith("#") or not line.startswith(name):
            continue
        head, _, value = line.rpartition(" ")
        metric, _, rest = head.partition("{")
        if metric != name:
            continue
        got = dict(re.findall(r'(\w+)="([^"]*)"', rest))
        if all(got.get(k) == str(v) for k, v in labels.items()):
            return float(value)
    return 0.0


# ---------------------------------------------------------------- /metrics
def test_metrics_requests_by_route_template_and_status(api_client):
    before = api_client.get("/metrics").text
    api_client.post("/models/ur5/fk", json={"q": [0.0] * 6})
    api_client.post("/models/ur3/fk", json={"q": [[0.0] * 6, [0.1] * 6]})
    api_client.post("/models/ur5/fk", json={"q": [0.0]})  # 422
    api_client.get("/no/such/route/12345")
    r = api_client.get("/metrics")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/plain")
    text = r.text
    fk = dict(method="POST", route="/models/{model_id}/fk")
    assert sample(text, "kin_http_requests_total", **fk, status=200) - \
        sample(before, "kin_http_requests_total", **fk, status=200) == 2
    assert sample(text, "kin_http_requests_total", **fk, status=422) - \
        sample(before, "kin_http_requests_total", **fk, status=422) == 1
    assert sample(text, "kin_http_request_duration_seconds_count", **fk, status=200) - \
        sample(before, "kin_http_request_duration_seconds_count", **fk, status=200) == 2
    # raw paths never become labels: one template for every model id, one label for unmatched paths
    assert "/models/ur5/fk" not in text and "/no/such/route" not in text
    assert sample(text, "kin_http_requests_total", method="GET", route="unmatched", status=404) >= 1
    assert sample(text, "kin_configurations_total", operation="fk") - \
        sample(before, "kin_configurations_total", operation="fk") == 3


def test_metrics_ik_outcomes_and_iterations(api_client):
    before = api_client.get("/metrics").text
    fk = api_client.post("/models/ur5/fk", json={"q": [0.3, -1.0, 1.2, -0.5, 0.4, 0.2], "links": ["tool0"]}).json()
    reachable = fk["poses"]["tool0"]["matrix"]
    far = [[1, 0, 0, 10.0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    body = {"link": "tool0", "target": [reachable, far], "restarts": 0}
    r = api_client.post("/models/ur5/ik", json=body)
    assert r.status_code == 200, r.text
    success = r.json()["success"]
    text = api_client.get("/metrics").text

    def delta(name, **labels):
        return sample(text, name, **labels) - sample(before, name, **labels)

    assert delta("kin_ik_targets_total", outcome="success") == sum(success)
    assert delta("kin_ik_targets_total", outcome="failure") == len(success) - sum(success) >= 1
    assert delta("kin_ik_iterations_count") == len(success)
    assert delta("kin_ik_iterations_sum") == sum(r.json()["iterations"])
    assert delta("kin_configurations_total", operation="ik") == len(success)


def test_metrics_multiprocess_mode(tmp_path):
    """With PROMETHEUS_MULTIPROC_DIR, /metrics aggregates the values every process wrote there."""
    code = """
import os
from fastapi.testclient import TestClient
from app.main import create_app
from app.settings import Settings
with TestClient(create_app(Settings(data_dir=os.environ['DATA']))) as c:
    for _ in range(3):
        assert c.get('/health').status_code == 200
    print(c.get('/metrics').text)
"""
    env = {"PROMETHEUS_MULTIPROC_DIR": str(tmp_path / "prom"), "DATA": str(tmp_path / "data"),
           "PATH": "/usr/bin:/bin"}
    (tmp_path / "prom").mkdir()
    (tmp_path / "data").mkdir()
    outs = [subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
            for _ in range(2)]  # two "workers", one after the other, sharing the directory
    health = dict(method="GET", route="/health", status=200)
    assert sample(outs[0], "kin_http_requests_total", **health) == 3
    assert sample(outs[1], "kin_http_requests_total", **health) == 6  # the first worker's counts included
    assert list((tmp_path / "prom").glob("*.db"))


# ---------------------------------------------------------------- X-Request-ID
def test_request_id_generated_and_echoed(api_client):
    a, b = api_client.get("/health"), api_client.get("/health")
    for r in (a, b):
        assert re.fullmatch(r"[0-9a-f]{32}", r.headers["x-request-id"])
    assert a.headers["x-request-id"] != b.headers["x-request-id"]


def test_request_id_kept_and_in_problem_details(api_client):
    r = api_client.get("/health", headers={"X-Request-ID": "pipeline-42.step:7"})
    assert r.headers["x-request-id"] == "pipeline-42.step:7"
    r = api_client.get("/models/nope", headers={"X-Request-ID": "abc-123"})
    assert r.status_code == 404 and r.headers["content-type"] == PROBLEM
    assert r.headers["x-request-id"] == "abc-123" and r.json()["request_id"] == "abc-123"
    r = api_client.post("/models/ur5/fk", json={"q": "x"})
    assert r.status_code == 422 and r.json()["request_id"] == r.headers["x-request-id"]
    # the body-size middleware's own answers too
    r = api_client.post("/models/ur5/fk", content=b"{}", headers={"Content-Length": "10000000000"})
    assert r.status_code == 413 and r.json()["request_id"] == r.headers["x-request-id"]


def test_unsafe_request_id_is_replaced(api_client):
    r = api_client.get("/health", headers={"X-Request-ID": "bad id\twith spaces" + "x" * 200})
    assert re.fullmatch(r"[0-9a-f]{32}", r.headers["x-request-id"])


def test_request_id_in_500_and_its_log(get_with_a_bug, caplog):
    r = get_with_a_bug("/models/ur5", headers={"X-Request-ID": "trace-500"})
    assert r.status_code == 500
    assert r.headers["x-request-id"] == "trace-500" and r.json()["request_id"] == "trace-500"
    assert "trace-500" in caplog.text


def test_request_id_log_filter():
    import logging

    from app.errors import REQUEST_ID, RequestIdFilter

    record = logging.LogRecord("app", logging.INFO, __file__, 1, "m", None, None)
    token = REQUEST_ID.set("rid-1")
    try:
        assert RequestIdFilter().filter(record) and record.request_id == "rid-1"
    finally:
        REQUEST_ID.reset(token)


# ---------------------------------------------------------------- did you mean
def test_did_you_mean_helper():
    assert did_you_mean("elbo", ["shoulder", "elbow"]) == "; did you mean 'elbow'? valid names: shoulder, elbow"
    assert did_you_mean("zzz", ["a", "b"], "ids") == "; valid ids: a, b"
    long = did_you_mean("q", [f"n{i}" for i in range(30)], limit=5)
    assert long.endswith("n4, ... (30 in all)")
    assert did_you_mean("x", []) == ""


def test_unknown_model_suggests(api_client):
    r = api_client.get("/models/ur6")
    assert r.status_code == 404
    detail = r.json()["detail"]
    assert detail.startswith("unknown model 'ur6'") and "did you mean 'ur5'" in detail and "valid model ids:" in detail
    assert "in all)" in detail  # the list is truncated


def test_unknown_link_suggests(api_client):
    r = api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "links": ["tool_0"]})
    assert r.status_code == 404
    body = r.json()
    assert body["detail"].startswith("unknown link 'tool_0'") and "did you mean 'tool0'" in body["detail"]
    assert body["link"] == "tool_0"


def test_unknown_joint_suggests(api_client):
    q = {"shoulder_pan_joint": 0, "shoulder_lift_joint": 0, "elbo_joint": 0, "wrist_1_joint": 0,
         "wrist_2_joint": 0, "wrist_3_joint": 0}
    r = api_client.post("/models/ur5/fk", json={"q": q})
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert "unknown joint name(s): elbo_joint" in detail and "did you mean 'elbow_joint'" in detail
    assert "valid joint names: shoulder_pan_joint" in detail


# ---------------------------------------------------------------- OpenAPI truth
def _ops(doc):
    return {(m, p): op for p, item in doc["paths"].items() for m, op in item.items()}


@pytest.mark.parametrize("settings, secured", [
    ({}, set()),
    ({"api_key": "k"}, {"write"}),
    ({"api_key": "k", "api_key_for_reads": True}, {"write", "read"}),
])
def test_openapi_declares_security_as_configured(make_client, settings, secured):
    doc = make_client(**settings).get("/openapi.json").json()
    ops = _ops(doc)
    write = ops[("post", "/models")]
    assert bool(ops[("delete", "/models/{model_id}")].get("security")) == ("write" in secured)
    read = ops[("post", "/models/{model_id}/fk")]
    assert bool(write.get("security")) == ("write" in secured)
    assert bool(read.get("security")) == ("read" in secured)
    for op, kind in ((write, "write"), (read, "read")):
        assert ("401" in op["responses"]) == (kind in secured)
        assert ("403" in op["responses"]) == (kind in secured)
    assert ("securitySchemes" in doc.get("components", {})) == bool(secured)
    assert not ops[("get", "/health")].get("security") and not ops[("get", "/metrics")].get("security")


def test_openapi_documents_403_on_bundled_delete_and_422_on_dh_of_a_tree(api_client):
    ops = _ops(api_client.get("/openapi.json").json())
    # without a key, the 403 of a read-only model stays documented (the key's 401 does not)
    assert "403" in ops[("delete", "/models/{model_id}")]["responses"]
    assert "401" not in ops[("delete", "/models/{model_id}")]["responses"]
    assert "422" in ops[("get", "/models/{model_id}/dh")]["responses"]
    assert api_client.delete("/models/ur5").status_code == 403
    tree = next(m["id"] for m in api_client.get("/models").json() if m["id"] in ("talos", "romeo", "icub", "baxter"))
    assert api_client.get(f"/models/{tree}/dh").status_code == 422


# ---------------------------------------------------------------- what each answer says
def test_links_given_as_a_string_says_what_to_send(api_client):
    r = api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "links": "tool0"})
    assert r.status_code == 422 and r.headers["content-type"] == PROBLEM
    body = r.json()
    assert body["field"] == "links"
    assert body["detail"] == 'links must be a list of link names or "all"; got the string "tool0" -- did you mean ["tool0"]?'
    r = api_client.post("/models/ur5/velocity", json={"q": [0.0] * 6, "qdot": [0.0] * 6, "links": "tool0"})
    assert r.status_code == 422 and 'did you mean ["tool0"]' in r.json()["detail"]
    # "all" and lists are still fine
    assert api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "links": "all"}).status_code == 200
    assert api_client.post("/models/ur5/fk", json={"q": [0.0] * 6, "links": ["tool0"]}).status_code == 200


def test_reupload_with_a_new_name_renames_and_says_so(make_client):
    from app.schemas import TWO_LINK_URDF

    a = make_client()
    r1 = a.post("/models?name=first", content=TWO_LINK_URDF, headers={"content-type": "application/xml"})
    assert r1.status_code == 201 and r1.json()["name"] == "first" and r1.json()["note"] is None
    mid = r1.json()["id"]
    b = make_client()  # a second replica on the same data directory caches the model under its old name
    assert b.get(f"/models/{mid}").json()["name"] == "first"
    r2 = a.post("/models?name=second", content=TWO_LINK_URDF, headers={"content-type": "application/xml"})
    assert r2.status_code == 200 and r2.json()["id"] == mid and r2.json()["name"] == "second"
    assert "renamed from 'first' to 'second'" in r2.json()["note"]
    assert b.get(f"/models/{mid}").json()["name"] == "second"  # the rename reaches every replica
    assert {m["id"]: m["name"] for m in b.get("/models").json()}[mid] == "second"
    # the same content and name, or no name: nothing changes, and the note says that
    r3 = a.post("/models", content=TWO_LINK_URDF, headers={"content-type": "application/xml"})
    assert r3.status_code == 200 and r3.json()["name"] == "second" and "nothing changed" in r3.json()["note"]


def test_405_allow_lists_every_method_of_the_path(api_client):
    r = api_client.request("PATCH", "/models/ur5")
    assert r.status_code == 405 and r.headers["allow"] == "GET, DELETE" and r.json()["request_id"]
    assert "allowed: GET, DELETE" in r.json()["detail"]


def test_deleting_a_bundled_model_is_403_read_only(make_client):
    for client in (make_client(), make_client(api_key="k")):
        headers = {"X-API-Key": "k"}
        r = client.delete("/models/ur5", headers=headers)
        assert r.status_code == 403 and r.json()["type"] == "urn:kinematics:problem:read-only-model"
    assert make_client(api_key="k").delete("/models/ur5").status_code == 401  # the key is asked for first


def test_405_allow_of_a_static_path_beside_a_template(api_client):
    # /models/dh is its own resource (POST), not also GET/DELETE /models/{model_id}
    r = api_client.options("/models/dh")
    assert r.status_code == 405 and r.headers["allow"] == "POST"


# ---------------------------------------------------------------- a live server: 2 workers, JSON logs
def test_live_two_workers_metrics_and_json_logs(tmp_path):
    """uvicorn with 2 workers, PROMETHEUS_MULTIPROC_DIR and KIN_LOG_FORMAT=json: /metrics adds up
    both workers (requests, models compiled and cached, IK, configurations) and every access and
    error record is one JSON object with the request id."""
    import json

    import httpx

    from tests.live import LiveServer

    prom, data = tmp_path / "prom", tmp_path / "data"
    prom.mkdir()
    data.mkdir()
    env = {"PROMETHEUS_MULTIPROC_DIR": str(prom), "KIN_LOG_FORMAT": "json"}
    with LiveServer(data, tmp_path / "uvicorn.log", workers=2, env=env) as live, \
            httpx.Client(base_url=live.url, timeout=60) as c:
        n = 12  # new connections: the kernel spreads them over both workers
        for i in range(n):
            r = httpx.post(live.url + "/models/ur5/fk", json={"q": [0.1 * i] * 6}, headers={"X-Request-ID": f"fk-{i}"})
            assert r.status_code == 200
        assert c.post("/models/ur5/ik", json={"link": "tool0", "target": {"xyz": [0.4, 0.1, 0.3], "rpy": [3.1, 0, 0]},
                                              "restarts": 2}).status_code == 200
        assert c.get("/models/ur6", headers={"X-Request-ID": "nf-1"}).status_code == 404
        text = c.get("/metrics").text
        log = live.log()
    fk = dict(method="POST", route="/models/{model_id}/fk", status=200)
    assert sample(text, "kin_http_requests_total", **fk) == n
    assert sample(text, "kin_http_request_duration_seconds_count", **fk) == n
    assert sample(text, "kin_http_requests_total", method="GET", route="/models/{model_id}", status=404) == 1
    assert sample(text, "kin_configurations_total", operation="fk") == n
    assert sample(text, "kin_ik_targets_total", outcome="success") + sample(text, "kin_ik_targets_total",
                                                                            outcome="failure") == 1
    assert sample(text, "kin_ik_iterations_count") == 1
    # each worker compiled its warm-up model and the UR5 (2 or 4: one worker may have served every FK)
    assert sample(text, "kin_models_compiled_total") >= 3
    assert sample(text, "kin_models_cached") >= 1
    assert len(list(prom.glob("*.db"))) >= 2  # both workers wrote their values
    records = [json.loads(line) for line in log.splitlines() if line.startswith("{")]
    access = [r for r in records if r["logger"] == "app.access"]
    assert {r["pid"] for r in access} <= {r["pid"] for r in records}
    by_id = {r["request_id"]: r for r in access}
    one = by_id["fk-3"]
    assert one["method"] == "POST" and one["path"] == "/models/ur5/fk" and one["route"] == "/models/{model_id}/fk"
    assert one["status"] == 200 and one["duration_ms"] > 0 and one["level"] == "info" and one["time"].endswith("+00:00")
    nf = by_id["nf-1"]
    assert nf["status"] == 404 and nf["problem"] == "urn:kinematics:problem:unknown-model" and "ur5" in nf["detail"]
    assert sum(r["path"] == "/models/ur5/fk" for r in access) == n
    assert '"GET /metrics HTTP/1.1"' not in log  # uvicorn's text access log is replaced


def test_json_error_log_has_the_exception_and_request_id(api_data_dir, capsys):
    import json

    from fastapi.testclient import TestClient

    from app import logs
    from app.main import create_app
    from app.settings import Settings

    try:
        app = create_app(Settings(data_dir=api_data_dir, log_format="json"))
        with TestClient(app, raise_server_exceptions=False) as c:
            def broken(model_id):
                raise RuntimeError("simulated bug")

            app.state.registry.get = broken
            assert c.get("/models/ur5", headers={"X-Request-ID": "trace-json"}).status_code == 500
            assert c.post("/models/ur5/fk", json={"q": "x"}, headers={"X-Request-ID": "bad-q"}).status_code == 422
        err = capsys.readouterr().err
    finally:
        logs.reset()
    records = [json.loads(line) for line in err.splitlines() if line.startswith("{")]
    bug = next(r for r in records if r["logger"] == "app.errors")
    assert bug["level"] == "error" and bug["request_id"] == "trace-json" and bug["status"] == 500
    assert bug["exception"] == "RuntimeError: simulated bug" and "Traceback" in bug["traceback"]
    assert bug["problem"] == "urn:kinematics:problem:internal-error" and bug["path"] == "/models/ur5"
    access = {r["request_id"]: r for r in records if r["logger"] == "app.access"}
    assert access["trace-json"]["status"] == 500 and access["trace-json"]["level"] == "error"
    assert access["bad-q"]["status"] == 422 and access["bad-q"]["problem"] == "urn:kinematics:problem:validation-error"
    assert access["bad-q"]["detail"].startswith("q must be")


def test_log_format_setting(monkeypatch):
    from app.settings import Settings

    assert Settings().log_format == "text"
    monkeypatch.setenv("KIN_LOG_FORMAT", "json")
    assert Settings().log_format == "json"
    monkeypatch.setenv("KIN_LOG_FORMAT", "xml")
    with pytest.raises(Exception):
        Settings()


def test_metrics_models_compiled_and_cached(api_client):
    from app.schemas import TWO_LINK_URDF

    before = api_client.get("/metrics").text
    mid = api_client.post("/models", content=TWO_LINK_URDF, headers={"content-type": "application/xml"}).json()["id"]
    for _ in range(3):  # compiled once, then served from the compiled form
        assert api_client.post(f"/models/{mid}/fk", json={"q": [0.1, 0.2]}).status_code == 200
    text = api_client.get("/metrics").text
    assert sample(text, "kin_models_compiled_total") - sample(before, "kin_models_compiled_total") == 1
    assert sample(text, "kin_models_cached") >= 1
