"""/docs (Swagger UI) and /redoc with their assets served by the app itself, never a CDN.

FastAPI's own pages load Swagger UI and ReDoc from a CDN, so without internet they stay
blank ("SwaggerUIBundle is not defined"). The assets come from the PyPI package
`fastapi-offline` (its `static/` folder: Swagger UI's bundle and CSS, ReDoc's standalone
bundle), mounted at `/docs-assets/`; the pages are FastAPI's, pointed at them. Each page gets
a Content-Security-Policy allowing this origin only, plus the one inline script Swagger UI's
page needs (by its hash), so a page that tried to reach another host would be blocked.
"""

from __future__ import annotations

import base64
import hashlib
import re
from importlib.resources import files
from pathlib import Path
from typing import Any

from fastapi import FastAPI
from fastapi.openapi.docs import (
    get_redoc_html,
    get_swagger_ui_html,
    get_swagger_ui_oauth2_redirect_html,
)
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles

ASSETS_URL = "/docs-assets"
DOCS_URL = "/docs"
REDOC_URL = "/redoc"
OAUTH2_REDIRECT_URL = "/docs/oauth2-redirect"
_INLINE_SCRIPT = re.compile(r"<script>(.*?)</script>", re.DOTALL)


def assets_dir() -> Path:
    """The installed package's folder of Swagger UI and ReDoc files."""
    return Path(str(files("fastapi_offline") / "static"))


def _csp(html: str) -> str:
    """Only this origin; inline scripts only those in `html`, by their SHA-256."""
    hashes = " ".join(
        "'sha256-" + base64.b64encode(hashlib.sha256(s.encode()).digest()).decode() + "'"
        for s in _INLINE_SCRIPT.findall(html)
    )
    return (
        f"default-src 'self'; script-src 'self' {hashes}; style-src 'self' 'unsafe-inline'; "
        "img-src 'self' data:; font-src 'self' data:; worker-src 'self' blob:; "
        "connect-src 'self'; frame-ancestors 'none'"
    )


class _Page:
    """One page's HTML and policy, built once; a fresh response per request (middleware
    adds per-request headers to it)."""

    def __init__(self, response: HTMLResponse) -> None:
        self.html = bytes(response.body).decode()
        self.csp = _csp(self.html)

    def response(self) -> HTMLResponse:
        return HTMLResponse(self.html, headers={"content-security-policy": self.csp})


def install(app: FastAPI) -> None:
    """Add /docs, its OAuth2 redirect, /redoc and the assets (built once, served as is)."""
    assert app.openapi_url is not None
    favicon = f"{ASSETS_URL}/favicon.png"
    swagger = _Page(
        get_swagger_ui_html(
            openapi_url=app.openapi_url,
            title=f"{app.title} - Swagger UI",
            swagger_js_url=f"{ASSETS_URL}/swagger-ui-bundle.js",
            swagger_css_url=f"{ASSETS_URL}/swagger-ui.css",
            swagger_favicon_url=favicon,
            oauth2_redirect_url=OAUTH2_REDIRECT_URL,
        )
    )
    redirect = _Page(get_swagger_ui_oauth2_redirect_html())
    redoc = _Page(
        get_redoc_html(
            openapi_url=app.openapi_url,
            title=f"{app.title} - ReDoc",
            redoc_js_url=f"{ASSETS_URL}/redoc.standalone.js",
            redoc_favicon_url=favicon,
            with_google_fonts=False,
        )
    )
    app.mount(ASSETS_URL, StaticFiles(directory=assets_dir()), name="docs-assets")

    @app.get(DOCS_URL, include_in_schema=False)
    async def swagger_ui() -> HTMLResponse:
        return swagger.response()

    @app.get(OAUTH2_REDIRECT_URL, include_in_schema=False)
    async def swagger_ui_redirect() -> HTMLResponse:
        return redirect.response()

    @app.get(REDOC_URL, include_in_schema=False)
    async def redoc_page() -> HTMLResponse:
        return redoc.response()

    _publish_examples(app)


def _publish_examples(app: FastAPI) -> None:
    """Each request model's `examples` (its JSON Schema, `app/api/schemas.py`) also as the
    request body's OpenAPI examples, which Swagger UI's "Try it out" fills in and ReDoc
    shows; without them Swagger UI makes a body up from the schema (`"plant": [null, null]`,
    a crater at -1e7) that the API refuses."""
    build = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            spec = build()
            models = spec.get("components", {}).get("schemas", {})
            for ops in spec.get("paths", {}).values():
                for op in ops.values():
                    media = op.get("requestBody", {}).get("content", {}).get("application/json")
                    if media is None or "examples" in media:
                        continue
                    schema = media.get("schema", {})
                    for option in schema.get("anyOf", [schema]):
                        found = models.get(option.get("$ref", "").rsplit("/", 1)[-1], {})
                        if found.get("examples"):
                            media["examples"] = {
                                f"example {i + 1}": {"value": ex}
                                for i, ex in enumerate(found["examples"])
                            }
                            break
            app.openapi_schema = spec
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
