"""Regenerate docs/img/live.png, the README's picture of the live view (on request only).

REGOLITH_DOCS_SCREENSHOT=1 .venv/bin/pytest tests/e2e/test_docs_screenshot.py
"""

from __future__ import annotations

import os

import pytest
from playwright.sync_api import Page, expect

from tests.e2e.conftest import REPO
from tests.e2e.test_dashboard import WORK, Start, next_robot_poll, open_live, wait_for

pytestmark = pytest.mark.skipif(
    os.environ.get("REGOLITH_DOCS_SCREENSHOT") != "1",
    reason="writes docs/img/live.png; set REGOLITH_DOCS_SCREENSHOT=1 to regenerate it",
)


def test_live_view_screenshot_for_the_readme(operator: Page, start_mission: Start) -> None:
    page = operator
    mission = start_mission(policy="coalition", seed=7, speed=60)
    open_live(page, mission["id"])
    # mid-mission: most sites found, minerals flowing, pairs visible
    wait_for(page, "(window.__regolith.lastCounters || {}).minerals_delivered >= 22", 60, WORK)
    page.locator('[data-speed="0"]').click()
    expect(page.locator("#live-status")).to_have_attribute("data-status", "paused")
    next_robot_poll(page, mission["id"])  # the robot list as paused
    wait_for(  # both charts drawn, with data (no "no data yet" placeholder)
        page,
        "document.querySelectorAll('#chart-minerals svg, #chart-distance svg').length === 2"
        " && !document.querySelector('#chart-minerals .empty, #chart-distance .empty')",
    )
    page.mouse.move(5, 795)  # no hover highlight in the picture
    out = REPO / "docs" / "img" / "live.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(out))
