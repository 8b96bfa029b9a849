"""/docs and /redoc render with no network: every request off 127.0.0.1 is aborted."""

from __future__ import annotations

import json
from urllib.parse import urlsplit

import pytest
from playwright.sync_api import Page, Route, expect

from tests.e2e.conftest import ConsoleLog

# ReDoc's side menu ends in an "API docs by Redocly" link whose logo it always loads from its
# CDN (and hides when that fails); the page's Content-Security-Policy blocks the request.
REDOC_LOGO = "https://cdn.redoc.ly/redoc/logo-mini.svg"


@pytest.fixture
def offline(page: Page) -> list[str]:
    """Abort (and list) every request that would leave the machine."""
    blocked: list[str] = []

    def route(r: Route) -> None:
        url = r.request.url
        if urlsplit(url).scheme in ("data", "blob") or urlsplit(url).hostname == "127.0.0.1":
            r.continue_()
        else:
            blocked.append(url)
            r.abort()

    page.route("**/*", route)
    return blocked


def test_swagger_ui_renders_offline(page: Page, console: ConsoleLog, offline: list[str]) -> None:
    page.goto("/docs")
    # the operation list, built by Swagger UI from /openapi.json
    expect(page.locator(".opblock-summary-path", has_text="/api/missions").first).to_be_visible()
    expect(page.locator(".opblock")).not_to_have_count(0)
    page.locator(".opblock-summary", has_text="/api/health").first.click()  # the UI works
    expect(page.locator(".opblock-body").first).to_be_visible()
    assert offline == [] and console.errors == []


def test_swagger_try_it_out_fills_in_a_valid_example(page: Page, offline: list[str]) -> None:
    """ "Try it out" on POST /api/missions fills in the published example (a request the API
    accepts, tests/api/test_openapi_examples.py), not a body made up from the schema."""
    page.goto("/docs")
    op = page.locator(
        ".opblock-post", has=page.locator(".opblock-summary-path[data-path='/api/missions']")
    )
    op.locator(".opblock-summary").click()
    op.locator("button.try-out__btn").click()
    body = json.loads(op.locator("textarea.body-param__text").input_value())
    spec = page.request.get("/openapi.json").json()
    first = spec["components"]["schemas"]["MissionCreate"]["examples"][0]
    assert body == first
    assert offline == []


def test_redoc_renders_offline(page: Page, console: ConsoleLog, offline: list[str]) -> None:
    page.goto("/redoc")
    expect(page.locator("h1", has_text="Regolith")).to_be_visible()  # the API's title
    menu = page.locator("[role=menuitem]", has_text="Create Mission")
    expect(menu.first).to_be_attached()  # the side menu lists the operations
    expect(page.locator(".api-content")).to_contain_text("Create Mission")
    assert offline == []
    assert [e for e in console.errors if f"'{REDOC_LOGO}' violates" not in e] == []
