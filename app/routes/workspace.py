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

from typing import Annotated

import numpy as np
from fastapi import APIRouter, Depends, Request

from kinematics import usecases

from ..adapter import budget, error_responses, execute, npy_response_doc, read_request, request_body_doc
from ..deps import ModelId, RegistryDep, SettingsDep, require_read_key, wants_npy, wants_npz
from ..responses import NPY_MEDIA_TYPE, NPZ_MEDIA_TYPE, FastJSONResponse, NpyResponse, NpzResponse
from ..schemas import WORKSPACE_EXAMPLES, WorkspaceRequest, WorkspaceResponse
from ..settings import Settings
from .collision import cache_dir as collision_cache_dir

router = APIRouter(tags=["kinematics"], dependencies=[Depends(require_read_key)])


async def read_workspace_request(request: Request, settings: SettingsDep) -> WorkspaceRequest:
    return await read_request(request, settings, WorkspaceRequest, batch=None)


@router.post(
    "/models/{model_id}/workspace", response_model=WorkspaceResponse,
    responses={200: {"content": {
        **npy_response_doc("np.savez: points (N, 3), manipulability (N,), voxel_centers (M, 3), voxel_index (M, 3), "
                           "voxel_manipulability (M,), bounding_box (2, 3), reach, volume, area, convergence (k, 2), "
                           "voxel, cell (3,), axes (3, 3), origin (3,)", NPZ_MEDIA_TYPE)["content"],
        **npy_response_doc("(N, 4) float64 rows x, y, z, manipulability", NPY_MEDIA_TYPE)["content"]}},
               **error_responses({413: "samples over max_workspace_samples, or the cloud over max_result_values",
                                  422: "invalid options (point, tool, voxel, a prismatic joint without limits)"})},
    openapi_extra=request_body_doc("WorkspaceRequest", WORKSPACE_EXAMPLES, required=False),
)
async def workspace(model_id: ModelId, req: Annotated[WorkspaceRequest, Depends(read_workspace_request)],
                    request: Request, registry: RegistryDep, settings: SettingsDep):
    """The reachable set of a link (or of a `point` / `tool` frame on it), sampled.

    `samples` configurations are drawn uniformly within the joint limits (`random_seed`), run
    through the compiled FK and Jacobian kernels, and give: the `bounding_box`, the `reach` (largest
    distance from the root), an occupancy-grid `volume` (for a planar arm, `area`) with its
    `convergence` over N/4, N/2 and N samples, the cell size (`voxel`, `cell`) and the range of the
    `manipulability` (product of the singular values of the Jacobian). The cloud and the dexterity
    map (best manipulability per cell) come as `.npz` with `Accept: application/x-npz`.
    """
    return await execute(request, _workspace, model_id, req, request, registry, settings)


def _workspace(model_id: str, req: WorkspaceRequest, request: Request, registry, settings: Settings):
    rec = registry.get(model_id)
    query = req.to_query(rec.model, budget(settings))
    if wants_npz(request) or wants_npy(request):  # the cloud: bounded before it is sampled
        query.budget.check_workspace_samples(req.samples)
        query.budget.check_result(req.samples * 4, f"a cloud of {req.samples} samples x 4")
    ws = usecases.workspace(query, samples=req.samples, voxel=req.voxel, measure=req.measure,
                            random_seed=req.random_seed, collision_free=req.collision_free,
                            collision_samples=settings.collision_samples, cache_dir=collision_cache_dir(registry))
    planar = ws.dimension < 3
    if wants_npy(request) and not wants_npz(request):
        return NpyResponse(np.column_stack([ws.points, ws.manipulability]),
                           headers={"X-Link": ws.link, "X-Columns": "x,y,z,manipulability",
                                    "X-Dropped": str(ws.dropped)})
    if wants_npz(request):
        arrays = {
            "points": ws.points, "manipulability": ws.manipulability, "voxel_centers": ws.voxel_centers,
            "voxel_index": ws.voxel_index, "voxel_manipulability": ws.voxel_manipulability,
            "bounding_box": ws.bounding_box, "reach": np.float64(ws.reach), "volume": np.float64(ws.volume),
            "convergence": np.array(ws.convergence, dtype=np.float64).reshape(-1, 2), "voxel": np.float64(ws.voxel),
            "cell": ws.cell, "axes": ws.axes, "origin": ws.origin, "dimension": np.int64(ws.dimension),
            "dropped": np.int64(ws.dropped),
        }
        if planar:
            arrays["area"] = np.float64(ws.area)
        return NpzResponse(arrays, headers={"X-Link": ws.link})
    key = "area" if planar else "volume"
    M = ws.manipulability
    body = {
        "model": rec.id, "link": ws.link, "samples": ws.samples, "collision_free": ws.collision_free,
        "dropped": ws.dropped, "random_seed": ws.random_seed, "measure": ws.measure,
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
