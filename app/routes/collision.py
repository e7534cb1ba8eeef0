"""Self-collision: ``POST /models/{id}/collision``, ``GET /models/{id}/collision/matrix`` and the
model's own pairs, ``GET|PUT /models/{id}/collision/pairs``.

The checks run on the enabled pairs of the model's allowed-collision matrix, computed once per
model from ``KIN_COLLISION_SAMPLES`` random configurations and kept in the data directory
(``<data_dir>/derived/collision/``) like other derived data, so every worker and every restart
reads it back. The pairs a user allows and forbids are laid over it: first the model's settings
(kept in its sidecar by the registry), then the request's ``allow`` / ``forbid`` (:func:`user_pairs`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from fastapi import APIRouter, Depends, Query, Request
from fastapi.responses import Response

from kinematics import usecases
from kinematics.errors import CollisionError

from ..adapter import budget, checked, error_responses, execute, one_or_all, read_request, request_body_doc
from ..deps import ModelId, RegistryDep, SettingsDep, require_read_key, require_write_key
from ..responses import FastJSONResponse
from ..schemas import (COLLISION_EXAMPLES, CollisionMatrixResponse, CollisionPairsRequest, CollisionPairsResponse,
                       CollisionRequest, CollisionResponse)
from ..settings import Settings

router = APIRouter(tags=["collision"], dependencies=[Depends(require_read_key)])

_EMPTY = ('{"q": [0, 0, 0, 0, 0, 0]}', "q")
#: the most pairs the matrix's query string may name
MAX_QUERY_PAIRS = 1000
SRDF_MEDIA_TYPE = "application/xml"


def cache_dir(registry) -> Path:
    """Where the allowed-collision matrices of the service are kept."""
    return Path(registry.data_dir) / "derived" / "collision"


def user_pairs(registry, model_id: str, req=None, allow=(), forbid=()) -> "usecases.UserPairs | None":
    """The pairs a check of ``model_id`` allows and forbids: the model's settings, then the request's
    (``req.allow`` / ``req.forbid``, or ``allow`` / ``forbid``): a pair the request names takes its
    choice. None when neither sets any."""
    stored = registry.collision_pairs(model_id)
    base = usecases.UserPairs(**stored) if stored else None
    if req is not None:
        allow, forbid = req.allow, req.forbid
    asked = usecases.UserPairs(allow, forbid) if (allow or forbid) else None
    return base.then(asked) if base is not None else asked


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
    query = req.to_query(rec.model, budget(settings), collision_pairs=user_pairs(registry, rec.id, req))
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
                               description="json (default) or srdf (MoveIt's disable_collisions)")] = "json",
                           allow: Annotated[list[str], Query(max_length=MAX_QUERY_PAIRS, description=(
                               "a link pair `a,b` also disabled (reason user); repeat for more"))] = [],  # noqa: B006
                           forbid: Annotated[list[str], Query(max_length=MAX_QUERY_PAIRS, description=(
                               "a link pair `a,b` checked even if the matrix disables it; repeat for more"))] = []):  # noqa: B006
    """The allowed-collision matrix: the link pairs never checked, each with its reason, as
    MoveIt's Setup Assistant makes them: `adjacent` (the parent and child links of a joint, links
    without geometry between them bridged), `always` (in collision in every sampled
    configuration), `never` (in none of `samples` random configurations), `user` (allowed by the
    model's settings or `allow`). `enabled` lists the pairs the model's settings or `forbid` make
    checked though the matrix would disable them. Computed once per model and kept in the data
    directory; `?format=srdf` gives it as SRDF (`disable_collisions`, then `enable_collisions`)."""
    return await execute(request, _matrix, model_id, format, registry, settings,
                         [_query_pair(p, "allow") for p in allow], [_query_pair(p, "forbid") for p in forbid])


def _query_pair(text: str, field: str) -> list[str]:
    names = [n.strip() for n in text.split(",")]
    if len(names) != 2 or not all(names):
        raise CollisionError(f"{field}: {text[:200]!r} is not a link pair; give two link names as a,b")
    return names


def _matrix(model_id: str, fmt: str, registry, settings: Settings, allow=(), forbid=()):
    rec = registry.get(model_id)
    matrix = usecases.collision_matrix(rec.model, settings.collision_samples, cache_dir=cache_dir(registry),
                                       collision_pairs=user_pairs(registry, rec.id, allow=allow, forbid=forbid))
    if fmt == "srdf":
        return Response(matrix.to_srdf(rec.model.name), media_type=SRDF_MEDIA_TYPE)
    return FastJSONResponse({"model": rec.id, **matrix.as_dict()})


@router.get("/models/{model_id}/collision/pairs", response_model=CollisionPairsResponse,
            responses=error_responses({404: "unknown model"}))
def get_collision_pairs(model_id: ModelId, registry: RegistryDep):
    """The model's own link pairs: `allow` (never checked, reason `user`) and `forbid` (always
    checked), laid under every self-collision check of the model (a request's own `allow` /
    `forbid` over them)."""
    stored = registry.collision_pairs(model_id) or {}
    return {"model": model_id, "allow": stored.get("allow", []), "forbid": stored.get("forbid", [])}


@router.put("/models/{model_id}/collision/pairs", response_model=CollisionMatrixResponse,
            dependencies=[Depends(require_write_key)], responses=error_responses({404: "unknown model", 422: "a pair naming an unknown link, a link without "
                                                                   "collision geometry, or a pair both allowed "
                                                                   "and forbidden"}))
async def put_collision_pairs(model_id: ModelId, pairs: CollisionPairsRequest, request: Request,
                              registry: RegistryDep, settings: SettingsDep):
    """Set (replace) the model's own link pairs -- a gripper holding a tool (`allow`), a pair the
    sampling called `never` that a task reaches (`forbid`); empty lists clear them. Kept with the
    model in the data directory (every worker sees them at once). Answers the matrix they give."""
    return await execute(request, _put_pairs, model_id, pairs, registry, settings)


def _put_pairs(model_id: str, pairs: CollisionPairsRequest, registry, settings: Settings):
    rec = registry.get(model_id)
    doc = pairs.user_pairs()
    matrix = usecases.collision_matrix(rec.model, settings.collision_samples, cache_dir=cache_dir(registry),
                                       collision_pairs=doc)  # the names checked before anything is kept
    registry.set_collision_pairs(rec.id, doc)
    return FastJSONResponse({"model": rec.id, **matrix.as_dict()})
