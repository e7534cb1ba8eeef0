"""Link velocities: ``POST /models/{id}/velocity``, in JSON or with an ``.npy`` body and answer.

A JSON body is a ``VelocityRequest`` (``q`` and ``qdot`` in the same form: one vector or map,
or a list of them). With ``Content-Type: application/x-npy`` the body is an ``(N, 2 dof)``
(or ``(2 dof,)``) float64 array, each row ``[q | qdot]`` (joint values, then joint velocities,
both in ``joint_names`` order), and the options are query parameters (``links``, ``verify``,
``limits``, ``point``). ``Accept: application/x-npy`` answers the twists as an
``(N, links, 3, 6)`` array: per link the twists in the references named by
``X-Twist-References`` (``world,local,local_world_aligned``), linear part first; link order in
``X-Links``.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from fastapi import APIRouter, Depends, Query, Request

from kinematics import api
from kinematics.spatial.reference import Reference

from ..deps import ModelId, RegistryDep, SettingsDep, media_type, read_body, require_read_key, wants_npy
from ..errors import ProblemError
from ..heavy import parse_body, run_heavy
from ..npy import decode_q
from ..responses import NPY_MEDIA_TYPE, FastJSONResponse, NpyResponse
from ..schemas import VELOCITY_EXAMPLES, Problem, VelocityRequest, VelocityResponse
from ..settings import Settings
from .kinematics import INLINE_MAX_CONFIGURATIONS, FloatingBaseQuery, NormalizeQuery, PointQuery, _budget, _configurations, _names_headers, _split_names, parse_point

router = APIRouter(tags=["kinematics"], dependencies=[Depends(require_read_key)])

#: the order of the twists of an .npy answer (``X-Twist-References``)
TWIST_ORDER = (Reference.WORLD, Reference.LOCAL, Reference.LOCAL_WORLD_ALIGNED)

_ERRORS = {
    400: {"model": Problem, "description": "malformed body"},
    404: {"model": Problem, "description": "unknown model or link"},
    413: {"model": Problem, "description": "body, batch or result over the configured limit"},
    415: {"model": Problem, "description": "unsupported content type"},
    422: {"model": Problem, "description": "invalid joint values or velocities, limits refused, or invalid options"},
    503: {"model": Problem, "description": "over the time budget KIN_REQUEST_TIMEOUT (time-budget-exceeded)"},
}


async def read_velocity_request(
    request: Request, settings: SettingsDep,
    links: Annotated[list[str] | None, Query(description=".npy bodies: link names (repeat or comma-separate), or `all`")] = None,
    verify: Annotated[bool, Query(description=".npy bodies: compare with Pinocchio")] = False,
    limits: Annotated[Literal["report", "refuse"], Query(description=".npy bodies: out-of-limit policy")] = "report",
    point: PointQuery = None,
    floating_base: FloatingBaseQuery = False,
    normalize: NormalizeQuery = False,
) -> dict[str, Any]:
    """The request as :func:`kinematics.api.velocity` keywords (plus ``q``, ``qdot``), whatever its encoding."""
    body = await read_body(request, settings.max_request_bytes, "request body")
    kind = media_type(request)
    if kind == NPY_MEDIA_TYPE:
        arr = decode_q(body)
        return {"q_qdot": arr, "links": _split_names(links), "verify": verify, "limits": limits,
                "point": parse_point(point), "floating_base": floating_base, "normalize": normalize}
    if kind not in ("application/json", ""):
        raise ProblemError(415, f"Content-Type {kind!r} is not supported: send application/json or {NPY_MEDIA_TYPE}",
                           slug="unsupported-media-type")
    if not body:
        raise ProblemError(422, 'the body is empty: send {"q": [...], "qdot": [...]}', slug="validation-error", field="q")
    req = await parse_body(request, VelocityRequest, body)
    _budget(settings).check_batch(_configurations(req["q"]))  # before the library reads a huge batch
    return req


def _split_npy(arr: np.ndarray, dof: int, nq: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(q, qdot)`` of an ``(N, nq + nv)`` or ``(nq + nv,)`` array of rows ``[q | qdot]`` (``nq = nv = dof``
    for models of one-dof joints)."""
    nq = dof if nq is None else nq
    if arr.shape[-1] != nq + dof:
        what = f"dof {dof}" if nq == dof else f"nq {nq}, nv {dof}"
        raise ProblemError(422, f"a velocity .npy body holds rows [q | qdot] of {nq + dof} numbers ({what}), "
                           f"got shape {arr.shape}", slug="invalid-npy", field="body")
    return arr[..., :nq], arr[..., nq:]


