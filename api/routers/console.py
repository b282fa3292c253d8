"""The operator console and the API documentation, served offline.

`GET /` is the console (api/console/index.html: sign-in with an API token, live rig view, scheme
forms, runs, jobs); its script and stylesheet come from `/console/…`, files of this package.
`/docs` (Swagger UI) and `/redoc` load their scripts from `/docs-assets/…`, the copies that the
`fastapi-offline` package ships: nothing is fetched from a CDN, so both work on a rig network with
no Internet. The console holds no authority of its own: every action is an API call with the
signed-in token, which the API checks as for any client. `GET /me` tells a token's holder
its name and role (the console shows it and hides what the role may not use)."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, HTTPException
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html
from fastapi.responses import FileResponse, HTMLResponse
from pydantic import BaseModel

from api.auth import ROLES
from api.deps import ERRORS, Viewer

CONSOLE_DIR = Path(__file__).resolve().parents[1] / "console"
"""The console's files (index.html, console.js, console.css)."""

CONSOLE_FILES = {"console.js": "text/javascript", "console.css": "text/css"}
"""The console's assets by name and media type (nothing else under /console is served)."""

DOCS_FILES = {"swagger-ui-bundle.js": "text/javascript", "swagger-ui.css": "text/css",
              "redoc.standalone.js": "text/javascript", "favicon.png": "image/png"}
"""The documentation pages' assets, from the fastapi-offline package."""

page_router = APIRouter(include_in_schema=False)
router = APIRouter(tags=["console"], responses=ERRORS)


def _docs_dir() -> Path:
    import fastapi_offline
    return Path(fastapi_offline.__file__).resolve().parent / "static"


@page_router.get("/", response_class=HTMLResponse)
def console_page() -> FileResponse:
    return FileResponse(CONSOLE_DIR / "index.html", media_type="text/html",
                        headers={"Cache-Control": "no-cache"})


@page_router.get("/console/{name}")
def console_asset(name: str) -> FileResponse:
    if name not in CONSOLE_FILES:
        raise HTTPException(404, f"no console file {name}")
    return FileResponse(CONSOLE_DIR / name, media_type=CONSOLE_FILES[name],
                        headers={"Cache-Control": "no-cache"})


@page_router.get("/favicon.ico")
def favicon() -> FileResponse:
    return FileResponse(_docs_dir() / "favicon.png", media_type="image/png",
                        headers={"Cache-Control": "max-age=86400"})


@page_router.get("/docs-assets/{name}")
def docs_asset(name: str) -> FileResponse:
    if name not in DOCS_FILES:
        raise HTTPException(404, f"no documentation file {name}")
    return FileResponse(_docs_dir() / name, media_type=DOCS_FILES[name],
                        headers={"Cache-Control": "max-age=86400"})


@page_router.get("/docs", response_class=HTMLResponse)
def swagger_ui() -> HTMLResponse:
    return get_swagger_ui_html(openapi_url="/openapi.json", title="J4 test platform — API",
                               swagger_js_url="/docs-assets/swagger-ui-bundle.js",
                               swagger_css_url="/docs-assets/swagger-ui.css",
                               swagger_favicon_url="/docs-assets/favicon.png")


@page_router.get("/redoc", response_class=HTMLResponse)
def redoc() -> HTMLResponse:
    return get_redoc_html(openapi_url="/openapi.json", title="J4 test platform — API",
                          redoc_js_url="/docs-assets/redoc.standalone.js",
                          redoc_favicon_url="/docs-assets/favicon.png", with_google_fonts=False)


class Me(BaseModel):
    """Who holds the token: its name and role, and the roles in order of authority."""
    name: str
    role: str
    roles: list[str]


@router.get("/me", response_model=Me, summary="The signed-in token's name and role")
def me(caller: Viewer) -> Me:
    return Me(name=caller.name, role=caller.role, roles=list(ROLES))
