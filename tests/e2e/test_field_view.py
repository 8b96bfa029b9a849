"""A look back the server refuses (a 409 for a field run, a server gone) returns the live view
to the present. (The field mission's own live view, its timeline, distances, final counters
and feed, is checked on the dashboard's field mission: tests/e2e/test_field.py.)"""

from __future__ import annotations

import re

import httpx
from playwright.sync_api import Page, expect

from tests.e2e.test_compare_groups import FOUR, finish
from tests.e2e.test_dashboard import Start, wait_for


def test_a_look_back_the_server_refuses_returns_to_the_present(
    operator: Page, start_mission: Start, api: httpx.Client
) -> None:
    """Whatever makes `…/state` fail (a 409 for a field run, a server gone), the view goes back
    to the present with the error said, rather than staying "looking back" at a moment it
    never showed."""
    page = operator
    mission = finish(api, start_mission(seed=8, planner="straight", scenario=FOUR))
    page.route(
        re.compile(r".*/api/missions/\d+/state\?.*"),
        lambda route: route.fulfill(
            status=409, json={"detail": "mission cannot be looked back at"}
        ),
    )
    page.goto(f"/#/live/{mission['id']}")
    wait_for(page, "window.__regolith.final")
    page.locator("#tl-range").focus()
    page.keyboard.press("Home")
    expect(page.locator("#toasts")).to_contain_text("mission cannot be looked back at")
    expect(page.locator("#timeline")).to_have_attribute("data-mode", "latest")
    wait_for(page, "window.__regolith.final")  # the stored ending again
    expect(page.locator("#live")).not_to_have_class(re.compile(r"\blooking-back\b"))
