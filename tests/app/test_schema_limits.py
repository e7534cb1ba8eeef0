"""Limits that come from settings are stated in the OpenAPI schema as the server is configured, so a
schema-valid request is not refused for its size: ``samples`` <= ``max_workspace_samples``
(``maximum``), batches of q, qdot and IK targets <= ``max_batch`` (``maxItems``)."""

from __future__ import annotations

import jsonschema
import pytest

from kinematics import api


def _property(doc: dict, schema: str, field: str) -> dict:
    return doc["components"]["schemas"][schema]["properties"][field]


@pytest.mark.parametrize("max_batch, max_samples", [(3, 2000), (7, 5000)])
def test_the_schema_states_the_configured_limits(make_client, max_batch, max_samples):
    doc = make_client(max_batch=max_batch, max_workspace_samples=max_samples).get("/openapi.json").json()
    assert _property(doc, "WorkspaceRequest", "samples")["maximum"] == max_samples
    for schema, field in (("FKRequest", "q"), ("JacobianRequest", "q"), ("VelocityRequest", "q"),
                          ("VelocityRequest", "qdot"), ("TaskRequest", "q")):
        q = _property(doc, schema, field)
        jsonschema.validate([[0.0] * 6] * max_batch, q)
        jsonschema.validate([{"j": 0.0}] * max_batch, q)
        jsonschema.validate([0.0] * (max_batch + 1), q)  # one vector is one configuration, whatever its length
        for batch in ([[0.0] * 6] * (max_batch + 1), [{"j": 0.0}] * (max_batch + 1)):
            with pytest.raises(jsonschema.ValidationError):
                jsonschema.validate(batch, q)
    target = _property(doc, "IKRequest", "target")
    assert [b.get("maxItems") for b in target["anyOf"]].count(max_batch) == 1
    assert "maxItems" not in target["anyOf"][2]  # a 4x4 matrix is one target


def test_at_the_limit_accepted_and_over_it_refused(make_client):
    client = make_client(max_batch=3, max_workspace_samples=2000)
    r = client.post("/models/ur5/workspace", json={"samples": 2000, "link": "tool0"})
    assert r.status_code == 200 and r.json()["samples"] == 2000, r.text
    r = client.post("/models/ur5/workspace", json={"samples": 2001, "link": "tool0"})
    assert r.status_code == 413 and r.json()["limit"] == 2000, r.text
    Q = [[0.1] * 6] * 3
    assert client.post("/models/ur5/fk", json={"q": Q}).status_code == 200
    assert client.post("/models/ur5/velocity", json={"q": Q, "qdot": Q}).status_code == 200
    r = client.post("/models/ur5/fk", json={"q": Q + [[0.1] * 6]})
    assert r.status_code == 413 and r.json()["type"].endswith("batch-too-large"), r.text
    T = api.fk(client.app.state.registry.get("ur5").model, Q, links=["tool0"]).poses[:, 0].tolist()
    r = client.post("/models/ur5/ik", json={"target": T, "link": "tool0", "restarts": 0, "seed": Q[0]})
    assert r.status_code == 200 and all(r.json()["success"]), r.text
    r = client.post("/models/ur5/ik", json={"target": T + T[:1], "link": "tool0", "restarts": 0})
    assert r.status_code == 413, r.text
    assert r.json()["limit"] == 3
