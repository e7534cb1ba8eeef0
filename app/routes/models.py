"""The model catalogue: list, register (URDF or DH table), inspect, export, delete."""

from __future__ import annotations

from typing import Annotated, Literal

import orjson
from fastapi import APIRouter, Depends, Query, Request, Response
from fastapi.responses import Response as PlainResponse

from kinematics import api
from kinematics.io.dh_table import table_to_dict

from ..deps import ModelId, RegistryDep, SettingsDep, media_type, read_body, require_read_key, require_write_key
from ..errors import ProblemError
from ..schemas import (DH_EXAMPLES, URDF_EXAMPLES, DHTable, ModelInfo, ModelSummary, Problem, Screws,
                       TWO_LINK_URDF, URDFUpload)
from ..views import model_info

router = APIRouter(tags=["models"], dependencies=[Depends(require_read_key)])

XML_TYPES = ("application/xml", "text/xml", "application/urdf+xml")
JSON_TYPES = ("application/json",)

_ERRORS = {
    404: {"model": Problem, "description": "unknown model"},
    422: {"model": Problem, "description": "invalid input"},
}
_WRITE_ERRORS = {
    **_ERRORS,
    401: {"model": Problem, "description": "API key required"},
    403: {"model": Problem, "description": "API key invalid"},
    413: {"model": Problem, "description": "body over the size limit"},
    415: {"model": Problem, "description": "unsupported content type"},
    507: {"model": Problem, "description": "the data directory cannot be written (full or read-only)"},
}


@router.get("/models", response_model=list[ModelSummary])
def list_models(registry: RegistryDep) -> list[ModelSummary]:
    """Every model: bundled (example-robot-data, DH presets), then uploaded and DH-built ones."""
    return [ModelSummary(id=s.id, name=s.name, source=s.source, dof=s.dof, error=s.error) for s in registry.summaries()]


async def read_urdf_upload(request: Request, settings: SettingsDep,
                           name: Annotated[str | None, Query(max_length=200, description="display name (raw XML bodies)")] = None
                           ) -> tuple[bytes, str | None]:
    """The URDF of a ``POST /models``: a raw XML body, or JSON ``{"urdf": ..., "name": ...}``."""
    body = await read_body(request, settings.max_model_bytes, "URDF body")
    kind = media_type(request)
    if kind in JSON_TYPES:
        upload = URDFUpload.model_validate_json(body)
        return upload.urdf.encode("utf-8"), upload.name or name
    if kind in XML_TYPES or kind == "":
        if not body.strip():
            raise ProblemError(422, "the body is empty: send a URDF document", slug="invalid-urdf", field="body")
        return body, name
    raise ProblemError(415, f"Content-Type {kind!r} is not supported: send application/xml (raw URDF) "
                       "or application/json ({\"urdf\": ..., \"name\": ...})", slug="unsupported-media-type")


def _created(response: Response, created: bool, model_id: str) -> None:
    response.status_code = 201 if created else 200
    if created:
        response.headers["Location"] = f"/models/{model_id}"


@router.post(
    "/models", response_model=ModelInfo, status_code=201, responses={200: {"model": ModelInfo, "description":
        "the same URDF is already registered (same id)"}, **_WRITE_ERRORS},
    dependencies=[Depends(require_write_key)],
    openapi_extra={"requestBody": {"required": True, "content": {
        "application/xml": {"schema": {"type": "string"}, "example": TWO_LINK_URDF},
        "application/json": {"schema": {"$ref": "#/components/schemas/URDFUpload"}, "examples": URDF_EXAMPLES},
    }}},
)
def register_urdf(upload: Annotated[tuple[bytes, str | None], Depends(read_urdf_upload)], registry: RegistryDep,
                  response: Response) -> dict:
    """Register a URDF (raw XML body, or JSON `{"urdf", "name"}`).

    The id is `u-` + 16 hex digits of the SHA-256 of the URDF bytes: the same file gives the
    same id on every replica. 201 when created, 200 when already registered; the body is
    the model's info either way. Meshes named by the file are never opened.
    """
    data, name = upload
    rec, created = registry.add_urdf(data, name)
    _created(response, created, rec.id)
    return model_info(rec)


