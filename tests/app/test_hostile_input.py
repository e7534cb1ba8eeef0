"""Hostile and malformed input at the API level: every item of ``tests/corpus/manifest.yaml``.

Each URDF, DH table and request of the corpus is sent to the service (in-process, through
its ASGI app). It must get the expected 4xx, an ``application/problem+json`` body whose
``detail`` names the problem, and leave the service healthy: ``/health`` answers 200, the
fixture model still gives the same FK, and nothing was registered. XML bombs are refused
with bounded memory and without touching the file system or the network.
"""

from __future__ import annotations

import io
import json
import pickle
import sys
import threading
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import yaml
from fastapi.testclient import TestClient
from numpy.lib import format as npy_format

from app.main import create_app
from app.settings import Settings
from tests.paths import CORPUS

MANIFEST = yaml.safe_load((CORPUS / "manifest.yaml").read_text())
ARM = (CORPUS / "fixture_arm.urdf").read_bytes()
ARM_Q = [0.3, -0.7, 0.2]

#: limits of the "small" app used by the over-the-limit items
SMALL_LIMITS = {"max_model_bytes": 2048, "max_request_bytes": 8192, "max_batch": 5, "max_links": 5,
                "max_archive_bytes": 65536, "max_archive_extracted_bytes": 65536, "max_archive_members": 50}
#: the xacro sandbox of the main app: bombs stop within seconds
MAIN_LIMITS = {"xacro_cpu_seconds": 2, "xacro_memory_bytes": 512 * 1024 * 1024}
#: peak Python heap of the whole request while refusing an XML bomb
BOMB_PEAK_BYTES = 8 * 1024 * 1024

PROBLEM = "application/problem+json"

# ---------------------------------------------------------------- process-wide audit hook
_AUDIT = {"on": False, "events": []}
_AUDIT_LOCK = threading.Lock()


def _hook(event, args):
    if _AUDIT["on"] and event in ("open", "socket.connect", "socket.getaddrinfo", "urllib.Request"):
        target = str(args[0]) if args else ""
        if event != "open" or "passwd" in target or target.endswith(".dtd"):
            _AUDIT["events"].append((event, target))


sys.addaudithook(_hook)


class _App:
    def __init__(self, client: TestClient, model_id: str):
        self.client = client
        self.model_id = model_id
        self.baseline = self.fk()
        self.stored = self.stored_ids()

    def fk(self):
        r = self.client.post(f"/models/{self.model_id}/fk", json={"q": ARM_Q, "links": "all"})
        assert r.status_code == 200, r.text
        return r.json()["poses"]

    def stored_ids(self):
        r = self.client.get("/models")
        assert r.status_code == 200, r.text
        return sorted(m["id"] for m in r.json() if m["source"] in ("upload", "dh"))

    def assert_healthy(self):
        r = self.client.get("/health")
        assert r.status_code == 200 and r.json()["status"] == "ok"
        assert self.fk() == self.baseline
        assert self.stored_ids() == self.stored


def _make_app(tmp_path_factory, **limits) -> tuple[TestClient, str]:
    settings = Settings(data_dir=tmp_path_factory.mktemp("data"), **limits)
    client = TestClient(create_app(settings), raise_server_exceptions=False)
    client.__enter__()
    r = client.post("/models", content=ARM, headers={"Content-Type": "application/xml"})
    assert r.status_code == 201, r.text
    return client, r.json()["id"]


@pytest.fixture(scope="module")
def apps(tmp_path_factory):
    main_client, main_id = _make_app(tmp_path_factory, **MAIN_LIMITS)
    small_client, small_id = _make_app(tmp_path_factory, **SMALL_LIMITS)
    yield {"main": _App(main_client, main_id), "small": _App(small_client, small_id)}
    main_client.__exit__(None, None, None)
    small_client.__exit__(None, None, None)


def assert_problem(r, status: int, contains: str):
    assert r.status_code == status, f"{r.status_code}: {r.text[:500]}"
    assert r.headers["content-type"].startswith(PROBLEM), r.headers["content-type"]
    body = r.json()
    assert {"type", "title", "status", "detail"} <= body.keys(), body
    assert body["status"] == status
    assert body["type"].startswith("urn:kinematics:problem:")
    assert contains.lower() in body["detail"].lower(), body["detail"]
    return body


# ---------------------------------------------------------------- URDF and DH corpus
def _ids(items, key="file"):
    return [Path(i[key]).stem for i in items]


