"""Every error as ``application/problem+json`` (RFC 9457), mapped in one place.

``type`` is a URN naming the kind of problem (``urn:kinematics:problem:<slug>``), ``title``
its short description, ``status`` the HTTP status, ``detail`` the message naming what is
wrong; ``field``, ``joint``, ``link`` or ``model`` are added when known. Library
exceptions (:mod:`kinematics.errors`) map to statuses by class, here and nowhere else.
"""

from __future__ import annotations

import contextvars
import functools
import logging
import re
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException

from kinematics.errors import (
    CollisionError,
    ArchiveError,
    ArchiveTooLargeError,
    ExpansionLimitError,
    MJCFError,
    XacroError,
    AxesError,
    BasePoseError,
    BudgetError,
    CalibrationError,
    CancelledError,
    ConfigurationNormError,
    DHError,
    JointValueError,
    KinematicsError,
    LimitError,
    MissingExtraError,
    LockedJointError,
    ModelTooLargeError,
    NoDHFormError,
    PoEError,
    PoseError,
    ReferenceUnavailableError,
    RepresentationSingularityError,
    SymbolicError,
    TaskError,
    TimeBudgetError,
    UnknownLinkError,
    UnknownMeshError,
    UnknownModelError,
    URDFError,
)

from .responses import ProblemResponse

log = logging.getLogger("app.errors")

PROBLEM_TYPE_PREFIX = "urn:kinematics:problem:"

#: the id of the request being answered (set by :class:`app.middleware.RequestContext`)
REQUEST_ID: contextvars.ContextVar[str | None] = contextvars.ContextVar("request_id", default=None)
#: the problem type (and detail) of the answer being sent, for the access log (reset per request)
PROBLEM: contextvars.ContextVar[tuple[str, str] | None] = contextvars.ContextVar("problem", default=None)


class RequestIdFilter(logging.Filter):
    """Adds ``request_id`` (``-`` outside a request) to every log record it sees."""

    def filter(self, record: logging.LogRecord) -> bool:
        record.request_id = REQUEST_ID.get() or "-"
        return True

#: library exception -> (status, slug, title); the first matching class wins (subclasses first)
KINEMATICS_ERRORS: tuple[tuple[type[KinematicsError], int, str, str], ...] = (
    (UnknownModelError, 404, "unknown-model", "Unknown model"),
    (UnknownLinkError, 404, "unknown-link", "Unknown link"),
    (UnknownMeshError, 404, "unknown-mesh", "Unknown visual mesh"),
    (TimeBudgetError, 503, "time-budget-exceeded", "Over the time budget"),
    (CancelledError, 499, "cancelled", "Cancelled: the client went away"),
    (BudgetError, 413, "too-large", "Content too large"),
    (ModelTooLargeError, 413, "model-too-large", "Model over the size limit"),
    (ExpansionLimitError, 413, "expansion-too-large", "xacro expansion over its limits"),
    (ArchiveTooLargeError, 413, "archive-too-large", "Archive over its size limits"),
    (XacroError, 422, "invalid-xacro", "Invalid xacro, or refused by its sandbox"),
    (ArchiveError, 422, "invalid-archive", "Invalid or hostile description archive"),
    (MJCFError, 422, "invalid-mjcf", "Invalid or unsupported MJCF"),
    (URDFError, 422, "invalid-urdf", "Invalid or unsupported URDF"),
    (DHError, 422, "invalid-dh-table", "Invalid Denavit-Hartenberg table"),
    (PoEError, 422, "invalid-poe-model", "Invalid product-of-exponentials description"),
    (AxesError, 422, "invalid-axes-model", "Invalid zero-configuration axes description"),
    (SymbolicError, 422, "invalid-symbolic-request", "Closed forms cannot be derived"),
    (RepresentationSingularityError, 422, "representation-singularity", "Singular task representation"),
    (TaskError, 422, "invalid-task-representation", "Invalid task representation"),
    (NoDHFormError, 422, "no-dh-form", "The model has no Denavit-Hartenberg form"),
    (ConfigurationNormError, 422, "non-unit-joint-values", "Quaternion or planar (cos, sin) not of unit norm"),
    (JointValueError, 422, "invalid-joint-values", "Invalid joint values"),
    (LimitError, 422, "joint-limits", "Joint values outside their limits"),
    (LockedJointError, 422, "invalid-locked-joint", "Invalid locked joint"),
    (BasePoseError, 422, "invalid-base-pose", "Invalid base pose"),
    (PoseError, 422, "invalid-pose", "Invalid pose"),
    (CalibrationError, 422, "invalid-calibration-data", "Measurements a calibration cannot use"),
    (ReferenceUnavailableError, 422, "reference-unavailable", "Pinocchio cannot check this model"),
    (MissingExtraError, 501, "extra-not-installed", "An optional dependency of the server is not installed"),
    (CollisionError, 422, "invalid-collision-request", "Invalid self-collision request"),
    (KinematicsError, 422, "kinematics-error", "Invalid request"),
)