@router.post(
    "/models/{model_id}/velocity", response_model=VelocityResponse,
    responses={200: {"content": {NPY_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary", "description":
               "(N, links, 3, 6) float64 twists, references in X-Twist-References order, linear part first"}}}},
               **_ERRORS},
    openapi_extra={"requestBody": {"required": True, "content": {
        "application/json": {"schema": {"$ref": "#/components/schemas/VelocityRequest"}, "examples": VELOCITY_EXAMPLES},
        NPY_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary", "description":
                                    "np.save of float64 rows [q | qdot], (N, 2 dof) or (2 dof,); options as query parameters"}},
    }}},
)
async def velocity(model_id: ModelId, options: Annotated[dict, Depends(read_velocity_request)], request: Request,
                   registry: RegistryDep, settings: SettingsDep):
    """Velocity of links (default: every link) for joint values `q` and joint velocities `qdot`.

    Per link: `linear`, the velocity of its origin, and `angular`, its angular velocity, both in
    world axes, and `twist` in the three references (`world`: the body's twist at the world
    origin; `local`: in the link's axes; `local_world_aligned`: `[linear, angular]`), linear part
    first, as Pinocchio's `getFrameVelocity`. Computed in one pass down the tree (not one
    Jacobian product per link). `point` / `tool`: the velocity of the frame at that offset from
    each link. `verify: true` compares with Pinocchio.
    """
    q = options.get("q", options.get("q_qdot"))
    if _configurations(q) <= INLINE_MAX_CONFIGURATIONS:
        return _velocity(model_id, options, request, registry, settings)
    return await run_heavy(request, _velocity, model_id, options, request, registry, settings)


def _velocity(model_id: str, options: dict[str, Any], request: Request, registry, settings: Settings):
    rec = registry.get(model_id)
    options = dict(options)
    if "q_qdot" in options:
        model = api.model_for(rec.model, options.get("floating_base", False))
        options["q"], options["qdot"] = _split_npy(options.pop("q_qdot"), model.nv, model.nq)
    answer = api.velocity(rec.model, options.pop("q"), options.pop("qdot"), budget=_budget(settings), **options)
    verification = answer.verification
    if wants_npy(request):
        headers = _names_headers(answer.links, answer.model.joint_names)
        headers.update({"X-Twist-References": ",".join(r.value for r in TWIST_ORDER),
                        "X-Out-Of-Limits": str(answer.out_of_limits_count())})
        if verification:
            headers.update({"X-Verification-Reference": verification.reference,
                            "X-Max-Velocity-Error": repr(verification.max_velocity_error)})
        return NpyResponse(np.stack([answer.twists[r] for r in TWIST_ORDER], axis=2), headers=headers)
    tw = {r.value: answer.twists[r] for r in Reference}
    lwa = answer.twists[Reference.LOCAL_WORLD_ALIGNED]

    def per_link(n: int) -> dict[str, Any]:
        return {link: {"linear": lwa[n, k, :3], "angular": lwa[n, k, 3:],
                       "twist": {name: t[n, k] for name, t in tw.items()}}
                for k, link in enumerate(answer.links)}

    N = answer.Q.shape[0]
    oob = answer.out_of_limits()
    return FastJSONResponse({
        "model": rec.id, "joint_names": list(answer.model.joint_names), "links": answer.links,
        "velocities": [per_link(n) for n in range(N)] if answer.is_batch else per_link(0),
        "out_of_limits": oob if answer.is_batch else oob[0],
        "verification": verification.as_dict() if verification else None,
    })
