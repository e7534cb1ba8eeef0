"""ASGI middleware: the request-body size limit, enforced before any handler parses a body."""

from __future__ import annotations

from .errors import ProblemError, problem


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

        return await self.app(scope, limited_receive, send)
