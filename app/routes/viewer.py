"""The model viewer: a browser page that draws any model and calls the API to move it.

``GET /viewer`` and ``GET /viewer/{id}`` return the page; ``GET /viewer/static/{path}``
its files (HTML, JS, CSS and vendored copies of three.js and KaTeX, see
``scripts/vendor_threejs.sh`` and ``scripts/vendor_katex.sh``); ``GET /viewer/api/{id}/visuals`` the primitive visual
geometry of a model's links, which the model info does not carry. The page draws the links'
visuals from ``GET /models/{id}/visual`` (meshes parsed by three.js's vendored STL, Collada and OBJ
loaders from ``/models/{id}/visual/meshes/{index}``, :mod:`app.routes.visual`) and paints the links
in self-collision red (``POST /models/{id}/collision``). It does no
kinematics itself: it calls ``POST /models/{id}/fk``, ``/jacobian`` and, for its draggable IK
target (three.js's ``TransformControls``, vendored too), ``/ik``; its "Closed form" tab and DH
editor ``POST /models/{id}/symbolic`` and ``/symbolic/dh`` (LaTeX typeset by KaTeX).

The page loads nothing from outside the service: its scripts are served here, and its
``Content-Security-Policy`` allows only this origin (plus the page's one inline import
map, by hash).
"""

from __future__ import annotations

import base64
import hashlib
import html
import json
import mimetypes
from functools import lru_cache
from pathlib import Path

from fastapi import APIRouter, Depends, Request
from fastapi.responses import FileResponse, HTMLResponse
from pydantic import BaseModel, Field

from app.deps import ModelId, RegistryDep, require_read_key
from app.errors import ProblemError

STATIC_DIR = Path(__file__).resolve().parent.parent / "static" / "viewer"
#: browsers revalidate the page's files on every load (cheap: ETag / Last-Modified answer 304),
#: so an upgraded service never runs with a stale script
STATIC_CACHE_CONTROL = "no-cache"

router = APIRouter(tags=["viewer"])


class VisualOut(BaseModel):
    """One primitive visual of a link. Meshes are listed by kind only (never opened)."""

    kind: str = Field(description="box | cylinder | sphere | mesh")
    origin: list[list[float]] = Field(description="T_link_visual, 4x4 row-major")
    size: list[float] = Field(description="box: [x, y, z]; cylinder: [radius, length]; sphere: [radius]; mesh: []")


class VisualsOut(BaseModel):
    model: str
    visuals: dict[str, list[VisualOut]] = Field(description="per link name, its visuals in URDF order")


@lru_cache(maxsize=1)
def _template() -> str:
    return (STATIC_DIR / "index.html").read_text(encoding="utf-8")


def _page(request: Request, model_id: str) -> HTMLResponse:
    root = request.scope.get("root_path", "").rstrip("/")
    import_map = json.dumps({
        "imports": {
            "three": f"{root}/viewer/static/vendor/three.module.js",
            "three/addons/": f"{root}/viewer/static/vendor/addons/",
        }
    })
    digest = base64.b64encode(hashlib.sha256(import_map.encode()).digest()).decode()
    body = (
        _template()
        .replace("__IMPORTMAP__", import_map)
        .replace("__ROOT__", html.escape(root, quote=True))
        .replace("__MODEL__", html.escape(model_id, quote=True))
    )
    csp = (
        "default-src 'self'; "
        f"script-src 'self' 'sha256-{digest}'; "
        "style-src 'self'; img-src 'self' data: blob:; connect-src 'self'; "
        "object-src 'none'; base-uri 'none'; frame-ancestors 'self'"
    )
    return HTMLResponse(body, headers={"Content-Security-Policy": csp, "Cache-Control": "no-cache"})


@router.get("/viewer", response_class=HTMLResponse, summary="Model viewer page")
def viewer_page(request: Request) -> HTMLResponse:
    """A page that draws a model in 3D (links as axis triads, joints, visuals: catalogue models'
    meshes; colliding links red), with a
    slider per joint, the pose and manipulability of a chosen link, a draggable IK target for
    that link, and a DH table editor."""
    return _page(request, "")


@router.get("/viewer/{model_id}", response_class=HTMLResponse, summary="Model viewer page for one model")
def viewer_page_for(model_id: str, request: Request) -> HTMLResponse:
    """The viewer page, opened on model ``model_id`` (an unknown id is reported in the page)."""
    return _page(request, model_id)


@router.get("/viewer/static/{path:path}", include_in_schema=False)
def viewer_static(path: str) -> FileResponse:
    """The page's own files (no directory listing; nothing outside ``app/static/viewer``)."""
    target = (STATIC_DIR / path).resolve()
    if not target.is_relative_to(STATIC_DIR) or not target.is_file():
        raise ProblemError(404, f"no viewer file {path!r}")
    media_type = mimetypes.guess_type(target.name)[0] or "application/octet-stream"
    if target.suffix == ".js":
        media_type = "text/javascript"
    elif target.suffix == ".woff2":  # KaTeX's fonts (mimetypes does not know woff2 everywhere)
        media_type = "font/woff2"
    return FileResponse(target, media_type=media_type, headers={"Cache-Control": STATIC_CACHE_CONTROL})



@router.get("/viewer/api/{model_id}/visuals", response_model=VisualsOut, summary="Primitive visuals of a model's links",
            dependencies=[Depends(require_read_key)], responses={404: {"description": "unknown model"}})
def viewer_visuals(model_id: ModelId, registry: RegistryDep) -> VisualsOut:
    """Per link, its URDF visual geometry: boxes, cylinders and spheres with ``origin`` =
    ``T_link_visual`` (4x4, row-major); meshes are listed by kind only (never opened)."""
    model = registry.get(model_id).model
    return VisualsOut(
        model=model_id,
        visuals={
            link: [VisualOut(kind=v.kind, origin=v.origin.tolist(), size=list(v.size)) for v in model.visuals.get(link, ())]
            for link in model.links
        },
    )
