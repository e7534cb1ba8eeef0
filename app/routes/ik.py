"""Inverse kinematics: ``POST /models/{id}/ik``, in JSON or with ``.npy`` targets and ``.npz`` answers.

A JSON body is an ``IKRequest``. With ``Content-Type: application/x-npy`` the body is an
``(N, 4, 4)`` float64 array of targets ``T_world_link`` and the other options are query
parameters. ``Accept: application/x-npz`` answers an uncompressed ``.npz`` with ``q`` (N, dof),
``success`` (N,), ``position_error`` (N,), ``rotation_error`` (N,) and ``iterations`` (N,)
(joint order in ``X-Joint-Names``).

With ``solutions: "all"`` the answer lists every solution (``count``, ``solutions`` records; the
``.npz`` holds ``q`` (N, K, dof) padded with NaN, ``count`` (N,), ``within_limits``, ``singular``,
``position_error``, ``rotation_error`` (N, K)); ``.npy`` requests give ``locked`` as repeated
``locked=joint:value`` query parameters.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Depends, Query, Request

from kinematics import api
from kinematics.io.poses import pose_count

from ..deps import ModelId, RegistryDep, SettingsDep, media_type, read_body, require_read_key
from ..errors import ProblemError
from ..heavy import parse_body, run_heavy
from ..metrics import record_ik
from ..npy import decode_targets, names_header
from ..responses import NPY_MEDIA_TYPE, NPZ_MEDIA_TYPE, FastJSONResponse, NpzResponse
from ..schemas import IK_EXAMPLES, IKRequest, IKResponse, Problem
from ..settings import Settings
from .kinematics import FloatingBaseQuery, NormalizeQuery, PointQuery, parse_point

router = APIRouter(tags=["kinematics"], dependencies=[Depends(require_read_key)])

#: IK of at most this many targets runs on the event loop (microseconds to a millisecond each);
#: larger batches run in the thread pool so the loop keeps serving
INLINE_MAX_TARGETS = 1
#: ... and of at most this many steps, (restarts + 1) x max_iterations (the defaults: 5,100, a few
#: milliseconds at worst); one target with more may take seconds, so it runs as heavy work
INLINE_MAX_STEPS = 51 * 100

_ERRORS = {
    400: {"model": Problem, "description": "malformed body"},
    404: {"model": Problem, "description": "unknown model or link"},
    413: {"model": Problem, "description": "body, targets or IK work (targets x attempts x iterations) over a limit"},
    415: {"model": Problem, "description": "unsupported content type"},
    422: {"model": Problem, "description": "invalid target, seed or options"},
    503: {"model": Problem, "description": "over the time budget KIN_REQUEST_TIMEOUT (time-budget-exceeded)"},
}


async def read_ik_request(
    request: Request, settings: SettingsDep,
    link: Annotated[str | None, Query(description=".npy bodies: the link (default: the first leaf link)")] = None,
    mode: Annotated[Literal["pose", "position"], Query(description=".npy bodies: pose or position")] = "pose",
    position_tolerance: Annotated[float, Query(ge=1e-12, description=".npy bodies: metres")] = 1e-6,
    rotation_tolerance: Annotated[float, Query(ge=1e-12, description=".npy bodies: radians")] = 1e-6,
    max_iterations: Annotated[int, Query(ge=1, le=10_000, description=".npy bodies: steps per attempt")] = 100,
    restarts: Annotated[int, Query(ge=0, le=10_000, description=".npy bodies: random restarts")] = 50,
    random_seed: Annotated[int, Query(ge=0, le=2**63 - 1, description=".npy bodies: restarts' draws")] = 0,
    verify: Annotated[bool, Query(description=".npy bodies: Pinocchio's FK of every answer")] = False,
    point: PointQuery = None,
    floating_base: FloatingBaseQuery = False,
    normalize: NormalizeQuery = False,
    solutions: Annotated[Literal["one", "all"], Query(description=".npy bodies: one or all")] = "one",
    method: Annotated[Literal["auto", "analytic", "numeric"], Query(description=".npy bodies: the method")] = "auto",
    limits: Annotated[Literal["respect", "ignore"], Query(description=".npy bodies: with solutions all")] = "respect",
    locked: Annotated[list[str] | None, Query(description=".npy bodies: joint:value, repeated")] = None,
) -> dict[str, Any]:
    """The request's options as :func:`kinematics.api.ik` keywords, whatever its encoding."""
    body = await read_body(request, settings.max_request_bytes, "request body")
    kind = media_type(request)
    if kind == NPY_MEDIA_TYPE:
        return {"target": decode_targets(body), "link": link, "mode": mode, "position_tolerance": position_tolerance,
                "rotation_tolerance": rotation_tolerance, "max_iterations": max_iterations, "restarts": restarts,
                "random_seed": random_seed, "verify": verify, "point": parse_point(point),
                "floating_base": floating_base, "normalize": normalize, "solutions": solutions, "method": method,
                "limits": limits, "locked": parse_locked(locked)}
    if kind not in ("application/json", ""):
        raise ProblemError(415, f"Content-Type {kind!r} is not supported: send application/json or {NPY_MEDIA_TYPE}",
                           slug="unsupported-media-type")
    if not body:
        raise ProblemError(422, 'the body is empty: send {"target": ...}', slug="validation-error", field="target")
    req = await parse_body(request, IKRequest, body)
    tolerance = req.pop("tolerance")
    return {**req, "position_tolerance": tolerance["position"], "rotation_tolerance": tolerance["rotation"]}


