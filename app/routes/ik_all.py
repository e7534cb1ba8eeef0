"""The families of IK chains and Cartesian paths: ``GET /models/{id}/ik/family``,
``POST /models/{id}/ik/path``."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, Query, Request

from kinematics import api

from ..deps import ModelId, RegistryDep, SettingsDep, read_body, require_read_key
from ..errors import ProblemError
from ..heavy import run_heavy
from ..ik_all_schemas import IKFamilyResponse, IKPathRequest, IKPathResponse
from ..responses import FastJSONResponse
from ..schemas import Problem
from .ik import parse_locked

router = APIRouter(tags=["kinematics"], dependencies=[Depends(require_read_key)])

_ERRORS = {
    404: {"model": Problem, "description": "unknown model or link"},
    422: {"model": Problem, "description": "invalid waypoints, seed, locked joint or options"},
}


@router.get("/models/{model_id}/ik/family", response_model=IKFamilyResponse, responses=_ERRORS)
def ik_family(model_id: ModelId, registry: RegistryDep,
              link: Annotated[str | None, Query(description="the link (default: the first leaf link)")] = None,
              locked: Annotated[list[str] | None, Query(description="joint:value, repeated")] = None):
    """The structure of the chain to `link` with `locked` joints held: which axes meet or are
    parallel, the family's name, whether it has a closed form and how many solutions at most."""
    rec = registry.get(model_id)
    return FastJSONResponse(api.ik_family(rec.model, link=link, locked=parse_locked(locked)))


@router.post("/models/{model_id}/ik/path", response_model=IKPathResponse, responses=_ERRORS)
async def ik_path(model_id: ModelId, request: Request, registry: RegistryDep, settings: SettingsDep):
    """A Cartesian path through `waypoints`: straight lines and rotation geodesics cut at `step`,
    each target solved by continuation from the previous row (the nearest solution of the full set),
    never a joint change over `max_joint_step`; where it stops, `stopped` says at which target and why."""
    body = await read_body(request, settings.max_request_bytes, "request body")
    if not body:
        raise ProblemError(422, 'the body is empty: send {"waypoints": [...]}', slug="validation-error",
                           field="waypoints")
    req = IKPathRequest.model_validate_json(body).model_dump()  # a few waypoints: decoded on the loop
    if req.pop("avoid_collisions"):
        raise ProblemError(422, "avoid_collisions: self-collision checks are not available for paths yet",
                           slug="validation-error", field="avoid_collisions")
    return await run_heavy(request, _path, model_id, req, registry)


def _path(model_id: str, req: dict, registry):
    rec = registry.get(model_id)
    tol = req.pop("tolerance")
    ans = api.ik_path(rec.model, req.pop("waypoints"), position_tolerance=tol["position"],
                      rotation_tolerance=tol["rotation"], **req)
    return FastJSONResponse({
        "model": rec.id, "link": req.get("link") or rec.model.leaf_links[0], "family": ans.family,
        "joint_names": list(rec.model.joint_names), "q": ans.q, "targets": ans.targets,
        "position_error": ans.position_error, "rotation_error": ans.rotation_error, "fraction": ans.fraction,
        "complete": ans.complete, "stopped": ans.stopped, "max_joint_step": ans.max_joint_step,
    })
