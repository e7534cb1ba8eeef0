"""Self-collision: ``POST /models/{id}/collision`` and ``GET /models/{id}/collision/matrix``.

The checks run on the enabled pairs of the model's allowed-collision matrix, computed once per
model from ``KIN_COLLISION_SAMPLES`` random configurations and kept in the data directory
(``<data_dir>/derived/collision/``) like other derived data, so every worker and every restart
reads it back.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from fastapi import APIRouter, Depends, Query, Request
from fastapi.responses import Response

from kinematics import usecases

from ..adapter import budget, checked, error_responses, execute, one_or_all, read_request, request_body_doc
from ..deps import ModelId, RegistryDep, SettingsDep, require_read_key
from ..responses import FastJSONResponse
from ..schemas import COLLISION_EXAMPLES, CollisionMatrixResponse, CollisionRequest, CollisionResponse
from ..settings import Settings

router = APIRouter(tags=["collision"], dependencies=[Depends(require_read_key)])

_EMPTY = ('{"q": [0, 0, 0, 0, 0, 0]}', "q")
SRDF_MEDIA_TYPE = "application/xml"


def cache_dir(registry) -> Path:
    """Where the allowed-collision matrices of the service are kept."""
    return Path(registry.data_dir) / "derived" / "collision"


async def read_collision_request(request: Request, settings: SettingsDep) -> CollisionRequest:
    return await read_request(request, settings, CollisionRequest, empty=_EMPTY)


@router.post(
    "/models/{model_id}/collision", response_model=CollisionResponse,
    responses=error_responses({404: "unknown model",
                               422: "invalid joint values or margin"}),
    openapi_extra=request_body_doc("CollisionRequest", COLLISION_EXAMPLES),
)
async def collision(model_id: ModelId, req: Annotated[CollisionRequest, Depends(read_collision_request)],
                    request: Request, registry: RegistryDep, settings: SettingsDep):
    """Self-collision of one configuration or a batch.

    Geometry is the URDF's `<collision>` elements (primitives; meshes of catalogue models from
    the installed packages, of uploads only from inside an uploaded archive). The pairs checked
    are those the allowed-collision matrix (`GET .../collision/matrix`) leaves enabled; pairs
    closer than `margin` count as colliding. With `distance`: the minimum distance over those
    pairs, the closest pair and its witness points (root frame).
    """
    return await execute(request, _collision, model_id, req, registry, settings,
                         inline=False)  # even one configuration may first compute the matrix


def _closest(pair, points):
    return None if pair is None else {"links": list(pair), "points": points.tolist()}


def _number(x: float):
    return None if x == float("inf") else float(x)


def _collision(model_id: str, req: CollisionRequest, registry, settings: Settings):
    rec = registry.get(model_id)
    query = req.to_query(rec.model, budget(settings))
    a = usecases.collision(query, req.q, distance=req.distance, margin=req.margin,
                           samples=settings.collision_samples, cache_dir=cache_dir(registry))
    pick = one_or_all(a.is_batch)
    body = {
        "model": rec.id, "joint_names": list(a.joint_names),
        "colliding": pick(a.colliding.tolist()),
        "pairs": pick([[list(p) for p in row] for row in checked(a.pairs)]),
        "checked_pairs": len(a.checked), "links": list(a.links), "warnings": list(a.warnings),
    }
    if req.distance:
        body["min_distance"] = pick([_number(d) for d in a.min_distance])
        body["closest"] = pick([_closest(c, p) for c, p in checked(zip(a.closest, a.points))])
    return FastJSONResponse(body)


@router.get(
    "/models/{model_id}/collision/matrix", response_model=CollisionMatrixResponse,
    responses={200: {"content": {SRDF_MEDIA_TYPE: {"schema": {"type": "string"},
                                                   "description": "with ?format=srdf: SRDF disable_collisions"}}},
               **error_responses({404: "unknown model"}, statuses=(404, 422, 503))},
)
async def collision_matrix(model_id: ModelId, request: Request, registry: RegistryDep, settings: SettingsDep,
                           format: Annotated[Literal["json", "srdf"], Query(
                               description="json (default) or srdf (MoveIt's disable_collisions)")] = "json"):
    """The allowed-collision matrix: the link pairs never checked, each with its reason, as
    MoveIt's Setup Assistant makes them: `adjacent` (the parent and child links of a joint, links
    without geometry between them bridged), `always` (in collision in every sampled
    configuration), `never` (in none of `samples` random configurations). Computed once per
    model and kept in the data directory; `?format=srdf` gives it as SRDF."""
    return await execute(request, _matrix, model_id, format, registry, settings)


def _matrix(model_id: str, fmt: str, registry, settings: Settings):
    rec = registry.get(model_id)
    matrix = usecases.collision_matrix(rec.model, settings.collision_samples, cache_dir=cache_dir(registry))
    if fmt == "srdf":
        return Response(matrix.to_srdf(rec.model.name), media_type=SRDF_MEDIA_TYPE)
    return FastJSONResponse({"model": rec.id, **matrix.as_dict()})
