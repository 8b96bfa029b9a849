"""The dashboard's layout at 1280×800, 1024×768 and on a phone (390×844): nothing overlaps
that should not, nothing is off-screen. Screenshots go to test-artifacts/e2e/ and,
with REGOLITH_DOCS_SCREENSHOT=1, to docs/img/ (the pictures docs/dashboard.md shows)."""

from __future__ import annotations

import os
from typing import Any

from playwright.sync_api import Page, expect

from tests.e2e.conftest import ARTIFACTS, REPO, painted
from tests.e2e.test_dashboard import WORK, Start, next_robot_poll, open_live, wait_for

DOCS = os.environ.get("REGOLITH_DOCS_SCREENSHOT") == "1"
SIZES = {"wide": (1280, 800), "laptop": (1024, 768), "phone": (390, 844)}

# every SVG text of a chart's x axis, and its bar values with their whiskers, as boxes
CHART_BOXES = """sel => [...document.querySelectorAll(sel)].map(svg => {
  const box = (e) => {
    const r = e.getBoundingClientRect();
    return [r.left, r.top, r.right, r.bottom];
  };
  return {
    xlabels: [...svg.querySelectorAll('text.xlabel')].map(box),
    values: [...svg.querySelectorAll('text.value')].map(box),
    whiskers: [...svg.querySelectorAll('path')].map(box),
  };
})"""


def _overlap(a: list[float], b: list[float], slack: float = 0.5) -> bool:
    return (
        a[0] < b[2] - slack and a[2] > b[0] + slack and a[1] < b[3] - slack and a[3] > b[1] + slack
    )


def _rect(page: Page, selector: str) -> list[float]:
    r = page.locator(selector).bounding_box()
    assert r is not None, selector
    return [r["x"], r["y"], r["x"] + r["width"], r["y"] + r["height"]]


IN_DOCS = {"live-laptop", "live-phone", "missions-phone"}  # docs/dashboard.md shows these


def _shot(page: Page, name: str) -> None:
    page.mouse.move(1, 1)  # no hover text in the picture
    page.screenshot(path=str(ARTIFACTS / f"layout-{name}.png"))
    if DOCS and name in IN_DOCS:
        page.screenshot(path=str(REPO / "docs" / "img" / f"{name}.png"))


def check_charts(page: Page, selector: str = ".charts svg") -> None:
    """No two x labels of a chart overlap; no bar value sits on a whisker."""
    for chart in page.evaluate(CHART_BOXES, selector):
        labels = chart["xlabels"]
        for i, a in enumerate(labels):
            assert not any(_overlap(a, b) for b in labels[i + 1 :]), labels
        for v in chart["values"]:
            assert not any(_overlap(v, w) for w in chart["whiskers"]), (v, chart["whiskers"])


def _check_map(page: Page) -> None:
    drawn = page.evaluate("window.__regolith.drawn")
    labels = [d["box"] for d in drawn["labels"]]
    for i, a in enumerate(labels):
        assert not any(_overlap(a, b) for b in labels[i + 1 :]), drawn["labels"]
        assert not any(_overlap(a, g) for g in drawn["glyphs"]), a
    # a robot that is down is drawn over the others, never under
    robots = {r["name"]: r for r in page.evaluate("window.__regolith.robots")}
    down = [
        robots[n]["alive"] is False or robots[n]["state"] in ("failed", "disabled")
        for n in drawn["order"]
    ]
    assert any(down) and down == sorted(down), drawn["order"]
    # no panel covers the mission area
    world = page.evaluate("window.__regolith.map")
    x0, y1 = page.evaluate("window.__regolith.pagePoint(0, 0)")
    x1, y0 = page.evaluate(f"window.__regolith.pagePoint({world['width']}, {world['height']})")
    area = [x0, y0, x1, y1]
    for panel in (".map-tools", "#live-counters", "#legend"):
        assert not _overlap(area, _rect(page, panel), slack=1), panel


def _fits_the_screen(page: Page, width: int) -> None:
    assert page.evaluate("document.documentElement.scrollWidth") <= width
    for sel in ("#token-button", "#operator-status", "[data-nav=compare]"):
        box = _rect(page, sel)
        assert box[0] >= 0 and box[2] <= width, (sel, box)


def test_layout_at_three_sizes(operator: Page, start_mission: Start, api: Any) -> None:
    page = operator
    mission = start_mission(policy="coalition", seed=7, speed=120)
    mid = mission["id"]
    open_live(page, mid)
    wait_for(page, "(window.__regolith.lastCounters || {}).minerals_delivered >= 12", 60, WORK)
    plant = page.evaluate("window.__regolith.map.plant")
    task = {"type": "excavate", "location": [plant["x"] + 12, plant["y"] + 10]}
    assert api.post(f"/missions/{mid}/tasks", json=task).status_code in (200, 201)
    assert (
        api.post(f"/missions/{mid}/robots/hauler-2/disable", json={"mode": "abrupt"}).status_code
        == 200
    )
    wait_for(
        page,
        "document.querySelector('#auction-feed li[data-kind=operator][data-status=closed]')",
        60,
        WORK,
    )
    page.locator('[data-speed="0"]').click()
    expect(page.locator("#live-status")).to_have_attribute("data-status", "paused")
    next_robot_poll(page, mid)
    wait_for(page, "(document.querySelector('#chart-auctions svg text.xlabel') || {}).textContent")

    for name, (w, h) in SIZES.items():
        page.set_viewport_size({"width": w, "height": h})
        painted(page)  # the charts and the map redraw on resize
        page.locator("#map-fit").click()
        wait_for(page, "window.__regolith.drawn && window.__regolith.drawn.labels.length > 0")
        _fits_the_screen(page, w)
        _check_map(page)
        check_charts(page)
        if name == "phone":
            # one column: the map, then status and controls, then the lists
            tops = [
                _rect(page, s)[1]
                for s in ("#map-stage", ".toolbar", ".robots-panel", ".feed-panel")
            ]
            assert tops == sorted(tops), tops
            assert _rect(page, "#map-stage")[2] - _rect(page, "#map-stage")[0] >= 340
            page.evaluate("window.scrollTo(0, 0)")
        _shot(page, f"live-{name}")

    page.set_viewport_size({"width": 390, "height": 844})
    page.goto("/#/missions")
    expect(page.locator(f'#history tr[data-mission="{mid}"]')).to_be_visible()
    _fits_the_screen(page, 390)
    _shot(page, "missions-phone")
    page.goto("/#/compare")
    _fits_the_screen(page, 390)
    _shot(page, "compare-phone")
