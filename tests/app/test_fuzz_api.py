"""Schemathesis against the live OpenAPI document of the service (ASGI, in-process).

Every operation of ``/openapi.json`` gets generated requests (valid and invalid ones) within
a bounded budget (:data:`MAX_EXAMPLES` per operation). Path parameters are steered half of
the time to models that exist (a bundled arm, a DH preset, an uploaded tree with a mimic
joint), so the generated bodies reach the kinematics and not only the 404 path.

Checks: ``not_a_server_error`` (no 5xx, ever), then the conformance checks: the status
code, the content type and the body of every answer are those the schema documents
(problem+json errors included).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import pytest
import schemathesis
from schemathesis import GenerationMode
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from hypothesis.errors import Unsatisfiable
from schemathesis.checks import (
    content_type_conformance,
    not_a_server_error,
    response_schema_conformance,
    status_code_conformance,
)

from app.main import create_app
from app.settings import Settings
from tests.paths import CORPUS

pytestmark = pytest.mark.slow

#: generated requests per operation: 25 with KIN_TEST_FULL_COUNTS=1, 10 by default (with 25 the file took
#: 2.5-3 min of a 27-minute suite on a busy 2-core machine)
MAX_EXAMPLES = 25 if os.environ.get("KIN_TEST_FULL_COUNTS", "") not in ("", "0") else 10

ARM = (CORPUS / "fixture_arm.urdf").read_bytes()
MIMIC_TREE = b"""<robot name="fuzz_tree">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/>
  <joint name="ja" type="revolute"><parent link="base"/><child link="a"/><origin xyz="0 0 0.2"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="jb" type="prismatic"><parent link="base"/><child link="b"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.2" effort="1" velocity="1"/></joint>
  <joint name="jc" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 1 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/><mimic joint="ja" multiplier="-0.5" offset="0.1"/></joint>