_HTTP_TITLES = {
    400: "Bad request", 401: "Authentication required", 403: "Forbidden", 404: "Not found",
    405: "Method not allowed", 406: "Not acceptable", 409: "Conflict", 413: "Content too large",
    415: "Unsupported media type", 422: "Unprocessable content", 500: "Internal server error",
    501: "Not implemented",
}

_QUOTED = {
    "joint": re.compile(r"\bjoint '([^']+)'"),
    "link": re.compile(r"\blink '([^']+)'"),
}


class ProblemError(Exception):
    """An error raised by the app itself, carrying its problem-details fields."""

    def __init__(self, status: int, detail: str, *, slug: str | None = None, title: str | None = None,
                 headers: dict[str, str] | None = None, **extra: Any):
        super().__init__(detail)
        self.status = status
        self.detail = detail
        self.slug = slug or _HTTP_TITLES.get(status, "error").lower().replace(" ", "-")
        self.title = title or _HTTP_TITLES.get(status, "Error")
        self.headers = headers
        self.extra = {k: v for k, v in extra.items() if v is not None}


def problem(status: int, title: str, detail: str, slug: str, headers: dict[str, str] | None = None,
            **extra: Any) -> ProblemResponse:
    body = {"type": PROBLEM_TYPE_PREFIX + slug, "title": title, "status": status, "detail": detail}
    body.update({k: v for k, v in extra.items() if v is not None})
    request_id = REQUEST_ID.get()
    if request_id is not None:
        body["request_id"] = request_id
    PROBLEM.set((body["type"], detail))
    return ProblemResponse(body, status_code=status, headers=headers)


def names_in(message: str) -> dict[str, str]:
    """The first quoted joint / link name in a library message, by kind."""
    out = {}
    for kind, pattern in _QUOTED.items():
        m = pattern.search(message)
        if m:
            out[kind] = m.group(1)
    return out


def kinematics_problem(exc: KinematicsError, model_id: str | None = None) -> ProblemResponse:
    """The problem of a library exception; ``model`` is the model id of the request path, if any."""
    for cls, status, slug, title in KINEMATICS_ERRORS:
        if isinstance(exc, cls):
            break
    detail = str(exc)
    if isinstance(exc, BudgetError):  # which budget: batch-too-large, verify-too-large, result-too-large
        return problem(status, title, detail, f"{exc.budget}-{slug}", field=exc.field, limit=exc.limit)
    if isinstance(exc, TimeBudgetError):  # a time budget (closed forms' too): the setting and its limit in seconds
        status = 422 if exc.setting == "timeout" else status  # the request's own time limit: the client's choice
        return problem(status, title, detail, slug, model=model_id, setting=exc.setting, limit=exc.limit)
    if isinstance(exc, LockedJointError):
        return problem(status, title, detail, slug, model=model_id, field="locked", joint=exc.joint)
    return problem(status, title, detail, slug, model=model_id, **names_in(detail))


_SOURCES = ("body", "query", "path", "header")
#: the labels pydantic gives a union's scalar members in an error's location
_SCALAR_LABELS = frozenset({"str", "int", "float", "bool", "none"})