@pytest.mark.parametrize("item", MANIFEST["urdf"], ids=_ids(MANIFEST["urdf"]))
def test_corpus_urdf_upload(apps, item):
    app = apps["main"]
    data = (CORPUS / item["file"]).read_bytes()
    r = app.client.post("/models", content=data, headers={"Content-Type": "application/xml"})
    assert_problem(r, item["status"], item.get("api_contains", item["contains"]))
    # the JSON form of the same upload is refused too (an empty string reaches the parser)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = None
    if text is not None:
        r = app.client.post("/models", json={"urdf": text, "name": "corpus"})
        body = assert_problem(r, item["status"], item["contains"])
        assert body["type"].endswith(item.get("api_type", "invalid-urdf"))
    app.assert_healthy()


@pytest.mark.parametrize("item", MANIFEST["dh"], ids=_ids(MANIFEST["dh"]))
def test_corpus_dh_table(apps, item):
    app = apps["main"]
    data = (CORPUS / item["file"]).read_bytes()
    r = app.client.post("/models/dh", content=data, headers={"Content-Type": "application/json"})
    assert_problem(r, item["status"], item.get("api_contains", item["contains"]))
    app.assert_healthy()


HOSTILE = [i for i in MANIFEST["urdf"] if i.get("hostile")]


@pytest.mark.parametrize("item", HOSTILE, ids=_ids(HOSTILE))
def test_xml_bombs_bounded_memory_no_io(apps, item):
    app = apps["main"]
    data = (CORPUS / item["file"]).read_bytes()
    with _AUDIT_LOCK:
        _AUDIT["events"] = []
        _AUDIT["on"] = True
        tracemalloc.start()
        try:
            r = app.client.post("/models", content=data, headers={"Content-Type": "application/xml"})
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
            _AUDIT["on"] = False
    assert_problem(r, 422, "DTD")
    assert peak < BOMB_PEAK_BYTES, peak
    assert _AUDIT["events"] == []
    app.assert_healthy()


# ---------------------------------------------------------------- requests
def npy_body(kind: str) -> bytes:
    buf = io.BytesIO()
    if kind == "object":
        np.save(buf, np.array([[0.0, {"x": 1}, 0.0]], dtype=object), allow_pickle=True)
    elif kind == "pickle":
        return pickle.dumps([[0.0, 0.0, 0.0]])
    elif kind == "truncated":
        np.save(buf, np.zeros((4, 3)))
        return buf.getvalue()[: len(buf.getvalue()) - 40]
    elif kind == "3d":
        np.save(buf, np.zeros((2, 3, 1)))
    elif kind == "strings":
        np.save(buf, np.array([["a", "b", "c"]]))
    elif kind == "nan":
        np.save(buf, np.array([[0.0, np.nan, 0.0]]))
    elif kind == "wide":
        np.save(buf, np.zeros((2, 4)))
    elif kind == "huge_header":  # declares 3e12 float64 (24 TB) and carries none of them
        npy_format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (10**12, 3)})
    else:
        raise ValueError(kind)
    return buf.getvalue()


def _padded_urdf(size: int) -> bytes:
    pad = size - len(ARM) - len(b"<!--  -->\n")
    return ARM + b"<!-- " + b"x" * pad + b" -->\n"


def _chain(n_links: int) -> bytes:
    links = "".join(f'<link name="l{i}"/>' for i in range(n_links))
    joints = "".join(
        f'<joint name="j{i}" type="fixed"><parent link="l{i - 1}"/><child link="l{i}"/></joint>'
        for i in range(1, n_links)
    )
    return f'<robot name="chain">{links}{joints}</robot>'.encode()


def generated_body(item) -> tuple[object, str]:
    """(content, content type) of a generated request body."""
    kind, size = item["generate"], item["size"]
    if kind == "urdf_bytes":
        return _padded_urdf(size), "application/xml"
    if kind == "urdf_chunked":  # an iterator: sent chunked, without Content-Length
        data = _padded_urdf(size)
        return (data[i : i + 512] for i in range(0, len(data), 512)), "application/xml"
    if kind == "dh_bytes":
        table = {"convention": "standard", "joints": [{"type": "revolute", "a": 1, "alpha": 0, "d": 0, "theta": 0}]}
        text = json.dumps(table)
        return (text + " " * (size - len(text))).encode(), "application/json"
    if kind == "fk_bytes":
        text = json.dumps({"q": ARM_Q})
        return (text + " " * (size - len(text))).encode(), "application/json"
    if kind == "batch":
        return json.dumps({"q": [ARM_Q] * size}).encode(), "application/json"
    if kind == "npy_batch":
        buf = io.BytesIO()
        np.save(buf, np.zeros((size, 3)))
        return buf.getvalue(), "application/x-npy"
    if kind == "chain":
        return _chain(size), "application/xml"
    raise ValueError(kind)


