"""The short way of /fk and /jacobian (app.adapter.PlainJSONRoute): a JSON body without a query
string skips FastAPI's dependency resolution and answers exactly what the usual way answers."""

from __future__ import annotations

import pytest

from app.deps import require_read_key

Q = [0.1, -0.4, 0.7, -1.2, 0.3, 2.0]

#: (path, JSON body or raw bytes) answered alike by both ways: answers and problems
CASES = [
    ("/models/ur5/fk", {"q": Q}),
    ("/models/ur5/fk", {"q": [Q, Q], "links": "all", "format": "compact"}),
    ("/models/ur5/fk", {"q": {"shoulder_pan_joint": 0.5}, "format": "matrix", "point": [0, 0, 0.1]}),
    ("/models/ur5/fk", {"q": [9.0] * 6, "limits": "refuse"}),
    ("/models/ur5/fk", {"q": Q, "links": ["no_such_link"]}),
    ("/models/ur5/fk", {"q": [0.0] * 5}),
    ("/models/ur5/fk", {"q": Q, "unknown": 1}),
    ("/models/ur5/fk", b""),
    ("/models/ur5/fk", b"{not json"),
    ("/models/nope/fk", {"q": Q}),
    ("/models/ur5/jacobian", {"q": Q}),
    ("/models/ur5/jacobian", {"q": [Q, Q], "reference": "local", "link": "wrist_2_link"}),
    ("/models/ur5/jacobian", {"q": Q, "representation": "rpy"}),
    ("/models/ur5/jacobian", {"q": Q, "reference": "sideways"}),
]


def _post(client, path, body, query=""):
    if isinstance(body, bytes):
        return client.post(path + query, content=body, headers={"content-type": "application/json"})
    return client.post(path + query, json=body)


@pytest.mark.parametrize("path,body", CASES)
def test_both_ways_answer_alike(api_client, path, body):
    usual_calls = []

    async def counted():  # the router's dependency: FastAPI resolves it on the usual way only
        usual_calls.append(1)

    api_client.app.dependency_overrides[require_read_key] = counted
    try:
        plain = _post(api_client, path, body)
        assert usual_calls == []  # taken the short way
        # a query parameter at its default value: the usual way, the same request otherwise
        usual = _post(api_client, path, body, "?limits=report")
        assert usual_calls == [1]
    finally:
        api_client.app.dependency_overrides.clear()
    assert plain.status_code == usual.status_code
    assert plain.headers["content-type"] == usual.headers["content-type"]
    if plain.headers["content-type"].startswith("application/problem+json"):
        a, b = plain.json(), usual.json()
        a.pop("request_id", None), b.pop("request_id", None)
        a.pop("instance", None), b.pop("instance", None)
        assert a == b
    else:
        assert plain.content == usual.content


def test_npy_and_other_content_types_take_the_usual_way(api_client):
    import io

    import numpy as np

    calls = []

    async def counted():
        calls.append(1)

    api_client.app.dependency_overrides[require_read_key] = counted
    try:
        buf = io.BytesIO()
        np.save(buf, np.array([Q]))
        r = api_client.post("/models/ur5/fk", content=buf.getvalue(), headers={"content-type": "application/x-npy"})
        assert r.status_code == 200 and calls == [1]
        r = api_client.post("/models/ur5/fk", content=b"q=1", headers={"content-type": "text/plain"})
        assert r.status_code == 415 and calls == [1, 1]
    finally:
        api_client.app.dependency_overrides.clear()