def _schema_names() -> set[str]:
    """The class names of every pydantic model (a union's model members are labelled by them)."""
    from pydantic import BaseModel

    names, todo = set(), [BaseModel]
    while todo:
        for sub in todo.pop().__subclasses__():
            if sub.__name__ not in names:
                names.add(sub.__name__)
                todo.append(sub)
    return names


def _is_label(part: Any) -> bool:
    """Whether a location part is a union member's label ("list[float]", "BasePositionQuaternion"), not a field."""
    return isinstance(part, str) and _is_label_name(part)


@functools.lru_cache(maxsize=1024)  # a batch's errors repeat the same few names; the models are all defined
def _is_label_name(part: str) -> bool:
    return "[" in part or part in _SCALAR_LABELS or part in _schema_names()


def _field(loc: tuple) -> str:
    """The field an error is about, as a client writes it: no source, no union labels (internal class names)."""
    return ".".join(str(p) for p in loc if p not in _SOURCES and not _is_label(p))


def _union(loc: tuple) -> tuple[tuple, str] | None:
    """(the union's location, the member's label) of an error inside a union member, else None."""
    for i, part in enumerate(loc):
        if _is_label(part):
            return tuple(loc[:i]), str(part)
    return None


#: errors that say the input has another shape than the member (not a wrong value inside it)
_SHAPE_ERRORS = frozenset({"missing", "extra_forbidden", "model_type", "model_attributes_type", "list_type",
                           "dict_type", "tuple_type"})


def _best_members(errors: list[dict]) -> dict[tuple, str]:
    """Per union, the member the input most nearly is: fewest shape mismatches at its top, then
    fewest errors, then the deepest (the member whose fields matched before something went wrong).
    ``{"position": .., "quaternion": [0, 0, 1]}`` is a position-quaternion pose with a short
    quaternion, not an xyz-rpy pose missing ``xyz``."""
    scores: dict[tuple, dict[str, list]] = {}
    for e in errors:
        union = _union(tuple(e.get("loc", ())))
        if union is None:
            continue
        where, label = union
        depth = len(e.get("loc", ())) - len(where) - 1
        score = scores.setdefault(where, {}).setdefault(label, [0, 0, 0])
        score[0] += e.get("type") in _SHAPE_ERRORS and depth <= 1
        score[1] += 1
        score[2] = min(score[2], -depth)
    return {where: min(members, key=lambda label: tuple(members[label])) for where, members in scores.items()}


def _fields_of(annotation: Any) -> list:
    """The pydantic models an annotation holds (through unions, lists and dicts)."""
    from typing import get_args

    from pydantic import BaseModel

    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in get_args(annotation) for m in _fields_of(arg)]


def _known_fields(schema: Any, loc: tuple) -> list[str]:
    """The field names of the object holding the extra key at ``loc`` in ``schema`` (a model), [] if unknown."""
    models = _fields_of(schema)
    for part in [p for p in loc if p not in _SOURCES][:-1]:
        if isinstance(part, int):
            continue
        named = [m for m in models if m.__name__ == part]
        if named or _is_label(part):
            models = named or models
            continue
        models = [m for model in models if part in model.model_fields
                  for m in _fields_of(model.model_fields[part].annotation)]
    return sorted({name for model in models for name in model.model_fields})


def _unknown_field(error: dict, schema: Any) -> str:
    """An extra key's message: the field meant (difflib's closest of the object's fields) or the fields there are."""
    import difflib

    loc = tuple(error.get("loc", ()))
    name = str(loc[-1]) if loc else ""
    fields = _known_fields(schema, loc) if schema is not None else []
    close = difflib.get_close_matches(name, fields, n=1, cutoff=0.6)
    if close:
        return f"unknown field {name!r}; did you mean {close[0]!r}?"
    if fields:
        return f"unknown field {name!r}; the fields are {', '.join(fields)}"
    return error.get("msg", "")


