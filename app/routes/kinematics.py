"""Forward kinematics and Jacobians, in JSON or NumPy ``.npy`` (binary batch transport).

Both endpoints take either a JSON body (``FKRequest`` / ``JacobianRequest``) or, with
``Content-Type: application/x-npy``, an ``(N, dof)`` float64 array with the other options
as query parameters. ``Accept: application/x-npy`` returns ``(N, links, 4, 4)`` poses or
``(N, 6, dof)`` Jacobians, with the link order in ``X-Links`` and the joint order in
``X-Joint-Names`` (comma-separated, each name percent-encoded). The Jacobian's
``representation`` answers the analytic Jacobian ``J_r`` and ``r`` of :func:`kinematics.api.task`
instead (``.npy``: ``(N, m, dof + 1)``, ``[J_r | r]``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, Literal

import numpy as np
from fastapi import APIRouter, Depends, Query, Request

from kinematics import api
from kinematics.io.pose_records import pose_output
from kinematics.spatial.reference import Reference

from ..deps import ModelId, RegistryDep, SettingsDep, media_type, read_body, require_read_key, wants_npy
from ..errors import ProblemError
from ..heavy import parse_body, run_heavy
from ..metrics import record_configurations
from ..npy import decode_q, names_header
from ..responses import NPY_MEDIA_TYPE, FastJSONResponse, NpyResponse
from ..schemas import (FK_EXAMPLES, JACOBIAN_EXAMPLES, FKRequest, FKResponse, JacobianRequest, JacobianResponse,
                       Problem, TaskRepresentationName)
from ..settings import Settings

router = APIRouter(tags=["kinematics"], dependencies=[Depends(require_read_key)])

_ERRORS = {
    400: {"model": Problem, "description": "malformed body"},
    404: {"model": Problem, "description": "unknown model or link"},
    413: {"model": Problem, "description": "body, batch or result over the configured limit"},
    415: {"model": Problem, "description": "unsupported content type"},
    422: {"model": Problem, "description": "invalid joint values, limits refused, or invalid options"},
    503: {"model": Problem, "description": "over the time budget KIN_REQUEST_TIMEOUT (time-budget-exceeded)"},
}


def _request_body(schema: str, examples: dict, npy_shape: str) -> dict:
    return {"requestBody": {"required": True, "content": {
        "application/json": {"schema": {"$ref": f"#/components/schemas/{schema}"}, "examples": examples},
        NPY_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary",
                                    "description": f"np.save of a float64 array {npy_shape}; options as query parameters"}},
    }}}


def _npy_response_doc(shape: str) -> dict:
    return {"content": {NPY_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary", "description": shape}}}}


@dataclass
class Call:
    """One FK / Jacobian request, whatever its encoding."""

    q: Any  # as given in JSON, or an ndarray from .npy
    verify: bool
    limits: str
    links: Any = None  # FK: None | "all" | list[str]
    format: str = "pose"
    link: str | None = None  # Jacobian
    reference: str | None = None  # None: not given (world)
    base: Any = None  # T_world_root: one pose or one per configuration (JSON bodies)
    point: Any = None  # [x, y, z] in the link frame
    tool: Any = None  # T_link_tool (JSON bodies)
    floating_base: bool = False  # the model on a free-flyer root joint
    normalize: bool = False  # scale quaternions and planar (cos, sin) to unit norm
    representation: str | None = None  # Jacobian: a task representation (analytic Jacobian)
    components: Any = None  # ... and the components kept


def parse_point(value: str | None) -> list[float] | None:
    """A ``point`` query parameter ``x,y,z`` (metres, the link frame) as three numbers."""
    if value is None:
        return None
    try:
        point = [float(v) for v in value.split(",")]
    except ValueError:
        point = []
    if len(point) != 3:
        raise ProblemError(422, f"point: {value!r}; give three comma-separated numbers x,y,z (metres, link frame)",
                           slug="validation-error", field="point")
    return point


_NUMBER = r"\s*[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?\s*"
#: three comma-separated numbers (what :func:`parse_point` reads), declared so the OpenAPI document says it
POINT_PATTERN = rf"^{_NUMBER},{_NUMBER},{_NUMBER}$"
PointQuery = Annotated[str | None, Query(description=".npy bodies: a point x,y,z in the link frame (metres)",
                                         pattern=POINT_PATTERN)]
FloatingBaseQuery = Annotated[bool, Query(description=".npy bodies: the model on a free-flyer root joint")]
NormalizeQuery = Annotated[bool, Query(description=".npy bodies: scale quaternions and planar (cos, sin) to unit norm")]


def _split_names(values: list[str] | None):
    if values is None:
        return None
    names = [n.strip() for v in values for n in v.split(",") if n.strip()]
    return "all" if names == ["all"] else names


#: Requests of at most this many configurations are answered on the event loop: their work
#: takes microseconds, and handing them to the thread pool costs a thread wake-up
#: (bench/RESULTS.md has the figures). Larger ones run in the thread pool, so the loop keeps serving.
INLINE_MAX_CONFIGURATIONS = 8


def _configurations(q: Any) -> int:
    """How many configurations a request's q holds (before validation; 1 for a vector or a map)."""
    if isinstance(q, np.ndarray):
        return int(q.shape[0]) if q.ndim == 2 else 1
    if isinstance(q, list) and q and isinstance(q[0], (list, dict)):
        return len(q)
    return 1