@pytest.mark.parametrize("item", MANIFEST["requests"], ids=[i["id"] for i in MANIFEST["requests"]])
def test_corpus_request(apps, item):
    app = apps[item.get("app", "main")]
    path = item["path"].replace("{model}", app.model_id)
    headers = dict(item.get("headers", {}))
    kwargs = {}
    if "json" in item:
        kwargs["json"] = item["json"]
    elif "body" in item:
        kwargs["content"] = item["body"].encode()
        headers.setdefault("Content-Type", item.get("content_type", "application/json"))
    elif "npy" in item:
        kwargs["content"] = npy_body(item["npy"])
        headers["Content-Type"] = "application/x-npy"
    elif "generate" in item:
        kwargs["content"], headers["Content-Type"] = generated_body(item)
    r = app.client.request(item["method"], path, headers=headers, **kwargs)
    assert_problem(r, item["status"], item["contains"])
    app.assert_healthy()


def test_limits_hold_at_the_boundary(apps):
    """Just under each small limit is accepted, so the 413s above are the limits, not other errors."""
    app = apps["small"]
    r = app.client.post("/models", content=_padded_urdf(SMALL_LIMITS["max_model_bytes"]),
                        headers={"Content-Type": "application/xml"})
    assert r.status_code == 201, r.text
    assert app.client.delete(f"/models/{r.json()['id']}").status_code == 204
    r = app.client.post("/models", content=_chain(SMALL_LIMITS["max_links"]), headers={"Content-Type": "application/xml"})
    assert r.status_code == 201, r.text
    assert app.client.delete(f"/models/{r.json()['id']}").status_code == 204
    r = app.client.post(f"/models/{app.model_id}/fk", json={"q": [ARM_Q] * SMALL_LIMITS["max_batch"]})
    assert r.status_code == 200 and len(r.json()["poses"]) == SMALL_LIMITS["max_batch"]
    app.assert_healthy()


def test_path_like_robot_name_stays_a_name(apps):
    """A robot called ``../../etc/passwd`` gets a hash id; its name is only a label, no file is made from it."""
    app = apps["main"]
    data = ARM.replace(b'name="corpus_arm"', b'name="../../etc/passwd"')
    r = app.client.post("/models", content=data, headers={"Content-Type": "application/xml"})
    assert r.status_code == 201, r.text
    info = r.json()
    assert info["id"].startswith("u-") and "/" not in info["id"] and info["name"] == "../../etc/passwd"
    assert app.client.get(f"/models/{info['id']}/urdf").content == data
    assert app.client.delete(f"/models/{info['id']}").status_code == 204
    app.assert_healthy()


def test_corpus_size():
    total = sum(len(MANIFEST[k]) for k in ("urdf", "dh", "requests"))
    assert total >= 30


# ---------------------------------------------------------------- descriptions: xacro, MJCF, archives
from tests.corpus import archives  # noqa: E402

DESCRIPTIONS = MANIFEST["descriptions"]


def _desc_ids(items):
    return [Path(i["file"]).stem if "file" in i else i["generate"] for i in items]


def _description_body(item) -> tuple[bytes, str]:
    if "generate" in item:
        return archives.build(item["generate"]), archives.media_type(item["generate"])
    data = (CORPUS / item["file"]).read_bytes()
    return data, "application/octet-stream" if item["file"].endswith(".bin") else "application/xml"


@pytest.mark.parametrize("item", DESCRIPTIONS, ids=_desc_ids(DESCRIPTIONS))
def test_corpus_description_upload(apps, item):
    """Each hostile description: a clean 4xx naming the problem, nothing read, the service alive."""
    app = apps[item.get("app", "main")]
    data, content_type = _description_body(item)
    r = app.client.post("/models", content=data, headers={"Content-Type": content_type})
    assert_problem(r, item["status"], item["contains"])
    if "secret" in item:
        assert item["secret"] not in r.text
    if "file" in item and content_type == "application/xml":  # the JSON form too
        r = app.client.post("/models", json={"urdf": data.decode("utf-8"), "name": "corpus"})
        assert_problem(r, item["status"], item["contains"])
    app.assert_healthy()
