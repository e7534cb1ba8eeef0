"""The model catalogue: list, register (URDF, DH table, PoE or zero-configuration axes), inspect, export, delete."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Annotated, Literal

import orjson
from fastapi import APIRouter, Depends, Query, Request, Response
from fastapi.responses import Response as PlainResponse
from pydantic import StringConstraints

from kinematics import usecases
from kinematics.io.archive import ArchiveLimits
from kinematics.io.xacro import SandboxLimits
from kinematics.io.dh_table import table_to_dict

from ..deps import ModelId, RegistryDep, SettingsDep, media_type, read_body, require_read_key, require_write_key
from ..errors import ProblemError
from ..schemas import (AXES_EXAMPLES, DH_EXAMPLES, POE_EXAMPLES, URDF_EXAMPLES, DHTable, ModelInfo, ModelSummary,
                       Problem, Screws, TWO_LINK_URDF, URDFUpload)
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


#: archive bodies (a zip, gzip or tar of ROS packages); octet-stream is sniffed like them
ARCHIVE_TYPES = ("application/zip", "application/x-zip-compressed", "application/gzip", "application/x-gzip",
                 "application/x-tar", "application/x-gtar", "application/x-compressed-tar", "application/octet-stream")


@dataclass(frozen=True)
class Upload:
    """A ``POST /models`` body and its options."""

    data: bytes
    name: str | None = None
    args: dict[str, str] | None = None
    entry: str | None = None


def _xacro_args(args_json: str | None, arg: list[str] | None) -> dict[str, str] | None:
    """``?args={"k": "v"}`` (a JSON object) and repeated ``?arg=k:v`` (or ``k=v``), merged."""
    out: dict[str, str] = {}
    if args_json is not None:
        try:
            parsed = orjson.loads(args_json)
        except orjson.JSONDecodeError as exc:
            raise ProblemError(422, f"args is not valid JSON: {exc}", slug="validation-error", field="args") from None
        if not isinstance(parsed, dict):
            raise ProblemError(422, "args must be a JSON object of xacro arguments", slug="validation-error", field="args")
        if len(parsed) > MAX_QUERY_ARGS or any(len(k) > MAX_QUERY_ARG_NAME for k in parsed) or any(
                isinstance(v, str) and len(v) > MAX_QUERY_ARG_VALUE for v in parsed.values()):
            raise ProblemError(422, f"args: at most {MAX_QUERY_ARGS} arguments in the query, names of at most "
                               f"{MAX_QUERY_ARG_NAME} characters and strings of at most {MAX_QUERY_ARG_VALUE}; send "
                               "more in the JSON body's \"args\"", slug="validation-error", field="args")
        for k, v in parsed.items():
            if isinstance(v, (dict, list)) or v is None:
                raise ProblemError(422, f"args: xacro argument {k!r} must be a string or a number",
                                   slug="validation-error", field="args")
            out[k] = ("true" if v else "false") if isinstance(v, bool) else str(v)
    for item in arg or ():
        sep = min((i for i in (item.find(":"), item.find("=")) if i > 0), default=-1)
        if sep < 0:
            raise ProblemError(422, f"arg {item[:80]!r} is not name:value", slug="validation-error", field="arg")
        out[item[:sep]] = item[sep + 1:]
    return out or None


#: the query forms of xacro arguments are bounded so that a URL stays under the HTTP server's
#: 64 KiB request-line limit even percent-encoded (more arguments: the JSON body's ``args``)
MAX_QUERY_ARGS, MAX_QUERY_ARG_NAME, MAX_QUERY_ARG_VALUE = 16, 32, 100

#: ``?args=``: a JSON object in the query, documented as such (OpenAPI parameter ``content``)
ARGS_PARAMETER = {
    "name": "args", "in": "query", "required": False,
    "description": "xacro arguments: a JSON object `{\"name\": value}` (values: strings, numbers, booleans; at most "
                   f"{MAX_QUERY_ARGS}, names of at most {MAX_QUERY_ARG_NAME} characters, strings of at most "
                   f"{MAX_QUERY_ARG_VALUE}; more through the JSON body)",
    "content": {"application/json": {"schema": {
        "type": "object", "maxProperties": MAX_QUERY_ARGS, "propertyNames": {"maxLength": MAX_QUERY_ARG_NAME},
        "additionalProperties": {"anyOf": [{"type": "string", "maxLength": MAX_QUERY_ARG_VALUE}, {"type": "number"},
                                           {"type": "boolean"}]}}}},
}


#: one ``?arg=name:value`` (or ``name=value``): a name, then the first ``:`` or ``=`` (what _xacro_args splits on)
XacroArg = Annotated[str, StringConstraints(max_length=MAX_QUERY_ARG_VALUE,
                                            pattern=r"^(?:[^:][\s\S]*:|[^=][\s\S]*=)[\s\S]*$")]


async def read_urdf_upload(
    request: Request, settings: SettingsDep,
    name: Annotated[str | None, Query(max_length=200, description="display name (raw bodies)")] = None,
    args: Annotated[str | None, Query(max_length=100_000, include_in_schema=False)] = None,  # ARGS_PARAMETER
    arg: Annotated[list[XacroArg] | None, Query(max_length=MAX_QUERY_ARGS, description="a xacro argument `name:value` "
                                           "(repeatable)")] = None,
    entry: Annotated[str | None, Query(max_length=255, description="the description file of an archive "
                                       "(default: its only one)")] = None,
) -> Upload:
    """The body of a ``POST /models``: a raw document (URDF, xacro, MJCF: XML types), an archive
    (zip, gzip, tar), or JSON ``{"urdf": ..., "name": ..., "args": ...}``. What it is comes from the
    content; the type picks the size limit (archives: ``max_archive_bytes``)."""
    kind = media_type(request)
    is_archive = kind in ARCHIVE_TYPES
    if not (is_archive or kind in JSON_TYPES or kind in XML_TYPES or kind == ""):
        raise ProblemError(415, f"Content-Type {kind!r} is not supported: send application/xml (raw URDF, xacro or "
                           "MJCF), application/zip or application/gzip (a description archive), or application/json "
                           "({\"urdf\": ..., \"name\": ...})", slug="unsupported-media-type")
    limit = settings.max_archive_bytes if is_archive else settings.max_model_bytes
    body = await read_body(request, limit, "archive body" if is_archive else "URDF body")
    xargs = _xacro_args(args, arg)
    if kind in JSON_TYPES:
        upload = URDFUpload.model_validate_json(body)
        merged = {**{k: ("true" if v else "false") if isinstance(v, bool) else str(v)
                     for k, v in (upload.args or {}).items()}, **(xargs or {})}
        return Upload(upload.urdf.encode("utf-8"), upload.name or name, merged or None, entry)
    if not body.strip():
        raise ProblemError(422, "the body is empty: send a URDF document", slug="invalid-urdf", field="body")
    return Upload(body, name, xargs, entry)


_SAME = "already registered (the same description has the same id); nothing changed"


def _created(response: Response, created: bool, model_id: str) -> None:
    response.status_code = 201 if created else 200
    if created:
        response.headers["Location"] = f"/models/{model_id}"


@router.post(
    "/models", response_model=ModelInfo, status_code=201, responses={200: {"model": ModelInfo, "description":
        "the same content is already registered (same id); a new `name` is applied to it; `note` says what happened"}, **_WRITE_ERRORS},
    dependencies=[Depends(require_write_key)],
    openapi_extra={"parameters": [ARGS_PARAMETER], "requestBody": {"required": True, "content": {
        "application/xml": {"schema": {"type": "string"}, "example": TWO_LINK_URDF},
        "application/json": {"schema": {"$ref": "#/components/schemas/URDFUpload"}, "examples": URDF_EXAMPLES},
        "application/zip": {"schema": {"type": "string", "format": "binary"}},
        "application/gzip": {"schema": {"type": "string", "format": "binary"}},
    }}},
)
def register_urdf(upload: Annotated[Upload, Depends(read_urdf_upload)], registry: RegistryDep,
                  settings: SettingsDep, response: Response) -> dict:
    """Register a robot description: URDF, xacro, MJCF, or a description archive -- told apart by content.

    * **URDF** (raw XML body, or JSON `{"urdf", "name"}`): the id is `u-` + 16 hex digits of the
      SHA-256 of the bytes;
    * **xacro** text (`?args={"name": value}` or repeated `?arg=name:value`): expanded in a
      sandboxed process (CPU, memory and output limits; it can read nothing but the text itself);
    * **MJCF** (`<mujoco>`): compiled by MuJoCo with meshes and geometry left out;
    * a **zip**, **gzip** or **tar** archive of ROS packages (`application/zip`, `application/gzip`):
      the description files are extracted (never the meshes), `$(find pkg)` resolves the
      packages in it, `?entry=path` picks the file (default: the only description in it).

    The last three are stored as the URDF they became (`GET /models/{id}/urdf`), under an id
    `x-`, `m-` or `a-` + 16 hex digits hashing the bytes, the arguments and the entry; `format`
    in the answer says what was read. 201 when created, 200 when already registered; the body
    is the model's info either way. Sending the same content again with another `name` (query or
    JSON) renames the stored model (its id is the content's hash, so it does not change) and the
    200's `note` says so: `already registered as u-...; renamed from 'a' to 'b'`. Meshes named by any file are never opened.
    """
    rec, created = registry.add_upload(
        upload.data, upload.name, args=upload.args, entry=upload.entry,
        xacro_limits=SandboxLimits(cpu_seconds=settings.xacro_cpu_seconds, memory_bytes=settings.xacro_memory_bytes,
                                   output_bytes=settings.max_model_bytes, wall_seconds=3 * settings.xacro_cpu_seconds + 5,
                                   max_macro_calls=settings.xacro_max_macro_calls),
        archive_limits=ArchiveLimits(max_members=settings.max_archive_members,
                                     max_bytes=settings.max_archive_extracted_bytes,
                                     max_stream_bytes=8 * settings.max_archive_bytes),
    )
    _created(response, created, rec.id)
    if created:
        return model_info(rec)
    if upload.name is not None and upload.name != rec.name:
        old = rec.name
        rec = registry.rename(rec.id, upload.name)
        return model_info(rec, note=f"already registered as {rec.id} (same content); renamed from {old!r} to "
                                    f"{rec.name!r}")
    return model_info(rec, note=f"already registered as {rec.id} (same content); nothing changed")


async def read_json_object(request: Request, settings: SettingsDep, what: str) -> dict:
    """A model description body: a JSON object of at most ``max_model_bytes``."""
    body = await read_body(request, settings.max_model_bytes, f"{what} body")
    kind = media_type(request)
    if kind not in JSON_TYPES and kind != "":
        raise ProblemError(415, f"Content-Type {kind!r} is not supported: send the {what} as application/json",
                           slug="unsupported-media-type")
    try:
        data = orjson.loads(body)
    except orjson.JSONDecodeError as exc:
        try:  # NaN and Infinity literals read as the other bodies read them; the model's checks then name the value
            data = json.loads(body)
        except ValueError:
            raise ProblemError(422, f"the body is not valid JSON: {exc}", slug="validation-error",
                               field="body") from None
    if not isinstance(data, dict):
        raise ProblemError(422, f"the {what} must be a JSON object", slug="validation-error", field="body")
    return data


async def read_dh_table(request: Request, settings: SettingsDep) -> dict:
    return await read_json_object(request, settings, "DH table")


async def read_poe(request: Request, settings: SettingsDep) -> dict:
    return await read_json_object(request, settings, "PoE description")


async def read_axes(request: Request, settings: SettingsDep) -> dict:
    return await read_json_object(request, settings, "axes description")


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
    return model_info(rec, note=None if created else _SAME)


@router.post(
    "/models/poe", response_model=ModelInfo, status_code=201, responses={200: {"model": ModelInfo, "description":
        "the same description is already registered (same id)"}, **_WRITE_ERRORS},
    dependencies=[Depends(require_write_key)],
    openapi_extra={"requestBody": {"required": True, "content": {
        "application/json": {"schema": {"$ref": "#/components/schemas/PoEDescriptionIn"}, "examples": POE_EXAMPLES}}}},
)
def register_poe(description: Annotated[dict, Depends(read_poe)], registry: RegistryDep, response: Response) -> dict:
    """Register a model from a product of exponentials: `M` and one screw per joint, angular first,
    in the space frame (`S`) or the end-effector frame (`B`).

    The description becomes a URDF (joint frames on the screw axes, `tool` at `M`); its FK is
    `exp([S_1] q_1) ... exp([S_n] q_n) M` and `GET /models/{id}/screws` gives the `S_i` back.
    The id is `poe-` + 16 hex digits of the SHA-256 of the canonical description (space
    screws, radians). 201 when created, 200 when already registered.
    """
    rec, created = registry.add_description("poe", description)
    _created(response, created, rec.id)
    return model_info(rec, note=None if created else _SAME)


@router.post(
    "/models/axes", response_model=ModelInfo, status_code=201, responses={200: {"model": ModelInfo, "description":
        "the same description is already registered (same id)"}, **_WRITE_ERRORS},
    dependencies=[Depends(require_write_key)],
    openapi_extra={"requestBody": {"required": True, "content": {
        "application/json": {"schema": {"$ref": "#/components/schemas/AxesDescriptionIn"}, "examples": AXES_EXAMPLES}}}},
)
def register_axes(description: Annotated[dict, Depends(read_axes)], registry: RegistryDep, response: Response) -> dict:
    """Register a model from zero-configuration axes (Wen): per joint its type, axis `h` and link
    vector `p` = p_{i-1,i} (every frame aligned with the base at q = 0), and the tool offset `p_nT`.

    FK: `p_0T = p_01 + R_01 p_12 + ... + R_0n p_nT` with `R_{i-1,i} = rot(h_i, q_i)` (prismatic:
    `p_{i-1,i} + q_i h_i`). The id is `axes-` + 16 hex digits of the SHA-256 of the canonical
    description. 201 when created, 200 when already registered.
    """
    rec, created = registry.add_description("axes", description)
    _created(response, created, rec.id)
    return model_info(rec, note=None if created else _SAME)


@router.get("/models/{model_id}", response_model=ModelInfo, responses=_ERRORS)
def get_model(model_id: ModelId, registry: RegistryDep,
              floating_base: Annotated[bool, Query(description="describe the model as computed with floating_base: "
                                                               "true (a free-flyer root_joint above its root)")] = False
              ) -> dict:
    """Joints (name, type, axis, parent, child, origin, limits, mimic), links, `joint_names` (the order of q), dof, root;
    `nq`, `nv` and `q_layout` (per joint its slices of q and of the velocity vector: a floating joint takes 7 and 6,
    a planar joint 4 and 3)."""
    return model_info(registry.get(model_id), floating_base=floating_base)


@router.get("/models/{model_id}/urdf", response_class=PlainResponse, responses={
    200: {"content": {"application/xml": {}}, "description": "the URDF document"}, **_ERRORS})
def get_urdf(model_id: ModelId, registry: RegistryDep) -> PlainResponse:
    """The model's URDF (for DH-built models and presets: the generated one)."""
    return PlainResponse(registry.get(model_id).model.urdf, media_type="application/xml")


@router.delete("/models/{model_id}", status_code=204, response_class=PlainResponse, responses={
    **_WRITE_ERRORS, 403: {"model": Problem, "description": "the model is bundled, so read-only (`read-only-model`); "
                          "with KIN_API_KEY set, also an API key that is not valid (`api-key-invalid`)"}},
    dependencies=[Depends(require_write_key)])
def delete_model(model_id: ModelId, registry: RegistryDep) -> PlainResponse:
    """Remove an uploaded or DH-built model (from every worker and replica sharing the data directory).

    Bundled models are read-only: deleting one is refused with 403 `read-only-model` (the method is
    supported on the path, so not 405; the refusal does not depend on the API key)."""
    if registry.is_bundled(model_id):
        raise ProblemError(403, f"model {model_id!r} is bundled and read-only; only uploaded and DH-built "
                           "models can be deleted", slug="read-only-model", title="Read-only model", model=model_id)
    registry.delete(model_id)
    return PlainResponse(status_code=204)


@router.get("/models/{model_id}/screws", response_model=Screws, responses=_ERRORS)
def get_screws(model_id: ModelId, registry: RegistryDep) -> dict:
    """The product-of-exponentials parameters: space screws (angular first) and home poses M.

    `T_world_L(q) = exp([S_1] q_1) ... exp([S_k] q_k) M_L` over the moving joints on the path to L.
    """
    rec = registry.get(model_id)
    poe = usecases.screws(rec.model)
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
    return table_to_dict(usecases.dh_form(rec.model, tip=tip, convention=convention))
