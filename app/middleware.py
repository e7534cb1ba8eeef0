"""ASGI middleware: the request context (``X-Request-ID``, metrics) and the request-body size
limit, enforced before any handler parses a body."""

from __future__ import annotations

import logging
import re
import time
import uuid

from . import metrics
from .errors import PROBLEM, PROBLEM_TYPE_PREFIX, REQUEST_ID, ProblemError, problem

access_log = logging.getLogger("app.access")

#: a client's X-Request-ID is kept when it is this safe (else a new one is generated)
_REQUEST_ID_OK = re.compile(rb"[A-Za-z0-9._:-]{1,128}")


class RequestContext:
    """Outermost middleware: gives every request an id (the client's ``X-Request-ID`` when it is
    1-128 of ``A-Za-z0-9._:-``, else a uuid4 hex), echoes it in the answer's headers, makes it
    available to problem details and logs (:data:`app.errors.REQUEST_ID`), and counts the request
    and its latency per route *template* (``/models/{model_id}/fk``, not the raw path; requests
    that match no route are labelled ``unmatched``), method and status. With ``access_log`` it
    also logs each answer on ``app.access`` (one record: method, path, route, status,
    duration_ms, the problem type of an error; ``KIN_LOG_FORMAT=json`` turns it on)."""

    def __init__(self, app, access_log: bool = False):
        self.app = app
        self.access_log = access_log

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        given = next((v for k, v in scope.get("headers", ()) if k == b"x-request-id"), None)
        request_id = given.decode() if given is not None and _REQUEST_ID_OK.fullmatch(given) else uuid.uuid4().hex
        scope["request_id"] = request_id
        REQUEST_ID.set(request_id)  # each request runs in its own context (task); not reset, so the 500 handler sees it
        PROBLEM.set(None)
        header = (b"x-request-id", request_id.encode())
        status = 500
        start = time.perf_counter()

        async def send_with_id(message):
            nonlocal status
            if message["type"] == "http.response.start":
                status = message["status"]
                headers = [h for h in message.get("headers", ()) if h[0].lower() != b"x-request-id"]
                message = {**message, "headers": [*headers, header]}
            await send(message)

        try:
            await self.app(scope, receive, send_with_id)
        except BaseException as exc:  # answered 500 by the outermost middleware (the error handler logs it)
            PROBLEM.set((PROBLEM_TYPE_PREFIX + "internal-error", type(exc).__name__))
            raise
        finally:
            elapsed = time.perf_counter() - start
            route = scope.get("route")
            template = getattr(route, "path", None) or "unmatched"
            labels = (scope.get("method", ""), template, str(status))
            metrics.REQUESTS.labels(*labels).inc()
            metrics.LATENCY.labels(*labels).observe(elapsed)
            metrics.record_models()
            if self.access_log:
                self._log(scope, template, status, elapsed)

    @staticmethod
    def _log(scope, template: str, status: int, elapsed: float) -> None:
        problem_ = PROBLEM.get()
        extra = {"method": scope.get("method", ""), "path": scope.get("path", ""), "route": template,
                 "status": status, "duration_ms": round(elapsed * 1000.0, 3),
                 "client": (scope.get("client") or ("-",))[0]}
        if problem_ is not None:
            extra["problem"], extra["detail"] = problem_[0], problem_[1][:500]
        level = logging.ERROR if status >= 500 else logging.INFO
        access_log.log(level, "%s %s %d", extra["method"], extra["path"], status, extra=extra)


#: a request body this large (bytes): the worker gives the memory freed by its request back to the system
TRIM_BYTES = 1 << 20


class BodySizeLimit:
    """Refuse (413 problem) bodies over ``limit`` bytes: by Content-Length up front, and by count
    while the body is received (chunked uploads)."""

    def __init__(self, app, limit: int):
        self.app = app
        self.limit = limit

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        for name, value in scope.get("headers", ()):
            if name == b"content-length":
                try:
                    size = int(value)
                except ValueError:
                    response = problem(400, "Bad request", "Content-Length is not a number", "bad-request")
                    return await response(scope, receive, send)
                if size > self.limit:
                    response = problem(413, "Content too large",
                                       f"request body of {size} bytes is over the limit of {self.limit} bytes",
                                       "content-too-large", field="body", limit=self.limit)
                    return await response(scope, receive, send)
        received = 0
        limit = self.limit

        async def limited_receive():
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise ProblemError(413, f"request body is over the limit of {limit} bytes",
                                       slug="content-too-large", field="body", limit=limit)
            return message

        try:
            return await self.app(scope, limited_receive, send)
        finally:
            if received >= TRIM_BYTES:  # a large body's pages back to the system once its request is done
                import asyncio

                from .heavy import release_freed_memory

                await asyncio.to_thread(release_freed_memory)
