"""Prometheus metrics: ``GET /metrics`` (text exposition format)."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from ..metrics import exposition

router = APIRouter(tags=["health"])


@router.get("/metrics", response_class=Response, responses={200: {
    "description": "Prometheus text exposition format", "content": {"text/plain": {"schema": {"type": "string"}}}}})
async def metrics() -> Response:
    """Request counts and latency per route template and status, IK outcomes and iterations,
    configurations processed. With `PROMETHEUS_MULTIPROC_DIR` set, aggregated over the workers."""
    body, content_type = exposition()
    return Response(body, media_type=content_type)
