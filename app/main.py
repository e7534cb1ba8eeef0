"""The ASGI application: ``app.main:app`` (``uvicorn app.main:app``), built by :func:`create_app`.

The registry (bundled catalogue listed, stored models loaded from the data directory) is
built in the lifespan hook, not at import. Routers are listed in :data:`ROUTERS`: each
module of ``app.routes`` named there exposes ``router``; a module that is not present is
skipped, so a feature can add its router by adding its name.
"""

from __future__ import annotations

import asyncio
import importlib
import logging
import threading
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.openapi.utils import get_openapi
from pydantic.json_schema import models_json_schema

import kinematics
from kinematics.io.catalogue import default_catalogue

from .docs import install_docs
from .errors import install_error_handlers
from .heavy import configure_process, start_decoder
from .middleware import BodySizeLimit, RequestContext
from .registry import Registry
from .responses import PROBLEM_MEDIA_TYPE, FastJSONResponse
from .schemas import REQUEST_SCHEMAS
from .settings import Settings
from .warm import prepare_routes, prepare_routes_in_background, process_warm_up

log = logging.getLogger("app")

#: modules of app.routes whose ``router`` is included, in order (missing optional ones are skipped)
ROUTERS = ("health", "metrics", "models", "kinematics", "ik", "ik_all", "velocity", "workspace", "symbolic",
           "calibration", "collision", "visual", "viewer", "trajectory")
OPTIONAL_ROUTERS = frozenset({"viewer"})
DESCRIPTION = """Forward kinematics, Jacobians and inverse kinematics of robots (URDF or Denavit-Hartenberg),
computed with product-of-exponentials and cross-checked against Pinocchio on request (`verify: true`).

Units are metres and radians. Poses are `T_world_link`; Jacobians are 6 x dof with the
linear rows first. Batch FK and Jacobians also speak NumPy `.npy`
(`Content-Type` / `Accept: application/x-npy`); IK takes `.npy` targets (N, 4, 4) and answers
`.npz` (`Accept: application/x-npz`). Errors are `application/problem+json`."""


#: routers matched first (a request is matched against the routes in the order they were included,
#: ~2 µs a route: a single FK request went through 13 routes before its own): the light requests
#: clients send most. The OpenAPI document lists the routes in :data:`ROUTERS` order all the same.
MATCHED_FIRST = ("health", "kinematics")


def _include_routers(app: FastAPI) -> None:
    names = [n for n in MATCHED_FIRST if n in ROUTERS] + [n for n in ROUTERS if n not in MATCHED_FIRST]
    app.state.router_rank = {}
    for name in names:
        try:
            module = importlib.import_module(f"app.routes.{name}")
        except ModuleNotFoundError as exc:
            if name in OPTIONAL_ROUTERS and exc.name == f"app.routes.{name}":
                continue
            raise
        app.include_router(module.router)
        app.state.router_rank[id(module.router)] = ROUTERS.index(name)


def _documented_order(app: FastAPI) -> list:
    """``app.routes`` with the included routers in :data:`ROUTERS` order (they are matched in another,
    :data:`MATCHED_FIRST`); routes added before the routers stay first, those added after last."""
    rank = app.state.router_rank
    routes = list(app.routes)
    first = next((i for i, r in enumerate(routes) if id(getattr(r, "original_router", r)) in rank), len(routes))

    def key(item):
        i, route = item
        r = rank.get(id(getattr(route, "original_router", route)))
        return (1, r, 0) if r is not None else ((0, 0, i) if i < first else (2, 0, i))

    return [route for _, route in sorted(enumerate(routes), key=key)]


def _document_problems(schema: dict) -> None:
    """Every 4xx/5xx answer is ``application/problem+json`` with the ``Problem`` schema (what the
    error handlers send), including FastAPI's default 422 (whose HTTPValidationError is dropped)."""
    problem = {PROBLEM_MEDIA_TYPE: {"schema": {"$ref": "#/components/schemas/Problem"}}}
    for path_item in schema.get("paths", {}).values():
        for operation in path_item.values():
            responses = operation.setdefault("responses", {})
            if operation.get("security"):  # depends on the API key (writes; reads when protected)
                responses.setdefault("401", {"description": "API key required (KIN_API_KEY set; for reads, "
                                                            "KIN_API_KEY_FOR_READS=true)"})
                responses.setdefault("403", {"description": "API key not valid"})
            if "requestBody" in operation:  # the body-size middleware answers these on any body
                responses.setdefault("400", {"description": "malformed request (Content-Length not a number)"})
                responses.setdefault("413", {"description": "body over the size limit"})
            for status, response in responses.items():
                if status[:1] in ("4", "5"):
                    response["content"] = dict(problem)
                    if response.get("description") == "Validation Error":
                        response["description"] = "invalid request (the problem names the field)"
    components = schema.get("components", {}).get("schemas", {})
    for unused in ("HTTPValidationError", "ValidationError"):
        components.pop(unused, None)


