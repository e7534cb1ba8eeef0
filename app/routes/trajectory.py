"""Trajectories: ``POST /models/{id}/trajectory``, answered in JSON or (``Accept:
application/x-npz``) as an ``.npz`` of ``t`` (K,), ``q``, ``qd``, ``qdd`` (K, dof) and a 0-d
``duration``, joint order in ``X-Joint-Names``, the method in ``X-Method``."""

from __future__ import annotations

from typing import Annotated

import numpy as np
from fastapi import APIRouter, Depends, Request

from kinematics import usecases

from ..adapter import budget, error_responses, execute, names_headers, npy_response_doc, read_request, request_body_doc
from ..deps import ModelId, RegistryDep, SettingsDep, require_read_key, wants_npz
from ..responses import FastJSONResponse, NpzResponse
from ..schemas import TRAJECTORY_EXAMPLES, TrajectoryRequest, TrajectoryResponse
from ..settings import Settings

router = APIRouter(tags=["timing"], dependencies=[Depends(require_read_key)])


async def read_trajectory_request(request: Request, settings: SettingsDep) -> TrajectoryRequest:
    return await read_request(request, settings, TrajectoryRequest,
                              empty=('{"waypoints": [...], "limits": {"acceleration": ...}}', "waypoints"),
                              batch="waypoints")


@router.post(
    "/models/{model_id}/trajectory", response_model=TrajectoryResponse,
    responses={200: npy_response_doc("t (K,), q, qd, qdd (K, dof), duration (0-d)", "application/x-npz"),
               **error_responses({413: "a rate or a sample count over the service's limits",
                                  422: "invalid waypoints or limits, or a path leaving the joint limits",
                                  503: "planning over the time budget"})},
    openapi_extra=request_body_doc("TrajectoryRequest", TRAJECTORY_EXAMPLES, None),
)
async def trajectory(model_id: ModelId, req: Annotated[TrajectoryRequest, Depends(read_trajectory_request)],
                     request: Request, registry: RegistryDep, settings: SettingsDep):
    """A trajectory through `waypoints` along the `interpolation` path (the not-a-knot cubic spline of
    `scipy.interpolate.CubicSpline(np.linspace(0, 1, M), waypoints)`, or straight segments with blends
    within `blend` of each corner), from rest to rest, time-optimal under the joints' `velocity` and
    `acceleration` limits and a tool's linear speed, every limit held at every instant; with `jerk`,
    jerk-limited with the acceleration continuous and zero at both ends. Sampled at `rate` from 0 to
    `duration`; `limits` answers the limits used per joint."""
    return await execute(request, _trajectory, model_id, req, request, registry, settings)


def _trajectory(model_id: str, req: TrajectoryRequest, request: Request, registry, settings: Settings):
    rec = registry.get(model_id)
    lim = dict(req.limits)
    tool = lim.get("tool_speed")
    limits = usecases.TrajectoryLimits(lim.get("velocity"), lim.get("acceleration"), lim.get("jerk"),
                                       usecases.ToolSpeed(**dict(tool)) if tool else None)
    ans = usecases.trajectory(usecases.Query(rec.model, budget=budget(settings)), req.waypoints, limits,
                              interpolation=req.interpolation, blend=req.blend, rate=req.rate,
                              sampling=usecases.Sampling(settings.trajectory_max_rate, settings.trajectory_max_samples))
    if wants_npz(request):
        headers = {**names_headers([], ans.joint_names), "X-Method": ans.method}
        return NpzResponse({"t": ans.t, "q": ans.q, "qd": ans.qd, "qdd": ans.qdd,
                            "duration": np.asarray(ans.duration)}, headers=headers)
    return FastJSONResponse({
        "model": rec.id, "joint_names": ans.joint_names, "duration": ans.duration, "method": ans.method,
        "interpolation": req.interpolation, "optimal_duration": ans.optimal_duration, "limits": ans.limits,
        "t": ans.t, "q": ans.q, "qd": ans.qd, "qdd": ans.qdd,
    })
