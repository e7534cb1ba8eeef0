"""The route adapter: what every operation's route does the same way, written once.

A route of an operation on a model is three calls: read the request, run the use case inline or
as heavy work, shape the answer.

- :func:`read_request`: the body as an instance of the operation's request schema (a subclass of
  :class:`app.schemas.QueryRequest`), whether it came as JSON (validated by the schema; a large
  body decoded off the event loop, :func:`app.heavy.parse_body`) or as a NumPy ``.npy`` body with
  the other options as query parameters (``npy``: the route's reader of the array and its query);
  other content types answer 415, an empty body 422. A batch over ``max_batch`` is refused before
  the library reads it.
- :func:`budget`: the caller's :class:`kinematics.Budget`, from the settings (the same for every
  operation).
- :func:`execute`: the handler on the event loop when the request is small (``inline``), else on
  the heavy pool under the time budget, stopped when the client goes away (:func:`app.heavy.run_heavy`).
- :class:`PlainJSONRoute`: a route class whose endpoints may carry a ``plain_json`` handler for
  their most common request (a JSON body, no query string), answered without FastAPI's resolution
  of dependencies and query parameters (``/fk``, ``/jacobian``: most of one configuration's time).
- :func:`error_responses`: the OpenAPI table of problem answers, with the operation's own wording.
- Answer helpers: :func:`one_or_all` (batch unwrapping), :func:`names_headers`,
  :func:`verification_headers`, :func:`request_body_doc`, :func:`npy_response_doc`, and the query
  parameters of ``.npy`` bodies (:data:`PointQuery`, :func:`split_names`, ...).
"""

from __future__ import annotations

import re
from typing import Annotated, Any, Awaitable, Callable, Literal

import numpy as np
from fastapi import Query, Request, Response
from fastapi.routing import APIRoute
from pydantic import StringConstraints

from kinematics.usecases import Budget

from .deps import media_type, read_body
from .errors import ProblemError
from .heavy import parse_body, run_heavy
from .npy import names_header
from .registry import MODEL_ID_PATTERN
from .responses import NPY_MEDIA_TYPE
from .schemas import Problem
from .schemas.common import checked, one_or_all  # noqa: F401 (the routes take them from here)
from .settings import Settings

#: Requests of at most this many configurations are answered on the event loop: their work
#: takes microseconds, and handing them to the thread pool costs a thread wake-up
#: (bench/RESULTS.md has the figures). Larger ones run as heavy work, so the loop keeps serving.
INLINE_MAX_CONFIGURATIONS = 8

#: the problem answers of an operation on a model, by status (a route words some its own way)
ERRORS = {
    400: "malformed body",
    404: "unknown model or link",
    413: "body, batch or result over the configured limit",
    415: "unsupported content type",
    422: "invalid joint values, limits refused, or invalid options",
    503: "over the time budget KIN_REQUEST_TIMEOUT (time-budget-exceeded)",
}


def error_responses(descriptions: dict[int, str] | None = None, statuses=tuple(ERRORS)) -> dict[int, dict]:
    """The ``responses`` of a route: ``statuses`` (default all of :data:`ERRORS`) answered with a
    :class:`~app.schemas.Problem`, described by ``descriptions`` where given, else by :data:`ERRORS`."""
    descriptions = descriptions or {}
    wanted = sorted(set(statuses) | set(descriptions))
    return {s: {"model": Problem, "description": descriptions.get(s, ERRORS.get(s, ""))} for s in wanted}


def budget(settings: Settings) -> Budget:
    """The :class:`kinematics.Budget` of every request, from the service's settings."""
    return Budget(max_batch=settings.max_batch, max_verify=settings.max_verify,
                  max_result_values=settings.max_result_values, max_ik_work=settings.max_ik_work,
                  max_workspace_samples=settings.max_workspace_samples, max_ik_solutions=settings.max_ik_solutions,
                  max_measurements=settings.max_measurements)


