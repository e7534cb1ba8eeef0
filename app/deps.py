"""Dependencies (typed aliases), API-key checks and request-body reading."""

from __future__ import annotations

import hmac
from typing import Annotated

from fastapi import Depends, Path, Request
from fastapi.security import APIKeyHeader, HTTPAuthorizationCredentials, HTTPBearer

from .errors import ProblemError
from .registry import MODEL_ID_PATTERN, Registry
from .settings import Settings

# The dependencies below are coroutines although they never await: FastAPI runs a plain ``def``
# dependency in its thread pool, a hop that costs more than the dependency itself.


async def get_settings(request: Request) -> Settings:
    return request.app.state.settings


async def get_registry(request: Request) -> Registry:
    return request.app.state.registry


SettingsDep = Annotated[Settings, Depends(get_settings)]
RegistryDep = Annotated[Registry, Depends(get_registry)]
ModelId = Annotated[str, Path(description="model id (`ur5`, `panda`, an uploaded `u-...`, a DH-built `dh-...`)",
                              pattern=MODEL_ID_PATTERN, examples=["ur5"])]

_api_key_header = APIKeyHeader(name="X-API-Key", auto_error=False, description="the service's API key")
_bearer = HTTPBearer(auto_error=False, description="the service's API key as a bearer token")


def _check_key(settings: Settings, header_key: str | None, bearer: HTTPAuthorizationCredentials | None) -> None:
    expected = settings.api_key.get_secret_value().encode() if settings.api_key else None
    if expected is None:
        return
    given = header_key if header_key is not None else (bearer.credentials if bearer is not None else None)
    if given is None:
        raise ProblemError(401, "this operation needs the API key (header X-API-Key, or Authorization: Bearer)",
                           slug="api-key-required", headers={"WWW-Authenticate": 'Bearer realm="kinematics"'})
    if not hmac.compare_digest(given.encode(), expected):
        raise ProblemError(403, "the API key is not valid", slug="api-key-invalid")


async def require_write_key(settings: SettingsDep, key: Annotated[str | None, Depends(_api_key_header)] = None,
                            bearer: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)] = None) -> None:
    """Writes (register / delete models) need the key when ``KIN_API_KEY`` is set."""
    _check_key(settings, key, bearer)


async def require_read_key(settings: SettingsDep, key: Annotated[str | None, Depends(_api_key_header)] = None,
                           bearer: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)] = None) -> None:
    """Reads need the key too when ``KIN_API_KEY_FOR_READS`` is true."""
    if settings.api_key_for_reads:
        _check_key(settings, key, bearer)


async def read_body(request: Request, limit: int, what: str) -> bytes:
    """The request body, refused with 413 when its declared or actual size exceeds ``limit`` bytes."""
    declared = request.headers.get("content-length")
    if declared is not None:
        try:
            size = int(declared)
        except ValueError:
            raise ProblemError(400, "Content-Length is not a number", slug="bad-request") from None
        if size > limit:
            raise ProblemError(413, f"{what} of {size} bytes is over the limit of {limit} bytes",
                               slug="content-too-large", field="body", limit=limit)
    chunks, total = [], 0
    async for chunk in request.stream():
        total += len(chunk)
        if total > limit:
            raise ProblemError(413, f"{what} is over the limit of {limit} bytes", slug="content-too-large",
                               field="body", limit=limit)
        chunks.append(chunk)
    return b"".join(chunks)


def media_type(request: Request) -> str:
    return request.headers.get("content-type", "").split(";", 1)[0].strip().lower()


def wants_npy(request: Request) -> bool:
    """The client accepts an ``.npy`` answer (``Accept: application/x-npy``)."""
    from .responses import NPY_MEDIA_TYPE

    return NPY_MEDIA_TYPE in request.headers.get("accept", "").lower()


def wants_npz(request: Request) -> bool:
    """The client accepts an ``.npz`` answer (``Accept: application/x-npz``)."""
    from .responses import NPZ_MEDIA_TYPE

    return NPZ_MEDIA_TYPE in request.headers.get("accept", "").lower()