@router.post(
    "/models/{model_id}/ik", response_model=IKResponse,
    responses={200: {"content": {NPZ_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary", "description":
               "np.savez: q (N, dof), success (N,), position_error (N,), rotation_error (N,), iterations (N,)"}}}},
               **_ERRORS},
    openapi_extra={"requestBody": {"required": True, "content": {
        "application/json": {"schema": {"$ref": "#/components/schemas/IKRequest"}, "examples": IK_EXAMPLES},
        NPY_MEDIA_TYPE: {"schema": {"type": "string", "format": "binary",
                                    "description": "np.save of float64 targets (N, 4, 4); options as query parameters"}},
    }}},
)
async def inverse_kinematics(model_id: ModelId, options: Annotated[dict, Depends(read_ik_request)], request: Request,
                             registry: RegistryDep, settings: SettingsDep):
    """Joint values that put `link` at `target` (`T_world_link`): one pose or a list of poses.

    Damped least squares on the service's own Jacobians, inside the joint limits, from `seed`
    (default the middle of the limits), then up to `restarts` random restarts. `success` is true
    only when FK of `q` is within `tolerance` of the target **and** `q` is inside the limits; an
    unreachable target answers 200 with the best `q` found and `success: false`. Work
    (targets x (restarts + 1) x max_iterations) is bounded by the `max_ik_work` setting (413).
    With `point` ([x, y, z] in the link frame) or `tool` (a pose `T_link_tool`) the targets are
    poses of that frame (a TCP without a URDF edit).
    """
    steps = (options["restarts"] + 1) * options["max_iterations"]
    if pose_count(options["target"]) <= INLINE_MAX_TARGETS and steps <= INLINE_MAX_STEPS:
        return _solve(model_id, options, request, registry, settings)
    return await run_heavy(request, _solve, model_id, options, request, registry, settings)


def parse_locked(values: list[str] | None) -> dict[str, float] | None:
    """``locked=joint:value`` query parameters as a map (a malformed one is a 422 naming it)."""
    if not values:
        return None
    out: dict[str, float] = {}
    for item in values:
        name, sep, value = item.rpartition(":")
        try:
            if not sep or not name:
                raise ValueError
            out[name] = float(value)
        except ValueError:
            raise ProblemError(422, f"locked: {item!r} is not joint:value", slug="validation-error",
                               field="locked") from None
    return out


def _solve(model_id: str, options: dict[str, Any], request: Request, registry, settings: Settings):
    rec = registry.get(model_id)
    budget = api.Budget(max_batch=settings.max_batch, max_verify=settings.max_verify,
                        max_ik_work=settings.max_ik_work)
    answer = api.ik(rec.model, budget=budget, **options)
    if isinstance(answer, api.IKAllAnswer):
        return _all_answer(rec.id, answer, request)
    sol = answer.solution
    record_ik(sol.success, sol.iterations)
    if NPZ_MEDIA_TYPE in request.headers.get("accept", "").lower():
        names = names_header(answer.model.joint_names)
        headers = {"X-Link": answer.link, **({"X-Joint-Names": names} if names is not None else
                                              {"X-Joint-Names-Omitted": "too long for a header; see GET /models/{id}"})}
        return NpzResponse({"q": sol.q, "success": sol.success, "position_error": sol.position_error,
                            "rotation_error": sol.rotation_error, "iterations": sol.iterations}, headers=headers)

    def one(values):
        return values if answer.is_batch else values[0]

    verification = None
    if answer.verification is not None:
        v = answer.verification
        verification = {"reference": v["reference"], "position_error": one(v["position_error"]),
                        "rotation_error": one(v["rotation_error"])}
    return FastJSONResponse({
        "model": rec.id, "link": answer.link, "mode": answer.mode, "joint_names": list(answer.model.joint_names),
        "q": one(sol.q), "success": one(sol.success.tolist()), "position_error": one(sol.position_error),
        "rotation_error": one(sol.rotation_error), "iterations": one(sol.iterations.tolist()),
        "verification": verification,
    })


def _all_answer(model_id: str, answer: "api.IKAllAnswer", request: Request):
    """Every solution: JSON records per target, or ``.npz`` arrays padded with NaN."""
    if NPZ_MEDIA_TYPE in request.headers.get("accept", "").lower():
        names = names_header(answer.model.joint_names)
        headers = {"X-Link": answer.link, "X-Family": answer.family, "X-Method": answer.method,
                   **({"X-Joint-Names": names} if names is not None else
                      {"X-Joint-Names-Omitted": "too long for a header; see GET /models/{id}"})}
        return NpzResponse({"q": answer.q, "count": answer.count, "within_limits": answer.within_limits,
                            "singular": answer.singular, "position_error": answer.position_error,
                            "rotation_error": answer.rotation_error}, headers=headers)
    per_target = [answer.solutions(n) for n in range(len(answer.count))]
    return FastJSONResponse({
        "model": model_id, "link": answer.link, "joint_names": list(answer.model.joint_names),
        "method": answer.method, "family": answer.family, "locked": answer.locked,
        "count": answer.count.tolist() if answer.is_batch else int(answer.count[0]),
        "solutions": per_target if answer.is_batch else per_target[0],
        "verification": answer.verification,
    })