def configurations(q: Any) -> int:
    """How many configurations a request's q holds (before validation; 1 for a vector or a map)."""
    if isinstance(q, np.ndarray):
        return int(q.shape[0]) if q.ndim == 2 else 1
    if isinstance(q, list) and q and isinstance(q[0], (list, dict)):
        return len(q)
    return 1


async def read_request(request: Request, settings: Settings, schema, *, npy: Callable[[bytes], dict] | None = None,
                       empty: tuple[str, str] | None = None, batch: str | None = "q"):
    """The request as an instance of ``schema`` (its fields as the library reads them: poses as dicts,
    batches possibly as float arrays).

    ``npy(body)``: the fields of an ``application/x-npy`` body (the route decodes the array and adds
    its query parameters); None: JSON only. ``empty``: ``(example, field)`` of the 422 answered to an
    empty body; None: an empty body is ``{}``. ``batch``: the field whose size ``max_batch`` bounds
    before the library reads it (None: no such field)."""
    body = await read_body(request, settings.max_request_bytes, "request body")
    kind = media_type(request)
    if npy is not None and kind == NPY_MEDIA_TYPE:
        return schema.model_construct(**npy(body))
    if kind not in ("application/json", ""):
        accepted = "application/json" + (f" or {NPY_MEDIA_TYPE}" if npy is not None else "")
        raise ProblemError(415, f"Content-Type {kind!r} is not supported: send {accepted}",
                           slug="unsupported-media-type")
    if not body:
        if empty is not None:
            example, field = empty
            raise ProblemError(422, f"the body is empty: send {example}", slug="validation-error", field=field)
        body = b"{}"
    fields = await parse_body(request, schema, body)
    if batch is not None:
        budget(settings).check_batch(configurations(fields[batch]))
    return schema.model_construct(**fields)


async def execute(request: Request, handler: Callable, *args: Any, inline: bool = False) -> Any:
    """``handler(*args)``: on the event loop when ``inline`` (a small request), else as heavy work
    (:func:`app.heavy.run_heavy`: off the loop, under the time budget, stopped with its client)."""
    if inline:
        return handler(*args)
    return await run_heavy(request, handler, *args)


_MODEL_ID = re.compile(MODEL_ID_PATTERN)


def plain_json(handler: Callable[[Request, str], Awaitable[Response]]):
    """Decorator of an endpoint of a :class:`PlainJSONRoute`: ``handler(request, model_id)``
    answers the endpoint's plain JSON requests (see there) as the endpoint would."""
    def mark(endpoint):
        endpoint.plain_json = handler
        return endpoint
    return mark


class PlainJSONRoute(APIRoute):
    """An ``APIRoute`` with a short way for the request most clients send: a JSON (or empty) body,
    no query string, reads without an API key, a well-formed ``model_id``. Such a request goes
    straight to the endpoint's ``plain_json`` handler (:func:`plain_json`), which reads and answers
    it as the endpoint does; every query parameter then has its default, so FastAPI's resolution
    of the dependencies and the query parameters (~0.2 ms of one configuration's ~0.3 ms of work
    in the service) would only confirm it. Every other request (``.npy`` bodies, query parameters,
    other content types, a bad id) takes the route's usual way, and so gets the usual answers and
    problems. Endpoints without ``plain_json`` are plain ``APIRoute`` endpoints."""

    def get_route_handler(self) -> Callable[[Request], Awaitable[Response]]:
        usual = super().get_route_handler()
        handler = getattr(self.endpoint, "plain_json", None)
        if handler is None:
            return usual

        async def route(request: Request) -> Response:
            model_id = request.path_params.get("model_id", "")
            if (not request.scope.get("query_string") and media_type(request) in ("application/json", "")
                    and not request.app.state.settings.api_key_for_reads and _MODEL_ID.fullmatch(model_id)):
                return await handler(request, model_id)
            return await usual(request)

        return route


