"""OpenAPI docs pages served offline: Swagger UI and ReDoc assets come from the service itself.

The assets are those bundled by the PyPI package ``fastapi-offline`` (``static/``); the
pages are FastAPI's own HTML pointed at them (no CDN, no Google fonts).
"""

from __future__ import annotations

from functools import partial
from pathlib import Path

import fastapi_offline
from fastapi import FastAPI, Request
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html, get_swagger_ui_oauth2_redirect_html
from fastapi.responses import HTMLResponse, RedirectResponse
from fastapi.staticfiles import StaticFiles

DOCS_ASSETS_DIR = Path(fastapi_offline.__file__).resolve().parent / "static"
DOCS_ASSETS_URL = "/static/docs"


def install_docs(app: FastAPI, docs_url: str = "/docs", redoc_url: str = "/redoc") -> None:
    """Mount the assets and add ``/docs``, ``/docs/oauth2-redirect``, ``/redoc``, and ``/`` (a redirect to ``/docs``)."""
    app.mount(DOCS_ASSETS_URL, StaticFiles(directory=DOCS_ASSETS_DIR), name="docs-assets")
    oauth2_url = f"{docs_url}/oauth2-redirect"

    def page(request: Request, render, name: str, **assets: str) -> HTMLResponse:
        """``render`` (FastAPI's page of ``name``) with the document and every asset under the root path."""
        root = request.scope.get("root_path", "")
        urls = {key: f"{root}{DOCS_ASSETS_URL}/{file}" for key, file in assets.items()}
        return render(openapi_url=f"{root}{app.openapi_url}", title=f"{app.title} - {name}", **urls)

    @app.get(docs_url, include_in_schema=False)
    async def swagger_ui(request: Request) -> HTMLResponse:
        return page(request, partial(get_swagger_ui_html, swagger_ui_parameters=app.swagger_ui_parameters,
                                     oauth2_redirect_url=f"{request.scope.get('root_path', '')}{oauth2_url}"),
                    "Swagger UI", swagger_js_url="swagger-ui-bundle.js", swagger_css_url="swagger-ui.css",
                    swagger_favicon_url="favicon.png")

    @app.get(oauth2_url, include_in_schema=False)
    async def swagger_ui_redirect() -> HTMLResponse:
        return get_swagger_ui_oauth2_redirect_html()

    @app.get(redoc_url, include_in_schema=False)
    async def redoc(request: Request) -> HTMLResponse:
        return page(request, partial(get_redoc_html, with_google_fonts=False), "ReDoc",
                    redoc_js_url="redoc.standalone.js", redoc_favicon_url="favicon.png")

    @app.get("/", include_in_schema=False)
    async def front_door(request: Request) -> RedirectResponse:
        """The service's address in a browser: its API pages (the viewer is at /viewer)."""
        return RedirectResponse(f"{request.scope.get('root_path', '')}{docs_url}", status_code=307)