def _budget(settings: Settings) -> api.Budget:
    return api.Budget(max_batch=settings.max_batch, max_verify=settings.max_verify,
                      max_result_values=settings.max_result_values)


async def _read_call(request: Request, settings: Settings, schema, query: dict) -> Call:
    body = await read_body(request, settings.max_request_bytes, "request body")
    kind = media_type(request)
    if kind == NPY_MEDIA_TYPE:
        return Call(q=decode_q(body), **query)
    if kind not in ("application/json", ""):
        raise ProblemError(415, f"Content-Type {kind!r} is not supported: send application/json or {NPY_MEDIA_TYPE}",
                           slug="unsupported-media-type")
    if not body:
        raise ProblemError(422, "the body is empty: send {\"q\": [...]}", slug="validation-error", field="q")
    fields = await parse_body(request, schema, body)
    q = fields.pop("q")
    _budget(settings).check_batch(_configurations(q))  # before the library reads a huge batch
    return Call(q=q, **fields)


async def read_fk_call(
    request: Request, settings: SettingsDep,
    links: Annotated[list[str] | None, Query(description=".npy bodies: link names (repeat or comma-separate), or `all`")] = None,
    verify: Annotated[bool, Query(description=".npy bodies: compare with Pinocchio")] = False,
    limits: Annotated[Literal["report", "refuse"], Query(description=".npy bodies: out-of-limit policy")] = "report",
    format: Annotated[Literal["pose", "matrix", "compact"], Query(description=".npy bodies with a JSON answer: pose format")] = "pose",
    point: PointQuery = None,
    floating_base: FloatingBaseQuery = False,
    normalize: NormalizeQuery = False,
) -> Call:
    return await _read_call(request, settings, FKRequest,
                            {"links": _split_names(links), "verify": verify, "limits": limits, "format": format,
                             "point": parse_point(point), "floating_base": floating_base, "normalize": normalize})


async def read_jacobian_call(
    request: Request, settings: SettingsDep,
    link: Annotated[str | None, Query(description=".npy bodies: the link (default: the first leaf link)")] = None,
    reference: Annotated[Reference | None, Query(description=".npy bodies: reference (default world)")] = None,
    verify: Annotated[bool, Query(description=".npy bodies: compare with Pinocchio")] = False,
    limits: Annotated[Literal["report", "refuse"], Query(description=".npy bodies: out-of-limit policy")] = "report",
    point: PointQuery = None,
    floating_base: FloatingBaseQuery = False,
    normalize: NormalizeQuery = False,
    representation: Annotated[TaskRepresentationName | None, Query(
        description=".npy bodies: the analytic Jacobian of this task representation; the answer is then "
                    "(N, m, dof + 1): J_r in the first dof columns, r in the last")] = None,
    components: Annotated[list[str] | None, Query(
        description=".npy bodies with representation: components kept (repeat or comma-separate)")] = None,
) -> Call:
    return await _read_call(request, settings, JacobianRequest,
                            {"link": link, "reference": reference, "verify": verify, "limits": limits,
                             "point": parse_point(point), "floating_base": floating_base, "normalize": normalize,
                             "representation": representation, "components": _split_names(components)})


async def _run(handler, model_id: str, call: Call, request: Request, registry, settings: Settings):
    """``handler(...)`` on the event loop for a small request, else as heavy work (``app.heavy``: off the
    loop, under the time budget, stopped when the client disconnects)."""
    args = (model_id, call, request, registry, settings)
    if _configurations(call.q) <= INLINE_MAX_CONFIGURATIONS:
        return handler(*args)
    return await run_heavy(request, handler, *args)


