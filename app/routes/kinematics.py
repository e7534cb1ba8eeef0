"""Forward kinematics and Jacobians, in JSON or NumPy ``.npy`` (binary batch transport).

Both endpoints take either a JSON body (``FKRequest`` / ``JacobianRequest``) or, with
``Content-Type: application/x-npy``, an ``(N, dof)`` float64 array with the other options
as query parameters. ``Accept: application/x-npy`` returns ``(N, links, 4, 4)`` poses or
``(N, 6, dof)`` Jacobians, with the link order in ``X-Links`` and the joint order in
``X-Joint-Names`` (comma-separated, each name percent-encoded). The Jacobian's
``representation`` answers the analytic Jacobian ``J_r`` and ``r`` of :func:`kinematics.task`
instead (``.npy``: ``(N, m, dof + 1)``, ``[J_r | r]``).
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from fastapi import APIRouter, Depends, Query, Request

from kinematics import usecases
from kinematics.spatial.reference import Reference

from ..adapter import (INLINE_MAX_CONFIGURATIONS, FloatingBaseQuery, LimitsQuery, LinkQuery, LinksQuery,  # noqa: F401
                       NormalizeQuery, PlainJSONRoute, PointQuery, VerifyQuery, budget, configurations,
                       error_responses, execute, names_headers, npy_response_doc, parse_point,
                       plain_json, read_request, request_body_doc, split_names, verification_headers)
from ..deps import ModelId, RegistryDep, SettingsDep, require_read_key, wants_npy
from ..metrics import record_configurations
from ..npy import decode_q
from ..responses import CHUNK_ITEMS, FastJSONResponse, NpyResponse, SmallJSONResponse
from ..schemas import (FK_EXAMPLES, JACOBIAN_EXAMPLES, FKRequest, FKResponse, JacobianRequest, JacobianResponse,
                       TaskRepresentationName)
from ..schemas.jacobian import check_analytic_reference
from ..settings import Settings

router = APIRouter(tags=["kinematics"], dependencies=[Depends(require_read_key)], route_class=PlainJSONRoute)

_EMPTY = ('{"q": [...]}', "q")


async def read_fk_request(
    request: Request, settings: SettingsDep, links: LinksQuery = None, verify: VerifyQuery = False,
    limits: LimitsQuery = "report",
    format: Annotated[Literal["pose", "matrix", "compact"], Query(description=".npy bodies with a JSON answer: pose format")] = "pose",
    point: PointQuery = None, floating_base: FloatingBaseQuery = False, normalize: NormalizeQuery = False,
) -> FKRequest:
    def npy(body: bytes) -> dict:
        return {"q": decode_q(body), "links": split_names(links), "verify": verify, "limits": limits, "format": format,
                "point": parse_point(point), "floating_base": floating_base, "normalize": normalize}

    return await read_request(request, settings, FKRequest, npy=npy, empty=_EMPTY)


async def read_jacobian_request(
    request: Request, settings: SettingsDep, link: LinkQuery = None,
    reference: Annotated[Reference | None, Query(description=".npy bodies: reference (default world)")] = None,
    verify: VerifyQuery = False, limits: LimitsQuery = "report", point: PointQuery = None,
    floating_base: FloatingBaseQuery = False, normalize: NormalizeQuery = False,
    representation: Annotated[TaskRepresentationName | None, Query(
        description=".npy bodies: the analytic Jacobian of this task representation; the answer is then "
                    "(N, m, dof + 1): J_r in the first dof columns, r in the last")] = None,
    components: Annotated[list[str] | None, Query(
        description=".npy bodies with representation: components kept (repeat or comma-separate)")] = None,
) -> JacobianRequest:
    def npy(body: bytes) -> dict:
        check_analytic_reference(reference, representation, split_names(components))  # a 422, as for JSON
        return {"q": decode_q(body), "link": link, "reference": Reference.WORLD if reference is None else reference,
                "verify": verify, "limits": limits, "point": parse_point(point), "floating_base": floating_base,
                "normalize": normalize, "representation": representation, "components": split_names(components)}

    return await read_request(request, settings, JacobianRequest, npy=npy, empty=_EMPTY)


_NPY_BODY = "np.save of a float64 array (N, dof) or (dof,); options as query parameters"


def _batch_route(path: str, response_model, npy_answer: str, schema, examples):
    """``POST path`` taking JSON or ``.npy`` (``npy_answer`` describes the ``.npy`` answer), and a
    plain JSON body with no query string read straight into ``schema`` and handed to the same
    endpoint (:class:`app.adapter.PlainJSONRoute`)."""
    def declare(endpoint):
        async def plain(request: Request, model_id: str):
            settings = request.app.state.settings
            req = await read_request(request, settings, schema, empty=_EMPTY)
            return await endpoint(model_id, req, request, request.app.state.registry, settings)

        route = router.post(path, response_model=response_model,
                            responses={200: npy_response_doc(npy_answer), **error_responses()},
                            openapi_extra=request_body_doc(schema.__name__, examples, _NPY_BODY))
        return route(plain_json(plain)(endpoint))
    return declare


def _run(handler, model_id: str, req, request: Request, registry, settings: Settings):
    """``handler`` inline for a small batch, in the heavy pool otherwise (:func:`app.adapter.execute`)."""
    return execute(request, handler, model_id, req, request, registry, settings,
                   inline=configurations(req.q) <= INLINE_MAX_CONFIGURATIONS)


@_batch_route("/models/{model_id}/fk", FKResponse, "(N, links, 4, 4) float64 poses T_world_link", FKRequest,
              FK_EXAMPLES)
async def forward_kinematics(model_id: ModelId, req: Annotated[FKRequest, Depends(read_fk_request)], request: Request,
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
    return await _run(_forward_kinematics, model_id, req, request, registry, settings)


def _forward_kinematics(model_id: str, req: FKRequest, request: Request, registry, settings: Settings):
    rec = registry.get(model_id)
    answer = usecases.fk(req.to_query(rec.model, budget(settings)), req.q)
    record_configurations("fk", configurations(req.q))
    verification = answer.verification
    if wants_npy(request):
        headers = names_headers(answer.links, answer.model.joint_names)
        headers["X-Out-Of-Limits"] = str(answer.out_of_limits_count())
        headers.update(verification_headers(verification))
        return NpyResponse(answer.poses, headers=headers)
    return _json(FKResponse.content(rec.id, answer, req.format), answer, len(answer.links))


@_batch_route("/models/{model_id}/jacobian", JacobianResponse, "(N, 6, dof) float64 Jacobians, linear rows first",
              JacobianRequest, JACOBIAN_EXAMPLES)
async def jacobian(model_id: ModelId, req: Annotated[JacobianRequest, Depends(read_jacobian_request)],
                   request: Request, registry: RegistryDep, settings: SettingsDep):
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
    return await _run(_jacobian, model_id, req, request, registry, settings)


def _jacobian(model_id: str, req: JacobianRequest, request: Request, registry, settings: Settings):
    if req.representation is not None or req.components is not None:
        return _analytic_jacobian(model_id, req, request, registry, settings)
    rec = registry.get(model_id)
    answer = usecases.jacobian(req.to_query(rec.model, budget(settings)), req.q, reference=req.reference)
    record_configurations("jacobian", configurations(req.q))
    if wants_npy(request):
        headers = names_headers([answer.link], answer.model.joint_names)
        headers.update({"X-Link": headers.pop("X-Links", ""), "X-Reference": answer.reference.value,
                        "X-Out-Of-Limits": str(answer.out_of_limits_count())})
        headers.update(verification_headers(answer.verification))
        return NpyResponse(answer.jacobians, headers=headers)
    return _json(JacobianResponse.content(rec.id, answer), answer, 1)


def _json(content: dict, answer, links: int) -> FastJSONResponse:
    """The JSON answer of ``content``: encoded in one call when it is small (a few configurations and
    no list longer than a chunk: :class:`app.responses.SmallJSONResponse`), else in parts."""
    small = answer.Q.shape[0] <= INLINE_MAX_CONFIGURATIONS and max(links, answer.Q.shape[1]) <= CHUNK_ITEMS
    return (SmallJSONResponse if small else FastJSONResponse)(content)


def _analytic_jacobian(model_id: str, req: JacobianRequest, request: Request, registry, settings: Settings):
    """The Jacobian route with ``representation``: ``J_r = dr/dq`` and ``r`` (:func:`kinematics.task`)."""
    # J_r = dr/dq is a derivative of coordinates: no reference frame enters it (it is built from the
    # local_world_aligned Jacobian, which the answer names). components alone: the default task, rpy.
    rec = registry.get(model_id)
    query = req.to_query(rec.model, budget(settings))  # task vectors refuse multi-dof joints
    answer = usecases.task(query, req.q, representation=req.representation or "rpy", components=req.components)
    verification = answer.verification  # (Pinocchio has no analytic Jacobian: the geometric one J_r is built from)
    record_configurations("jacobian", configurations(req.q))
    labels = list(answer.representation.labels)
    if wants_npy(request):
        headers = names_headers([answer.link], rec.model.joint_names)
        headers.update({"X-Link": headers.pop("X-Links", ""), "X-Reference": Reference.LOCAL_WORLD_ALIGNED.value,
                        "X-Representation": answer.representation.name, "X-Components": ",".join(labels),
                        "X-Out-Of-Limits": str(answer.out_of_limits_count()), **verification_headers(verification)})
        return NpyResponse(np.concatenate([answer.J_r, answer.r[:, :, None]], axis=2), headers=headers)
    return FastJSONResponse(JacobianResponse.analytic_content(rec.id, answer))