def _write_operations(app: FastAPI) -> set[tuple[str, str]]:
    """(method, path) of the operations that depend on :func:`app.deps.require_write_key` (a
    route-level dependency; every other operation that declares security needs the read key)."""
    from fastapi import routing

    from .deps import require_write_key

    iter_contexts = getattr(routing, "iter_route_contexts", None)  # FastAPI >= 0.16x nests included routers
    routes = ([getattr(c, "original_route", c.route) for c in iter_contexts(app.routes)] if iter_contexts
              else list(app.routes))

    def writes(dependant) -> bool:
        return any(sub.call is require_write_key or writes(sub) for sub in dependant.dependencies)

    return {(method.lower(), route.path) for route in routes
            if isinstance(route, routing.APIRoute) and writes(route.dependant) for method in route.methods}


def _document_security(app: FastAPI, schema: dict) -> None:
    """Declare the API-key security only where the server, as configured, asks for a key: nowhere
    without ``KIN_API_KEY``; on writes with it; on reads too with ``KIN_API_KEY_FOR_READS``. An
    operation that needs no key documents no 401/403 either."""
    settings = app.state.settings
    writes = _write_operations(app)
    needs = set()
    if settings.api_key:
        needs.add("write")
        if settings.api_key_for_reads:
            needs.add("read")
    for path, path_item in schema.get("paths", {}).items():
        for method, operation in path_item.items():
            if not isinstance(operation, dict) or not operation.get("security"):
                continue
            if ("write" if (method, path) in writes else "read") in needs:
                continue
            operation.pop("security", None)
            responses = operation.get("responses", {})
            responses.pop("401", None)
            if str(responses.get("403", {}).get("description", "")).startswith("API key"):
                responses.pop("403", None)  # a 403 of another cause (a read-only model) stays
    if not needs:
        schema.get("components", {}).pop("securitySchemes", None)


#: request fields whose batch size the ``max_batch`` setting bounds: (schema, field)
BATCH_FIELDS = (("FKRequest", "q"), ("JacobianRequest", "q"), ("VelocityRequest", "q"), ("VelocityRequest", "qdot"),
                ("TaskRequest", "q"), ("IKRequest", "target"))


def _document_limits(app: FastAPI, schema: dict) -> None:
    """State the limits that come from settings in the schema, so that a schema-valid request is not
    refused for its size: ``samples`` at most ``max_workspace_samples`` (``maximum``), and the batch
    forms of q, qdot and IK targets at most ``max_batch`` items (``maxItems`` on the list-of-configurations
    and list-of-poses branches; a single vector, map or pose is one)."""
    settings = app.state.settings
    components = schema.get("components", {}).get("schemas", {})
    samples = components.get("WorkspaceRequest", {}).get("properties", {}).get("samples")
    if samples is not None:
        samples["maximum"] = settings.max_workspace_samples
    # the bounds checked before the work that no JSON-schema keyword can say, in words
    for name, field, text in (
            ("IKRequest", "solutions", f"all: at most {settings.max_ik_solutions} solutions in one request "
                                       "(KIN_MAX_IK_SOLUTIONS), counted before the work as targets x the most the "
                                       "chain can have; over it: 413 ik-solutions-too-large"),
            ("IKPathRequest", "step", f"the path's interpolated targets x the most solutions the chain can have "
                                      "(with redundancy: x the slices of the self-motion each target solves): at "
                                      f"most {settings.max_ik_solutions} (KIN_MAX_IK_SOLUTIONS; 413)")):
        prop = components.get(name, {}).get("properties", {}).get(field)
        if prop is not None:
            prop["description"] = f"{prop.get('description', '')} ({text})".strip()
    measurements = components.get("CalibrationRequest", {}).get("properties", {}).get("measurements")
    for branch in (measurements or {}).get("anyOf", []):
        branch["maxItems"] = settings.max_measurements
    for name, field in BATCH_FIELDS:
        prop = components.get(name, {}).get("properties", {}).get(field)
        for branch in (prop or {}).get("anyOf", []):
            items = branch.get("items") if branch.get("type") == "array" else None
            batch = isinstance(items, dict) and (
                items.get("type") == "object" or "anyOf" in items  # maps, or poses of any form
                or (field != "target" and items.get("type") == "array"))  # vectors (for targets: a 4x4 matrix)
            if batch:
                branch["maxItems"] = settings.max_batch