</robot>"""


def _upload_id(data: bytes) -> str:
    return "u-" + hashlib.sha256(data).hexdigest()[:16]


#: model ids the path parameters are steered to (None: keep the generated id)
KNOWN_MODELS = ["ur5", "planar_2r", _upload_id(ARM), _upload_id(MIMIC_TREE)]
CHECKS = [not_a_server_error, status_code_conformance, content_type_conformance, response_schema_conformance]


@pytest.fixture(scope="module")
def fuzz_app(tmp_path_factory):
    app = create_app(Settings(data_dir=tmp_path_factory.mktemp("fuzz-data"), max_batch=1000))
    with TestClient(app) as client:  # runs the lifespan: the registry lives on app.state
        for data in (ARM, MIMIC_TREE):
            r = client.post("/models", content=data, headers={"Content-Type": "application/xml"})
            assert r.status_code in (200, 201), r.text
        app.state.fuzz_client = client
        yield app


@pytest.fixture(scope="module")
def api_schema(fuzz_app):
    return schemathesis.openapi.from_asgi("/openapi.json", fuzz_app)


def _operations() -> list[tuple[str, str]]:
    """(method, path) of every operation of the OpenAPI document (built without a lifespan)."""
    app = create_app(Settings(data_dir=CORPUS / "no-such-data-dir"))
    return [(m.upper(), p) for p, ops in app.openapi()["paths"].items() for m in ops]


OPERATIONS = _operations()
#: cases run per (operation, mode), for the closing report
RUN_COUNTS: dict[str, int] = {}


@pytest.mark.parametrize("mode", [GenerationMode.POSITIVE, GenerationMode.NEGATIVE], ids=str)
@pytest.mark.parametrize("method, path", OPERATIONS, ids=[f"{m} {p}" for m, p in OPERATIONS])
def test_api_conforms_to_its_schema(api_schema, method, path, mode):
    operation = api_schema[path][method]
    label = f"{method} {path} {mode}"
    RUN_COUNTS[label] = 0
    statuses: dict[int, int] = {}

    @given(case=operation.as_strategy(generation_mode=mode), model=st.sampled_from([None] * 4 + KNOWN_MODELS))
    @settings(
        max_examples=MAX_EXAMPLES,
        deadline=None,
        derandomize=True,
        phases=[Phase.explicit, Phase.generate],
        suppress_health_check=list(HealthCheck),
    )
    def run(case, model):
        RUN_COUNTS[label] += 1
        if model is not None and case.path_parameters and "model_id" in case.path_parameters:
            case.path_parameters["model_id"] = model
        response = case.call_and_validate(checks=CHECKS)
        statuses[response.status_code] = statuses.get(response.status_code, 0) + 1

    try:
        run()
    except Unsatisfiable:
        if mode == GenerationMode.NEGATIVE:
            pytest.skip("no input to make invalid (no parameters, no body)")
        raise
    assert RUN_COUNTS[label] > 0
    print(f"\nschemathesis {label}: {RUN_COUNTS[label]} cases, statuses {dict(sorted(statuses.items()))}")


# ------------------------------------------------------------------ valid requests that reach the math
VALID_MODELS = ["ur5", "planar_2r", "talos_reduced", _upload_id(ARM), _upload_id(MIMIC_TREE)]
value = st.one_of(st.floats(-1e6, 1e6), st.sampled_from([0.0, -0.0, 1e-300, -1e6, 1e6, 3.141592653589793]))


@st.composite
def kinematics_requests(draw, infos):
    """(model_id, kind, body): an FK or Jacobian request that is valid for the model."""
    model_id = draw(st.sampled_from(VALID_MODELS))
    info = infos[model_id]
    names, links = info["joint_names"], info["links"]
    n = draw(st.integers(1, 3))
    rows = [[draw(value) for _ in names] for _ in range(n)]
    shape = draw(st.sampled_from(["vector", "map", "batch", "batch_of_maps"]))
    if shape == "vector":
        q = rows[0]
    elif shape == "map":
        q = dict(zip(names, rows[0]))
    elif shape == "batch":
        q = rows
    else:
        q = [dict(zip(names, r)) for r in rows]
    kind = draw(st.sampled_from(["fk", "jacobian"]))
    body = {"q": q, "verify": draw(st.booleans())}
    if kind == "fk":
        body["links"] = draw(st.one_of(st.none(), st.just("all"), st.lists(st.sampled_from(links), min_size=1, max_size=4)))
        body["format"] = draw(st.sampled_from(["pose", "matrix", "compact"]))
        if body["links"] is None:
            del body["links"]
    else:
        body["link"] = draw(st.sampled_from(links))
        body["reference"] = draw(st.sampled_from(["world", "local", "local_world_aligned"]))
    return model_id, kind, body


def test_valid_kinematics_requests_conform_and_match_the_library(api_schema, fuzz_app):
    """Valid FK / Jacobian requests (extreme but legal values, every q shape and option) answer
    200, conform to the schema, and carry exactly the library's numbers."""
    import numpy as np

    from kinematics import as_batch, compile_model

    registry = fuzz_app.state.registry
    client = fuzz_app.state.fuzz_client
    for data in (ARM, MIMIC_TREE):  # the generated DELETEs above may have removed them
        r = client.post("/models", content=data, headers={"Content-Type": "application/xml"})
        assert r.status_code in (200, 201), r.text
    infos = {mid: client.get(f"/models/{mid}").json() for mid in VALID_MODELS}
    counter = {"cases": 0}

    @given(req=kinematics_requests(infos))
    @settings(max_examples=3 * MAX_EXAMPLES, deadline=None, derandomize=True,
              phases=[Phase.explicit, Phase.generate], suppress_health_check=list(HealthCheck))
    def run(req):
        model_id, kind, body = req
        counter["cases"] += 1
        operation = api_schema[f"/models/{{model_id}}/{kind}"]["POST"]
        case = operation.Case(path_parameters={"model_id": model_id}, body=body, media_type="application/json")
        response = case.call_and_validate(checks=CHECKS)
        assert response.status_code == 200, response.text
        answer = response.json()
        model = registry.get(model_id).model
        Q, is_batch = as_batch(model, body["q"])
        poe = compile_model(model)
        if kind == "jacobian":
            J = poe.jacobian(Q, body["link"], body["reference"])
            got = np.array(answer["jacobian"], dtype=float).reshape(J.shape)
            np.testing.assert_array_equal(got, J)
        elif body["format"] == "matrix":
            links = answer["links"]
            T = poe.fk(Q, links)
            poses = answer["poses"] if is_batch else [answer["poses"]]
            got = np.array([[p[link] for link in links] for p in poses], dtype=float)
            np.testing.assert_array_equal(got, T)
        if body["verify"]:
            v = answer["verification"]
            worst = max(v.get("max_position_error", 0), v.get("max_rotation_error", 0), v.get("max_jacobian_error", 0))
            assert worst < 1e-9 * max(1.0, float(np.max(np.abs(Q))))

    run()
    print(f"\nschemathesis valid FK/Jacobian requests: {counter['cases']} cases, all 200 and equal to the library")


# ------------------------------------------------------------------ a key-protected service
PROTECTED_EXAMPLES = 8


@pytest.fixture(scope="module")
def protected_schema(tmp_path_factory):
    settings = Settings(data_dir=tmp_path_factory.mktemp("fuzz-protected"), api_key="fuzz-key", api_key_for_reads=True)
    app = create_app(settings)
    with TestClient(app):
        yield schemathesis.openapi.from_asgi("/openapi.json", app)


@pytest.mark.parametrize("method, path", OPERATIONS, ids=[f"{m} {p}" for m, p in OPERATIONS])
def test_protected_service_conforms_to_its_schema(protected_schema, method, path):
    """With KIN_API_KEY set and reads protected, generated requests (no key, or a generated
    X-API-Key / Authorization header) get documented answers: 401/403 problems where a key is needed."""
    operation = protected_schema[path][method]
    statuses: dict[int, int] = {}

    @given(case=operation.as_strategy())
    @settings(max_examples=PROTECTED_EXAMPLES, deadline=None, derandomize=True,
              phases=[Phase.explicit, Phase.generate], suppress_health_check=list(HealthCheck))
    def run(case):
        response = case.call_and_validate(checks=CHECKS)
        statuses[response.status_code] = statuses.get(response.status_code, 0) + 1

    run()
    if any(s in operation.definition.raw.get("responses", {}) for s in ("401", "403")):
        assert set(statuses) <= {401, 403, 404, 405, 413, 415, 422}, statuses  # never served without the key
    print(f"\nschemathesis protected {method} {path}: {sum(statuses.values())} cases, statuses {dict(sorted(statuses.items()))}")