def names_headers(links: list[str], joint_names) -> dict[str, str]:
    """``X-Links`` and ``X-Joint-Names`` of an ``.npy`` answer (``...-Omitted`` when too long for a header)."""
    headers = {}
    for key, names in (("X-Links", links), ("X-Joint-Names", joint_names)):
        value = names_header(names)
        if value is None:
            headers[key + "-Omitted"] = "too long for a header; see GET /models/{id}"
        else:
            headers[key] = value
    return headers


def verification_headers(verification) -> dict[str, str]:
    """The ``.npy`` answer's headers of a :class:`kinematics.Verification` (none without one):
    ``X-Verification-Reference`` and one ``X-Max-...-Error`` per deviation it holds."""
    if not verification:
        return {}
    headers = {"X-Verification-Reference": verification.reference}
    for name, value in verification.as_dict().items():
        if name != "reference":
            headers["X-" + "-".join(part.capitalize() for part in name.split("_"))] = repr(value)
    return headers


def request_body_doc(schema: str, examples: dict, npy_description: str | None = None, required: bool = True) -> dict:
    """``openapi_extra`` of a route reading its body itself: the JSON ``schema`` with ``examples`` and,
    with ``npy_description``, the ``application/x-npy`` form (options as query parameters)."""
    content = {"application/json": {"schema": {"$ref": f"#/components/schemas/{schema}"}, "examples": examples}}
    if npy_description is not None:
        content[NPY_MEDIA_TYPE] = {"schema": {"type": "string", "format": "binary", "description": npy_description}}
    return {"requestBody": {"required": required, "content": content}}


def npy_response_doc(description: str, media: str = NPY_MEDIA_TYPE) -> dict:
    """The 200 answer's binary form (``.npy`` or ``.npz``) in OpenAPI."""
    return {"content": {media: {"schema": {"type": "string", "format": "binary", "description": description}}}}


# ---------------------------------------------------------------------- query parameters of .npy bodies
def parse_point(value: str | None) -> list[float] | None:
    """A ``point`` query parameter ``x,y,z`` (metres, the link frame) as three numbers."""
    if value is None:
        return None
    try:
        point = [float(v) for v in value.split(",")]
    except ValueError:
        point = []
    if len(point) != 3:
        raise ProblemError(422, f"point: {value!r}; give three comma-separated numbers x,y,z (metres, link frame)",
                           slug="validation-error", field="point")
    return point


def split_names(values: list[str] | None):
    """Repeated or comma-separated names of a query parameter (``["all"]``: ``"all"``)."""
    if values is None:
        return None
    names = [n.strip() for v in values for n in v.split(",") if n.strip()]
    return "all" if names == ["all"] else names


_NUMBER = r"\s*[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?\s*"
#: three comma-separated numbers (what :func:`parse_point` reads), declared so the OpenAPI document says it
POINT_PATTERN = rf"^{_NUMBER},{_NUMBER},{_NUMBER}$"
PointQuery = Annotated[str | None, Query(description=".npy bodies: a point x,y,z in the link frame (metres)",
                                         pattern=POINT_PATTERN)]
FloatingBaseQuery = Annotated[bool, Query(description=".npy bodies: the model on a free-flyer root joint")]
NormalizeQuery = Annotated[bool, Query(description=".npy bodies: scale quaternions and planar (cos, sin) to unit norm")]
VerifyQuery = Annotated[bool, Query(description=".npy bodies: compare with Pinocchio")]
LinksQuery = Annotated[list[str] | None, Query(description=".npy bodies: link names (repeat or comma-separate), or `all`")]
LinkQuery = Annotated[str | None, Query(description=".npy bodies: the link (default: the first leaf link)")]
#: one ``locked=joint:value`` query parameter (a number after the colon), repeated for several joints
LockedItem = Annotated[str, StringConstraints(pattern=r"^[^:]+:\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*$")]
LockedQuery = Annotated[list[LockedItem] | None, Query(description="joints held at values: joint:value, repeated")]
LimitsQuery = Annotated[Literal["report", "refuse"], Query(description=".npy bodies: out-of-limit policy")]