def _custom_openapi(app: FastAPI):
    """OpenAPI with the schemas of request bodies the handlers read themselves (JSON or .npy)."""

    def openapi() -> dict:
        if app.openapi_schema:
            return app.openapi_schema
        schema = get_openapi(title=app.title, version=app.version, description=app.description,
                             routes=_documented_order(app))
        _, defs = models_json_schema([(m, "validation") for m in REQUEST_SCHEMAS],
                                     ref_template="#/components/schemas/{model}")
        components = schema.setdefault("components", {}).setdefault("schemas", {})
        for name, s in defs.get("$defs", {}).items():
            components.setdefault(name, s)
        _document_security(app, schema)
        _document_limits(app, schema)
        _document_problems(schema)
        app.openapi_schema = schema
        return schema

    return openapi


def _configure_logging(level: str, fmt: str = "text") -> None:
    """Level and format (text, json: :mod:`app.logs`) of the ``app`` loggers; in text mode a stderr
    handler when nothing else (uvicorn, pytest) handles them."""
    from .logs import configure

    configure(level, fmt)


#: response headers a browser page on another origin may read (the .npy answers' metadata)
EXPOSED_HEADERS = ["Location", "X-Request-ID", "X-Links", "X-Joint-Names", "X-Link", "X-Reference", "X-Out-Of-Limits",
                   "X-Links-Omitted", "X-Joint-Names-Omitted", "X-Verification-Reference", "X-Max-Position-Error",
                   "X-Max-Rotation-Error", "X-Max-Jacobian-Error", "X-Twist-References", "X-Max-Velocity-Error", "X-Columns"]


def _report_decoder(future) -> None:
    if not future.cancelled() and future.exception() is not None:  # large bodies are then decoded in the worker (app.heavy)
        log.warning("the decoder process did not start (%s): large bodies are decoded in the worker", future.exception())


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the service. ``settings`` default to the environment (``KIN_*``)."""
    settings = settings if settings is not None else Settings()
    _configure_logging(settings.log_level, settings.log_format)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        data_dir = settings.resolved_data_dir()
        decoder = start_decoder(settings)  # the large-body decoder process starts while the rest warms up
        background = settings.warm_up == "background"
        warm_up = process_warm_up()  # every operation's compiled kernels, not on a first request (app.warm)
        warm_up.start(background=background)
        if background:  # the routes' own state too (app.warm.prepare_routes), beside the kernels
            threading.Thread(target=prepare_routes_in_background, args=(app,), name="prepare-routes", daemon=True).start()
        else:
            prepare_routes(app)
        configure_process(settings)  # heavy work off the loop at a lower priority (app.heavy)
        registry = Registry(default_catalogue(), data_dir, max_links=settings.max_links)
        loaded = registry.load_stored()
        app.state.registry = registry
        log.info("registry: %d bundled models, %d stored models in %s", len(registry.catalogue.ids()), loaded, data_dir)
        if decoder is not None:
            decoder.add_done_callback(_report_decoder)
            if not background:  # else it gets ready while the worker answers (a large body meanwhile waits for it)
                await asyncio.wait([asyncio.wrap_future(decoder)])
        yield
        warm_up.stop()

    app = FastAPI(
        title="Kinematics service", version=kinematics.__version__, description=DESCRIPTION,
        lifespan=lifespan, default_response_class=FastJSONResponse, docs_url=None, redoc_url=None,
    )
    app.state.settings = settings
    install_error_handlers(app)
    _include_routers(app)
    install_docs(app)
    app.openapi = _custom_openapi(app)
    if settings.cors_origins:
        app.add_middleware(CORSMiddleware, allow_origins=settings.cors_origins, allow_methods=["*"],
                           allow_headers=["*"], expose_headers=EXPOSED_HEADERS)
    app.add_middleware(BodySizeLimit, limit=settings.max_request_bytes)
    # added last: outermost, so every answer carries the id (and, in JSON mode, is logged)
    app.add_middleware(RequestContext, access_log=settings.log_format == "json")
    return app


app = create_app()