#: list-of-names fields that also take the string "all" (a bare name is the usual mistake)
_NAME_LIST_FIELDS = ("links",)


def _json_str(s: str) -> str:
    import json

    return json.dumps(s[:200])


def _names_given_as_string(errors: list[dict]) -> tuple[str, str] | None:
    """(field, the string) when a names-or-"all" field got a string other than "all"."""
    for e in errors:
        loc = tuple(e.get("loc", ()))
        field = _field(loc)
        if field in _NAME_LIST_FIELDS and isinstance(e.get("input"), str):
            return field, e["input"]
    return None


#: what a query parameter's pattern means, said instead of the regular expression
_PATTERN_HINTS = {
    "arg": "is not name:value (a xacro argument: a name, then ':' or '=', then the value)",
    "point": "is not three comma-separated numbers x,y,z (metres, link frame)",
    "locked": "is not joint:value (a joint name, ':', then its value: radians or metres)",
}


def _message(error: dict, field: str, schema: Any = None) -> str:
    hint = _PATTERN_HINTS.get(field.split(".", 1)[0])
    if hint is not None and error.get("type") == "string_pattern_mismatch":
        return f"{str(error.get('input'))[:100]!r} {hint}"
    if error.get("type") == "extra_forbidden":
        return _unknown_field(error, schema)
    if error.get("type") == "value_error":  # a schema's own check: its message, without pydantic's prefix
        return str(error.get("msg", "")).removeprefix("Value error, ")
    if error.get("type") == "model_type" and schema is not None:  # say which object: its fields
        fields = _known_fields(schema, (*error.get("loc", ()), ""))
        if fields:
            given = type(error.get("input")).__name__.replace("dict", "object")
            return f"should be an object with the fields {', '.join(fields)}, got a {given}"
    if error.get("type") == "finite_number":  # NaN / Infinity: named, not compared with a range
        return f"{error.get('msg', '')}, not {_NON_FINITE.get(str(error.get('input')), error.get('input'))}"
    return error.get("msg", "")


#: how JSON (and Python's json module) spells the non-finite numbers pydantic refuses
_NON_FINITE = {"nan": "NaN", "inf": "Infinity", "-inf": "-Infinity"}


def validation_problem(errors: list[dict], schema: Any = None) -> ProblemResponse:
    """422 for pydantic errors: ``field`` names the first offending field, ``errors`` lists the rest.

    For a union (q, a pose), only the errors of the member the input most nearly is are kept
    (:func:`_best_members`): "q.5: not a number" says more than "q: not an object" and its other
    alternatives. ``schema`` (the request's model, when known) names the field an unknown key was
    probably meant to be.
    """
    if not errors:
        return problem(422, "Invalid request", "invalid request", "validation-error")
    best = _best_members(errors)
    seen, cleaned = set(), []
    for e in errors:
        loc = tuple(e.get("loc", ()))
        union = _union(loc)
        if union is not None and best.get(union[0]) != union[1]:
            continue
        item = {"field": _field(loc), "message": _message(e, _field(loc), schema), "type": e.get("type", "")}
        if (item["field"], item["message"]) not in seen:
            seen.add((item["field"], item["message"]))
            cleaned.append(item)
    first = cleaned[0]
    names = _names_given_as_string(errors)
    if names is not None:
        field, given = names
        detail = (f'{field} must be a list of link names or "all"; got the string {_json_str(given)}'
                  f' -- did you mean [{_json_str(given)}]?')
        return problem(422, "Invalid request", detail, "validation-error", field=field, errors=cleaned[:20])
    if first["field"] == "q" or first["field"].startswith("q."):
        detail = ("q must be a list of numbers (one configuration), a {joint_name: number} map, "
                  f"or a list of those (a batch): {first['field']}: {first['message']}")
    elif first["field"]:
        detail = f"{first['field']}: {first['message']}"
    else:  # a check of the whole request (its message names the fields)
        detail = first["message"] if first["type"] == "value_error" else f"request: {first['message']}"
    return problem(422, "Invalid request", detail, "validation-error", field=first["field"] or None,
                   errors=cleaned[:20])