def _names_headers(links: list[str], joint_names) -> dict[str, str]:
    headers = {}
    for key, names in (("X-Links", links), ("X-Joint-Names", joint_names)):
        value = names_header(names)
        if value is None:
            headers[key + "-Omitted"] = "too long for a header; see GET /models/{id}"
        else:
            headers[key] = value
    return headers


@router.post(
    "/models/{model_id}/fk", response_model=FKResponse,
    responses={200: _npy_response_doc("(N, links, 4, 4) float64 poses T_world_link"), **_ERRORS},
    openapi_extra=_request_body("FKRequest", FK_EXAMPLES, "(N, dof) or (dof,)"),
)
async def forward_kinematics(model_id: ModelId, call: Annotated[Call, Depends(read_fk_call)], request: Request,
                             registry: RegistryDep, settings: SettingsDep):
    """Poses `T_world_link` of links (default: the leaf links; `"all"`; or names) for one configuration or a batch.

    q is a vector in `joint_names` order, a `{joint_name: value}` map, or a list of those.
    `out_of_limits` lists the joints outside their limits (per configuration for a batch);
    `limits: "refuse"` answers 422 instead. `verify: true` compares with Pinocchio.
    `format`: `pose` (matrix, position, quaternion {w,x,y,z}, rpy), `matrix`, or `compact`
    (per link `positions` (N, 3) and `quaternions` (N, 4), w first). `point` ([x, y, z] in the
    link frame) or `tool` (a pose `T_link_tool`) give the poses of that frame instead
    (`T_world_link @ T_link_tool`, on every link returned).
    """
    return await _run(_forward_kinematics, model_id, call, request, registry, settings)


def _forward_kinematics(model_id: str, call: Call, request: Request, registry, settings: Settings):
    rec = registry.get(model_id)
    answer = api.fk(rec.model, call.q, links=call.links, base=call.base, point=call.point, tool=call.tool,
                    verify=call.verify, limits=call.limits, budget=_budget(settings),
                    floating_base=call.floating_base, normalize=call.normalize)
    record_configurations("fk", _configurations(call.q))
    verification = answer.verification
    if wants_npy(request):
        headers = _names_headers(answer.links, answer.model.joint_names)
        headers["X-Out-Of-Limits"] = str(answer.out_of_limits_count())
        if verification:
            headers.update({"X-Verification-Reference": verification.reference,
                            "X-Max-Position-Error": repr(verification.max_position_error),
                            "X-Max-Rotation-Error": repr(verification.max_rotation_error)})
        return NpyResponse(answer.poses, headers=headers)
    oob = answer.out_of_limits()
    return FastJSONResponse({
        "model": rec.id, "joint_names": list(answer.model.joint_names), "links": answer.links, "format": call.format,
        "poses": pose_output(answer.poses, answer.links, call.format, answer.is_batch),
        "out_of_limits": oob if answer.is_batch else oob[0],
        "verification": verification.as_dict() if verification else None,
    })


@router.post(
    "/models/{model_id}/jacobian", response_model=JacobianResponse,
    responses={200: _npy_response_doc("(N, 6, dof) float64 Jacobians, linear rows first"), **_ERRORS},
    openapi_extra=_request_body("JacobianRequest", JACOBIAN_EXAMPLES, "(N, dof) or (dof,)"),
)
async def jacobian(model_id: ModelId, call: Annotated[Call, Depends(read_jacobian_call)], request: Request,
                   registry: RegistryDep, settings: SettingsDep):
    """Jacobian (6 x dof, linear rows first) of a link in `world`, `local` or `local_world_aligned`.

    Also the singular values, manipulability (their product) and condition number
    (largest / smallest; `null` at a singularity). `verify: true` compares with Pinocchio.
    `point` / `tool`: the Jacobian of the frame at that offset from the link (Pinocchio's frame
    semantics: the `local_world_aligned` reference point is its origin, `local` its axes).
    `representation` (`rpy`, `zyx`, `zyz`, `quaternion`, `rotvec`, `position`, `scara`, `planar`;
    `components` to keep some): the analytic Jacobian `J_r = dr/dq` (m x dof) of the task vector
    `r` (also answered) instead, as `POST /models/{id}/task` computes it; at a singularity of the
    representation 422 `representation-singularity`. `.npy`: `?representation=`, answer (N, m, dof + 1),
    `[J_r | r]`, rows named in `X-Components`.
    """
    return await _run(_jacobian, model_id, call, request, registry, settings)


