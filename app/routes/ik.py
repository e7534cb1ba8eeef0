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

``avoid_collisions`` (``avoid_collisions=true`` for ``.npy`` bodies): only answers free of
self-collision, checked on the allowed-collision matrix kept in the data directory (as
``/collision``); the ``.npz`` answers add ``collision_free`` (N,) (one) or ``colliding`` (N,)
(all: solutions left out).
"""

from __future__ import annotations

from typing import Annotated, Literal, Union

from fastapi import APIRouter, Depends, Query, Request

from kinematics import usecases
from kinematics.io.poses import pose_count
from kinematics.usecases.ik_all import parse_locked as read_locked
from kinematics.usecases.ik_options import DEFAULT_SETTINGS, CollisionAvoidance

from ..adapter import (FloatingBaseQuery, LinkQuery, LockedQuery, NormalizeQuery, PointQuery, budget, error_responses,
                       execute, names_headers, npy_response_doc, parse_point, read_request, request_body_doc)
from ..deps import ModelId, RegistryDep, SettingsDep, require_read_key, wants_npz
from ..errors import ProblemError
from ..metrics import record_ik
from ..npy import decode_targets
from ..responses import NPZ_MEDIA_TYPE, FastJSONResponse, NpzResponse
from .collision import cache_dir as collision_cache_dir
from .collision import user_pairs
from ..schemas import IK_EXAMPLES, IKAllResponse, IKRequest, IKResponse
from ..settings import Settings

router = APIRouter(tags=["kinematics"], dependencies=[Depends(require_read_key)])

#: IK of at most this many targets runs on the event loop (microseconds to a millisecond each);
#: larger batches run in the thread pool so the loop keeps serving
INLINE_MAX_TARGETS = 1
#: ... and of at most this many steps, (restarts + 1) x max_iterations (the defaults: 5,100, a few
#: milliseconds at worst); one target with more may take seconds, so it runs as heavy work
INLINE_MAX_STEPS = (DEFAULT_SETTINGS.restarts + 1) * DEFAULT_SETTINGS.max_iterations


async def read_ik_request(
    request: Request, settings: SettingsDep, link: LinkQuery = None,
    mode: Annotated[Literal["pose", "position"], Query(description=".npy bodies: pose or position")] = "pose",
    position_tolerance: Annotated[float, Query(ge=1e-12, description=".npy bodies: metres")] =
    DEFAULT_SETTINGS.position_tolerance,
    rotation_tolerance: Annotated[float, Query(ge=1e-12, description=".npy bodies: radians")] =
    DEFAULT_SETTINGS.rotation_tolerance,
    max_iterations: Annotated[int, Query(ge=1, le=10_000, description=".npy bodies: steps per attempt")] =
    DEFAULT_SETTINGS.max_iterations,
    restarts: Annotated[int, Query(ge=0, le=10_000, description=".npy bodies: random restarts")] =
    DEFAULT_SETTINGS.restarts,
    random_seed: Annotated[int, Query(ge=0, le=2**63 - 1, description=".npy bodies: restarts' draws")] =
    DEFAULT_SETTINGS.random_seed,
    verify: Annotated[bool, Query(description=".npy bodies: Pinocchio's FK of every answer")] = False,
    point: PointQuery = None, floating_base: FloatingBaseQuery = False, normalize: NormalizeQuery = False,
    solutions: Annotated[Literal["one", "all"], Query(description=".npy bodies: one or all")] = "one",
    method: Annotated[Literal["auto", "analytic", "numeric"], Query(description=".npy bodies: the method")] = "auto",
    limits: Annotated[Literal["respect", "ignore"], Query(description=".npy bodies: with solutions all")] = "respect",
    locked: LockedQuery = None,
    avoid_collisions: Annotated[bool, Query(description=".npy bodies: answers free of self-collision only")] = False,
) -> IKRequest:
    def npy(body: bytes) -> dict:
        return {"target": decode_targets(body), "link": link, "mode": mode, "max_iterations": max_iterations,
                "tolerance": {"position": position_tolerance, "rotation": rotation_tolerance}, "restarts": restarts,
                "random_seed": random_seed, "verify": verify, "point": parse_point(point),
                "floating_base": floating_base, "normalize": normalize, "solutions": solutions, "method": method,
                "limits": limits, "locked": parse_locked(locked), "avoid_collisions": avoid_collisions}

    return await read_request(request, settings, IKRequest, npy=npy, empty=('{"target": ...}', "target"), batch=None)


@router.post(
    "/models/{model_id}/ik", response_model=Union[IKResponse, IKAllResponse],
    responses={200: npy_response_doc("np.savez: q (N, dof), success (N,), position_error (N,), rotation_error (N,), "
                                     "iterations (N,)", NPZ_MEDIA_TYPE),
               **error_responses({413: "body, targets or IK work (targets x attempts x iterations) over a limit",
                                  422: "invalid target, seed or options"})},
    openapi_extra=request_body_doc("IKRequest", IK_EXAMPLES, "np.save of float64 targets (N, 4, 4); options as "
                                                             "query parameters"),
)
async def inverse_kinematics(model_id: ModelId, req: Annotated[IKRequest, Depends(read_ik_request)], request: Request,
                             registry: RegistryDep, settings: SettingsDep):
    """Joint values that put `link` at `target` (`T_world_link`): one pose or a list of poses.

    Damped least squares on the service's own Jacobians, inside the joint limits, from `seed`
    (default the middle of the limits), then up to `restarts` random restarts. `success` is true
    only when FK of `q` is within `tolerance` of the target **and** `q` is inside the limits; an
    unreachable target answers 200 with the best `q` found and `success: false`. Work
    (targets x (restarts + 1) x max_iterations) is bounded by the `max_ik_work` setting (413).
    With `point` ([x, y, z] in the link frame) or `tool` (a pose `T_link_tool`) the targets are
    poses of that frame (a TCP without a URDF edit). With `avoid_collisions` only answers free of
    self-collision: `solutions: "all"` leaves the colliding ones out (`colliding` counts them),
    `"one"` searches on and claims `success` only for a free answer (`collision_free`); a model
    without collision geometry is a 422.
    """
    steps = (req.restarts + 1) * req.max_iterations
    # collision checks (and a first request's allowed-collision matrix) run as heavy work
    return await execute(request, _solve, model_id, req, request, registry, settings,
                         inline=pose_count(req.target) <= INLINE_MAX_TARGETS and steps <= INLINE_MAX_STEPS
                         and not req.avoid_collisions)


def parse_locked(values: list[str] | None) -> dict[str, float] | None:
    """``locked=joint:value`` query parameters as a map (a malformed one is a 422 naming the field)."""
    try:
        return read_locked(values) or None
    except ValueError as exc:
        raise ProblemError(422, f"locked: {exc}", slug="validation-error", field="locked") from None


def collision_avoidance(registry, settings: Settings) -> CollisionAvoidance:
    """The service's :class:`~kinematics.usecases.ik_options.CollisionAvoidance`: its allowed-collision
    matrices of ``collision_samples`` configurations, kept in the data directory (as ``/collision``)."""
    return CollisionAvoidance(settings.collision_samples, collision_cache_dir(registry))


def _npz_headers(answer, **extra: str) -> dict[str, str]:
    """The headers of an ``.npz`` answer: ``X-Link``, ``extra``, then the joint order (``X-Joint-Names``)."""
    names = names_headers([answer.link], answer.model.joint_names)
    return {"X-Link": answer.link, **extra, **{k: v for k, v in names.items() if "Joint-Names" in k}}


def _solve(model_id: str, req: IKRequest, request: Request, registry, settings: Settings):
    rec = registry.get(model_id)
    pairs = user_pairs(registry, rec.id, req) if req.avoid_collisions else None
    answer = usecases.ik(req.to_query(rec.model, budget(settings), collision_pairs=pairs), req.target, seed=req.seed,
                         options=req.ik_options(collision_avoidance(registry, settings)))
    if isinstance(answer, usecases.IKAllAnswer):
        if wants_npz(request):
            return NpzResponse(IKAllResponse.arrays(answer), headers=_npz_headers(
                answer, **{"X-Family": answer.family, "X-Method": answer.method}))
        return FastJSONResponse(IKAllResponse.content(rec.id, answer))
    record_ik(answer.solution.success, answer.solution.iterations)
    if wants_npz(request):
        return NpzResponse(IKResponse.arrays(answer), headers=_npz_headers(answer))
    return FastJSONResponse(IKResponse.content(rec.id, answer))
