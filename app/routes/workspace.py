"""Workspace sampling: ``POST /models/{id}/workspace``.

The body is a ``WorkspaceRequest`` (JSON). The JSON answer summarises the sampled set: bounding
box, reach, occupancy-grid volume (area for a planar arm) with its convergence, the cell size
and the manipulability range. The cloud itself comes with ``Accept: application/x-npz`` (an
uncompressed ``.npz``: ``points`` (N, 3), ``manipulability`` (N,), the dexterity map
``voxel_centers`` (M, 3), ``voxel_index`` (M, 3), ``voxel_manipulability`` (M,), and the summary
as arrays) or ``Accept: application/x-npy`` (an (N, 4) array of rows ``x, y, z, manipulability``,
what the viewer draws). Samples are bounded by ``max_workspace_samples`` (413
``workspace-samples-too-large``), the cloud by ``max_result_values`` (413 ``result-too-large``).
"""

from __future__ import annotations

from typing import Annotated, Any

import numpy as np
from fastapi import APIRouter, Depends, Request

from kinematics import api

from ..deps import ModelId, RegistryDep, SettingsDep, media_type, read_body, require_read_key, wants_npy
from ..errors import ProblemError
from ..heavy import run_heavy
from ..responses import NPY_MEDIA_TYPE, NPZ_MEDIA_TYPE, FastJSONResponse, NpyResponse, NpzResponse
from ..schemas import WORKSPACE_EXAMPLES, Problem, WorkspaceRequest, WorkspaceResponse
from ..settings import Settings

router = APIRouter(tags=["kinematics"], dependencies=[Depends(require_read_key)])

_ERRORS = {
    400: {"model": Problem, "description": "malformed body"},
    404: {"model": Problem, "description": "unknown model or link"},
    413: {"model": Problem, "description": "samples over max_workspace_samples, or the cloud over max_result_values"},
    415: {"model": Problem, "description": "unsupported content type"},
    422: {"model": Problem, "description": "invalid options (point, tool, voxel, a prismatic joint without limits)"},
    503: {"model": Problem, "description": "over the time budget KIN_REQUEST_TIMEOUT (time-budget-exceeded)"},
}


async def read_workspace_request(request: Request, settings: SettingsDep) -> dict[str, Any]:
    body = await read_body(request, settings.max_request_bytes, "request body")
    kind = media_type(request)
    if kind not in ("application/json", ""):
        raise ProblemError(415, f"Content-Type {kind!r} is not supported: send application/json",
                           slug="unsupported-media-type")
    return WorkspaceRequest.model_validate_json(body or b"{}").model_dump()


def _wants_npz(request: Request) -> bool:
    return NPZ_MEDIA_TYPE in request.headers.get("accept", "").lower()


@router.post(
    "/models/{model_id}/workspace", response_model=WorkspaceResponse,
    responses={200: {"content": {
        NPZ_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary", "description":
                         "np.savez: points (N, 3), manipulability (N,), voxel_centers (M, 3), voxel_index (M, 3), "
                         "voxel_manipulability (M,), bounding_box (2, 3), reach, volume, area, convergence (k, 2), "
                         "voxel, cell (3,), axes (3, 3), origin (3,)"}},
        NPY_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary",
                                    "description": "(N, 4) float64 rows x, y, z, manipulability"}}}},
               **_ERRORS},
    openapi_extra={"requestBody": {"required": False, "content": {
        "application/json": {"schema": {"$ref": "#/components/schemas/WorkspaceRequest"}, "examples": WORKSPACE_EXAMPLES},
    }}},
)
async def workspace(model_id: ModelId, options: Annotated[dict, Depends(read_workspace_request)], request: Request,
                    registry: RegistryDep, settings: SettingsDep):
    """The reachable set of a link (or of a `point` / `tool` frame on it), sampled.

    `samples` configurations are drawn uniformly within the joint limits (`random_seed`), run
    through the compiled FK and Jacobian kernels, and give: the `bounding_box`, the `reach` (largest
    distance from the root), an occupancy-grid `volume` (for a planar arm, `area`) with its
    `convergence` over N/4, N/2 and N samples, the cell size (`voxel`, `cell`) and the range of the
    `manipulability` (product of the singular values of the Jacobian). The cloud and the dexterity
    map (best manipulability per cell) come as `.npz` with `Accept: application/x-npz`.
    """
    return await run_heavy(request, _workspace, model_id, options, request, registry, settings)


def _workspace(model_id: str, options: dict[str, Any], request: Request, registry, settings: Settings):
    rec = registry.get(model_id)
    budget = api.Budget(max_result_values=settings.max_result_values,
                        max_workspace_samples=settings.max_workspace_samples)
    cloud = _wants_npz(request) or wants_npy(request)
    if cloud:
        budget.check_workspace_samples(options["samples"])
        budget.check_result(options["samples"] * 4, f"a cloud of {options['samples']} samples x 4")
    ws = api.workspace(rec.model, budget=budget, **options)
    planar = ws.dimension < 3
    if wants_npy(request) and not _wants_npz(request):
        return NpyResponse(np.column_stack([ws.points, ws.manipulability]),
                           headers={"X-Link": ws.link, "X-Columns": "x,y,z,manipulability"})
    if _wants_npz(request):
        arrays = {
            "points": ws.points, "manipulability": ws.manipulability, "voxel_centers": ws.voxel_centers,
            "voxel_index": ws.voxel_index, "voxel_manipulability": ws.voxel_manipulability,
            "bounding_box": ws.bounding_box, "reach": np.float64(ws.reach), "volume": np.float64(ws.volume),
            "convergence": np.array(ws.convergence, dtype=np.float64).reshape(-1, 2), "voxel": np.float64(ws.voxel),
            "cell": ws.cell, "axes": ws.axes, "origin": ws.origin, "dimension": np.int64(ws.dimension),
        }
        if planar:
            arrays["area"] = np.float64(ws.area)
        return NpzResponse(arrays, headers={"X-Link": ws.link})
    key = "area" if planar else "volume"
    M = ws.manipulability
    body = {
        "model": rec.id, "link": ws.link, "samples": ws.samples, "random_seed": ws.random_seed, "measure": ws.measure,
        "dimension": ws.dimension,
        "bounding_box": {"min": ws.bounding_box[0], "max": ws.bounding_box[1]},
        "reach": ws.reach, "volume": ws.volume,
        "convergence": [{"samples": n, key: v} for n, v in ws.convergence],
        "converged": ws.converged, "advice": ws.advice,
        "voxel": ws.voxel, "cell": ws.cell, "occupied_voxels": int(ws.voxel_centers.shape[0]),
        "manipulability": {"min": float(M.min()), "mean": float(M.mean()), "max": float(M.max())},
    }
    if planar:
        body["area"] = ws.area
    return FastJSONResponse(body)