def _flat_routes(app) -> list:
    """Every route of ``app``, the included routers' too (FastAPI >= 0.16x nests them)."""
    from fastapi import routing

    iter_contexts = getattr(routing, "iter_route_contexts", None)
    if iter_contexts is None:
        return list(app.router.routes)
    return [getattr(c, "original_route", None) or c.route for c in iter_contexts(app.router.routes)]


def allowed_methods(request: Request) -> list[str]:
    """The methods of the request's path, for the ``Allow`` header of a 405: those of every route
    of its most specific template (Starlette's own 405 names only the first route that matched)."""
    from starlette.routing import get_route_path

    path = get_route_path(request.scope)
    by_params: dict[int, set[str]] = {}
    for route in _flat_routes(request.app):
        regex, route_methods = getattr(route, "path_regex", None), getattr(route, "methods", None)
        if regex is not None and route_methods and regex.match(path):
            by_params.setdefault(str(getattr(route, "path", "")).count("{"), set()).update(route_methods)
    # the most specific templates name the resource: /models/dh is POST /models/dh, not also the
    # GET and DELETE of /models/{model_id} (which would answer "unknown model 'dh'")
    methods = by_params[min(by_params)] if by_params else set()
    order = ("GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS")
    return sorted(methods, key=lambda m: (order.index(m) if m in order else len(order), m))


def _route_body_schema(request: Request) -> Any:
    """The model of the body a FastAPI route declares (None when it reads its body itself)."""
    field = getattr(request.scope.get("route"), "body_field", None)
    return getattr(getattr(field, "field_info", None), "annotation", None)


def _schema_named(title: str) -> Any:
    """The request schema of that class name (a ValidationError's ``title``), None if not one of ours."""
    from . import schemas

    found = getattr(schemas, title, None)
    return found if isinstance(found, type) else None


def install_error_handlers(app: FastAPI) -> None:
    """Register the problem-details handlers on ``app``."""

    @app.exception_handler(ProblemError)
    async def _problem_error(request: Request, exc: ProblemError):
        return problem(exc.status, exc.title, exc.detail, exc.slug, headers=exc.headers, **exc.extra)

    @app.exception_handler(KinematicsError)
    async def _kinematics_error(request: Request, exc: KinematicsError):
        return kinematics_problem(exc, request.path_params.get("model_id"))

    @app.exception_handler(RequestValidationError)
    async def _request_validation(request: Request, exc: RequestValidationError):
        return validation_problem(list(exc.errors()), _route_body_schema(request))

    @app.exception_handler(ValidationError)
    async def _pydantic_validation(request: Request, exc: ValidationError):
        return validation_problem(exc.errors(include_url=False), _schema_named(exc.title))

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, exc: StarletteHTTPException):
        status = exc.status_code
        title = _HTTP_TITLES.get(status, "Error")
        detail = exc.detail if isinstance(exc.detail, str) else title
        if status == 404 and detail == "Not Found":
            detail = f"no route {request.url.path!r}"
        headers = getattr(exc, "headers", None)
        if status == 405:
            allowed = allowed_methods(request)
            headers = {**(headers or {}), "Allow": ", ".join(allowed)}
            if detail == "Method Not Allowed":
                detail = f"method {request.method} is not allowed on {request.url.path!r}; allowed: {', '.join(allowed)}"
        return problem(status, title, detail, title.lower().replace(" ", "-"), headers=headers)

    @app.exception_handler(Exception)
    async def _bug(request: Request, exc: Exception):
        request_id = REQUEST_ID.get()
        log.exception("unhandled error on %s %s (request %s)", request.method, request.url.path, request_id,
                      extra={"method": request.method, "path": request.url.path, "status": 500,
                             "problem": PROBLEM_TYPE_PREFIX + "internal-error"})
        # sent by Starlette's outermost middleware, past RequestContext: the header is added here
        return problem(500, "Internal server error", "an unexpected error occurred; it has been logged", "internal-error",
                       headers={"X-Request-ID": request_id} if request_id else None)
