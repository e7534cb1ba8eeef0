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

from typing import Annotated, Any

import numpy as np
from fastapi import APIRouter, Depends, Request

from kinematics import usecases
from kinematics.spatial.reference import Reference

from ..adapter import (INLINE_MAX_CONFIGURATIONS, FloatingBaseQuery, LimitsQuery, LinksQuery, NormalizeQuery, PointQuery,
                       VerifyQuery, budget, configurations, error_responses, execute, names_headers, npy_response_doc,
                       one_or_all, parse_point, read_request, request_body_doc, split_names, verification_headers)
from ..deps import ModelId, RegistryDep, SettingsDep, require_read_key, wants_npy
from ..errors import ProblemError
from ..npy import decode_q
from ..responses import FastJSONResponse, NpyResponse
from ..schemas import VELOCITY_EXAMPLES, VelocityRequest, VelocityResponse
from ..settings import Settings

router = APIRouter(tags=["kinematics"], dependencies=[Depends(require_read_key)])

#: the order of the twists of an .npy answer (``X-Twist-References``)
TWIST_ORDER = (Reference.WORLD, Reference.LOCAL, Reference.LOCAL_WORLD_ALIGNED)


async def read_velocity_request(
    request: Request, settings: SettingsDep, links: LinksQuery = None, verify: VerifyQuery = False,
    limits: LimitsQuery = "report", point: PointQuery = None, floating_base: FloatingBaseQuery = False,
    normalize: NormalizeQuery = False,
) -> VelocityRequest:
    """The request, whatever its encoding (an ``.npy`` body: ``q`` holds the rows ``[q | qdot]``, ``qdot`` None,
    split by :func:`split_npy` once the model is known)."""
    def npy(body: bytes) -> dict:
        return {"q": decode_q(body), "qdot": None, "links": split_names(links), "verify": verify, "limits": limits,
                "point": parse_point(point), "floating_base": floating_base, "normalize": normalize}

    return await read_request(request, settings, VelocityRequest, npy=npy, empty=('{"q": [...], "qdot": [...]}', "q"))


def split_npy(arr: np.ndarray, dof: int, nq: int | None = None) -> tuple[np.ndarray, np.ndarray]:
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
    responses={200: npy_response_doc("(N, links, 3, 6) float64 twists, references in X-Twist-References order, "
                                     "linear part first"),
               **error_responses({422: "invalid joint values or velocities, limits refused, or invalid options"})},
    openapi_extra=request_body_doc("VelocityRequest", VELOCITY_EXAMPLES, "np.save of float64 rows [q | qdot], "
                                   "(N, 2 dof) or (2 dof,); options as query parameters"),
)
async def velocity(model_id: ModelId, req: Annotated[VelocityRequest, Depends(read_velocity_request)],
                   request: Request, registry: RegistryDep, settings: SettingsDep):
    """Velocity of links (default: every link) for joint values `q` and joint velocities `qdot`.

    Per link: `linear`, the velocity of its origin, and `angular`, its angular velocity, both in
    world axes, and `twist` in the three references (`world`: the body's twist at the world
    origin; `local`: in the link's axes; `local_world_aligned`: `[linear, angular]`), linear part
    first, as Pinocchio's `getFrameVelocity`. Computed in one pass down the tree (not one
    Jacobian product per link). `point` / `tool`: the velocity of the frame at that offset from
    each link. `verify: true` compares with Pinocchio.
    """
    return await execute(request, _velocity, model_id, req, request, registry, settings,
                         inline=configurations(req.q) <= INLINE_MAX_CONFIGURATIONS)


def _velocity(model_id: str, req: VelocityRequest, request: Request, registry, settings: Settings):
    rec = registry.get(model_id)
    query = req.to_query(rec.model, budget(settings))
    q, qdot = req.q, req.qdot
    if qdot is None:  # an .npy body of rows [q | qdot]
        q, qdot = split_npy(q, query.robot.nv, query.robot.nq)
    answer = usecases.velocity(query, q, qdot)
    if wants_npy(request):
        headers = names_headers(answer.links, answer.model.joint_names)
        headers.update({"X-Twist-References": ",".join(r.value for r in TWIST_ORDER),
                        "X-Out-Of-Limits": str(answer.out_of_limits_count()), **verification_headers(answer.verification)})
        return NpyResponse(np.stack([answer.twists[r] for r in TWIST_ORDER], axis=2), headers=headers)
    tw = {r.value: answer.twists[r] for r in Reference}
    lwa = answer.twists[Reference.LOCAL_WORLD_ALIGNED]

    def per_link(n: int) -> dict[str, Any]:
        return {link: {"linear": lwa[n, k, :3], "angular": lwa[n, k, 3:],
                       "twist": {name: t[n, k] for name, t in tw.items()}}
                for k, link in enumerate(answer.links)}

    one = one_or_all(answer.is_batch)
    return FastJSONResponse({
        "model": rec.id, "joint_names": list(answer.model.joint_names), "links": answer.links,
        "velocities": one([per_link(n) for n in range(answer.Q.shape[0])]),
        "out_of_limits": one(answer.out_of_limits()),
        "verification": answer.verification.as_dict() if answer.verification else None,
    })
