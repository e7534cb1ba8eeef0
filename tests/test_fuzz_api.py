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

pytestmark = pytest.mark.slow

#: generated requests per operation (the whole file stays well under a minute on 2 cores)
MAX_EXAMPLES = 25

CORPUS = Path(__file__).parent / "corpus"
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
        yield app


@pytest.fixture(scope="module")
def api_schema(fuzz_app):
    return schemathesis.openapi.from_asgi("/openapi.json", fuzz_app)


def _operations() -> list[tuple[str, str]]:
    """(method, path) of every operation of the OpenAPI document (built without a lifespan)."""
    app = create_app(Settings(data_dir=Path(__file__).parent / "corpus" / "no-such-data-dir"))
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
        case.call_and_validate(checks=CHECKS)

    try:
        run()
    except Unsatisfiable:
        if mode == GenerationMode.NEGATIVE:
            pytest.skip("no input to make invalid (no parameters, no body)")
        raise
    assert RUN_COUNTS[label] > 0
