"""The families of IK chains and Cartesian paths: ``GET /models/{id}/ik/family``,
``POST /models/{id}/ik/path``."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, Request

from kinematics import usecases

from ..adapter import LinkQuery, LockedQuery, budget, error_responses, execute, read_request, request_body_doc
from ..deps import ModelId, RegistryDep, SettingsDep, require_read_key
from ..responses import FastJSONResponse
from ..schemas import IK_PATH_EXAMPLES, IKFamilyResponse, IKPathRequest, IKPathResponse
from .ik import collision_avoidance, parse_locked
from .collision import user_pairs

router = APIRouter(tags=["kinematics"], dependencies=[Depends(require_read_key)])


@router.get("/models/{model_id}/ik/family", response_model=IKFamilyResponse,
            responses=error_responses({422: "invalid locked joint"}, statuses=(404, 422)))
def ik_family(model_id: ModelId, registry: RegistryDep, link: LinkQuery = None,
              locked: LockedQuery = None):
    """The structure of the chain to `link` with `locked` joints held: which axes meet or are
    parallel, the family's name, whether it has a closed form and how many solutions at most."""
    rec = registry.get(model_id)
    return FastJSONResponse(usecases.ik_family(usecases.Query(rec.model, link=link), locked=parse_locked(locked)))


async def read_path_request(request: Request, settings: SettingsDep) -> IKPathRequest:
    return await read_request(request, settings, IKPathRequest, empty=('{"waypoints": [...]}', "waypoints"),
                              batch=None)


@router.post("/models/{model_id}/ik/path", response_model=IKPathResponse,
             responses=error_responses({422: "invalid waypoints, seed, locked joint, redundancy or options"}),
             openapi_extra=request_body_doc("IKPathRequest", IK_PATH_EXAMPLES, None))
async def ik_path(model_id: ModelId, req: Annotated[IKPathRequest, Depends(read_path_request)], request: Request,
                  registry: RegistryDep, settings: SettingsDep):
    """A Cartesian path through `waypoints`: straight lines and rotation geodesics cut at `step`,
    each target solved by continuation from the previous row (the nearest solution of the full set),
    never a joint change over `max_joint_step`; where it stops, `stopped` says at which target and why.
    With `avoid_collisions` the path stops at its first row in self-collision (reason `collision`).
    With `redundancy` (`{"select": "nearest" | "margin" | "manipulability"}`) a 7-joint chain moves
    along its self-motion: at each target the parameter is chosen on the previous row's branch, within
    `max_joint_step` and the limits, for the objective; a chain that is not redundant is a 422."""
    return await execute(request, _path, model_id, req, registry, settings)


def _path(model_id: str, req: IKPathRequest, registry, settings):
    rec = registry.get(model_id)
    pairs = user_pairs(registry, rec.id, req) if req.avoid_collisions else None
    ans = usecases.ik_path(req.to_query(rec.model, budget(settings), collision_pairs=pairs), req.waypoints, seed=req.seed, step=req.step,
                           max_joint_step=req.max_joint_step,
                           options=req.ik_options(collision_avoidance(registry, settings)))
    return FastJSONResponse(IKPathResponse.content(rec.id, req.link or rec.model.leaf_links[0], rec.model.joint_names,
                                                   ans))