def _jacobian(model_id: str, call: Call, request: Request, registry, settings: Settings):
    if call.representation is not None or call.components is not None:
        return _analytic_jacobian(model_id, call, request, registry, settings)
    rec = registry.get(model_id)
    reference = Reference.WORLD if call.reference is None else call.reference
    answer = api.jacobian(rec.model, call.q, link=call.link, reference=reference, base=call.base,
                          point=call.point, tool=call.tool, verify=call.verify, limits=call.limits,
                          budget=_budget(settings), floating_base=call.floating_base, normalize=call.normalize)
    record_configurations("jacobian", _configurations(call.q))
    J, verification = answer.jacobians, answer.verification
    if wants_npy(request):
        headers = _names_headers([answer.link], answer.model.joint_names)
        headers.update({"X-Link": headers.pop("X-Links", ""), "X-Reference": answer.reference.value,
                        "X-Out-Of-Limits": str(answer.out_of_limits_count())})
        headers.update(_verification_headers(verification))
        return NpyResponse(J, headers=headers)
    oob = answer.out_of_limits()
    measures = answer.conditioning()
    cond = [None if not np.isfinite(c) else float(c) for c in measures["condition_number"]]
    if answer.is_batch:
        body = {"jacobian": J, "singular_values": measures["singular_values"],
                "manipulability": measures["manipulability"], "condition_number": cond, "out_of_limits": oob}
    else:
        body = {"jacobian": J[0], "singular_values": measures["singular_values"][0],
                "manipulability": float(measures["manipulability"][0]), "condition_number": cond[0],
                "out_of_limits": oob[0]}
    return FastJSONResponse({"model": rec.id, "link": answer.link, "reference": answer.reference.value,
                             "joint_names": list(answer.model.joint_names), **body,
                             "verification": verification.as_dict() if verification else None})


def _analytic_jacobian(model_id: str, call: Call, request: Request, registry, settings: Settings):
    """The Jacobian route with ``representation``: ``J_r = dr/dq`` and ``r`` (:func:`kinematics.api.task`)."""
    # J_r = dr/dq is a derivative of coordinates: no reference frame enters it (it is built from the
    # local_world_aligned Jacobian, which the answer names). components alone: the default task, rpy.
    rec = registry.get(model_id)
    model = api.model_for(rec.model, floating_base=call.floating_base)  # task vectors refuse multi-dof joints
    answer = api.task(model, call.q, link=call.link, representation=call.representation or "rpy",
                      components=call.components, base=call.base, point=call.point, tool=call.tool,
                      limits=call.limits, budget=_budget(settings))
    verification = None
    if call.verify:  # Pinocchio has no analytic Jacobian: the geometric one J_r is built from is checked
        verification = api.jacobian(model, call.q, link=answer.link, reference=Reference.LOCAL_WORLD_ALIGNED,
                                    base=call.base, point=call.point, tool=call.tool, verify=True,
                                    limits=call.limits, budget=_budget(settings)).verification
    record_configurations("jacobian", _configurations(call.q))
    labels = list(answer.representation.labels)
    if wants_npy(request):
        headers = _names_headers([answer.link], rec.model.joint_names)
        headers.update({"X-Link": headers.pop("X-Links", ""), "X-Reference": Reference.LOCAL_WORLD_ALIGNED.value,
                        "X-Representation": answer.representation.name, "X-Components": ",".join(labels),
                        "X-Out-Of-Limits": str(answer.out_of_limits_count()), **_verification_headers(verification)})
        return NpyResponse(np.concatenate([answer.J_r, answer.r[:, :, None]], axis=2), headers=headers)
    oob = answer.out_of_limits()
    measures = answer.conditioning()
    cond = [None if not np.isfinite(c) else float(c) for c in measures["condition_number"]]
    k = slice(None) if answer.is_batch else 0
    body = {"jacobian": answer.J_r[k], "r": answer.r[k], "singular_values": measures["singular_values"][k],
            "manipulability": measures["manipulability"][k].tolist(), "condition_number": cond if answer.is_batch
            else cond[0], "out_of_limits": oob if answer.is_batch else oob[0]}
    return FastJSONResponse({"model": rec.id, "link": answer.link, "reference": Reference.LOCAL_WORLD_ALIGNED.value,
                             "representation": answer.representation.name, "components": labels,
                             "joint_names": list(rec.model.joint_names), **body,
                             "verification": verification.as_dict() if verification else None})


def _verification_headers(verification) -> dict[str, str]:
    """The ``.npy`` answer's headers of a Jacobian verification (none without one)."""
    if not verification:
        return {}
    return {"X-Verification-Reference": verification.reference,
            "X-Max-Jacobian-Error": repr(verification.max_jacobian_error)}