async def read_dh_table(request: Request, settings: SettingsDep) -> dict:
    body = await read_body(request, settings.max_model_bytes, "DH table body")
    kind = media_type(request)
    if kind not in JSON_TYPES and kind != "":
        raise ProblemError(415, f"Content-Type {kind!r} is not supported: send the DH table as application/json",
                           slug="unsupported-media-type")
    try:
        table = orjson.loads(body)
    except orjson.JSONDecodeError as exc:
        raise ProblemError(422, f"the body is not valid JSON: {exc}", slug="validation-error", field="body") from None
    if not isinstance(table, dict):
        raise ProblemError(422, "the DH table must be a JSON object", slug="validation-error", field="body")
    return table


@router.post(
    "/models/dh", response_model=ModelInfo, status_code=201, responses={200: {"model": ModelInfo, "description":
        "the same table is already registered (same id)"}, **_WRITE_ERRORS},
    dependencies=[Depends(require_write_key)],
    openapi_extra={"requestBody": {"required": True, "content": {
        "application/json": {"schema": {"$ref": "#/components/schemas/DHTable"}, "examples": DH_EXAMPLES}}}},
)
def register_dh(table: Annotated[dict, Depends(read_dh_table)], registry: RegistryDep, response: Response) -> dict:
    """Register a model built from a Denavit-Hartenberg table (standard or modified convention).

    The table becomes a URDF (one link per DH frame, `GET /models/{id}/urdf` shows it).
    The id is `dh-` + 16 hex digits of the SHA-256 of the canonical table. 201 when
    created, 200 when already registered.
    """
    rec, created = registry.add_dh(table)
    _created(response, created, rec.id)
    return model_info(rec)


@router.get("/models/{model_id}", response_model=ModelInfo, responses=_ERRORS)
def get_model(model_id: ModelId, registry: RegistryDep) -> dict:
    """Joints (name, type, axis, parent, child, origin, limits, mimic), links, `joint_names` (the order of q), dof, root."""
    return model_info(registry.get(model_id))


@router.get("/models/{model_id}/urdf", response_class=PlainResponse, responses={
    200: {"content": {"application/xml": {}}, "description": "the URDF document"}, **_ERRORS})
def get_urdf(model_id: ModelId, registry: RegistryDep) -> PlainResponse:
    """The model's URDF (for DH-built models and presets: the generated one)."""
    return PlainResponse(registry.get(model_id).model.urdf, media_type="application/xml")


@router.delete("/models/{model_id}", status_code=204, response_class=PlainResponse, responses={
    **_WRITE_ERRORS, 405: {"model": Problem, "description": "bundled models are read-only"}},
    dependencies=[Depends(require_write_key)])
def delete_model(model_id: ModelId, registry: RegistryDep) -> PlainResponse:
    """Remove an uploaded or DH-built model (from every worker and replica sharing the data directory)."""
    if registry.is_bundled(model_id):
        raise ProblemError(405, f"model {model_id!r} is bundled and read-only; only uploaded and DH-built "
                           "models can be deleted", slug="read-only-model", headers={"Allow": "GET"}, model=model_id)
    registry.delete(model_id)
    return PlainResponse(status_code=204)


@router.get("/models/{model_id}/screws", response_model=Screws, responses=_ERRORS)
def get_screws(model_id: ModelId, registry: RegistryDep) -> dict:
    """The product-of-exponentials parameters: space screws (angular first) and home poses M.

    `T_world_L(q) = exp([S_1] q_1) ... exp([S_k] q_k) M_L` over the moving joints on the path to L.
    """
    rec = registry.get(model_id)
    poe = api.screws(rec.model)
    joints = []
    for j, name in enumerate(poe.joint_names):
        joints.append({
            "name": name, "type": rec.model.joint_map[name].type, "screw": poe.S[j].tolist(),
            "axis": poe.w[j].tolist(), "point": poe.r[j].tolist(), "q_index": int(poe.q_index[j]),
            "multiplier": float(poe.multiplier[j]), "offset": float(poe.offset[j]),
        })
    return {"model": rec.id, "twist_order": "angular_first", "joint_names": list(rec.model.joint_names),
            "joints": joints, "home_poses": {link: poe.M[i].tolist() for i, link in enumerate(poe.link_names)}}


@router.get("/models/{model_id}/dh", response_model=DHTable, responses=_ERRORS)
def get_dh(model_id: ModelId, registry: RegistryDep,
           tip: Annotated[str | None, Query(description="the link ending the chain (default: the only leaf)")] = None,
           convention: Annotated[Literal["standard", "modified"], Query()] = "standard") -> dict:
    """The model as a DH table, when it is a serial chain that has one (422 otherwise)."""
    rec = registry.get(model_id)
    return table_to_dict(api.dh_form(rec.model, tip=tip, convention=convention))
