"""A field mission's live view tells the truth as a simulated one does: every auction the API
shows closed is closed in the feed (none left "open" after the end), the timeline is on and
says a field run plays back from its stored poses (tests/e2e/test_field_playback.py scrubs
one), each robot's
distance travelled is measured from what mission control hears (table, chart and stored
metrics), and the counters on completion are the final ones (docs/dashboard.md)."""

from __future__ import annotations

import re
import time
from typing import Any

import httpx
import pytest
from playwright.sync_api import Page, expect

from tests.e2e.conftest import ConsoleLog
from tests.e2e.test_compare_groups import FOUR, finish
from tests.e2e.test_dashboard import Start, open_live, wait_for
from tests.field.pace import paced
from tests.field.serial import one_field_mission_at_a_time

STUCK_S = 90  # wall seconds without a new delivery before the mission counts as stuck


def table_distances(page: Page) -> dict[str, float]:
    return dict(
        page.evaluate(
            """Object.fromEntries([...document.querySelectorAll('#robot-table tr[data-robot]')]
                .map(tr => [tr.dataset.robot, Number(tr.dataset.distance)]))"""
        )
    )


def wait_while_delivering(page: Page, api: httpx.Client, mid: int) -> dict[str, Any]:
    """Until the mission ends; fails only when deliveries stop coming for STUCK_S seconds."""
    seen, since = -1, time.monotonic()
    while True:
        detail: dict[str, Any] = api.get(f"/missions/{mid}").json()
        if detail["status"] != "running":
            return detail
        now = page.evaluate("window.__regolith.lastCounters.minerals_delivered ?? 0")
        if now != seen:
            seen, since = now, time.monotonic()
        assert time.monotonic() - since < STUCK_S, f"no delivery for {STUCK_S} s at {seen}"
        page.wait_for_timeout(500)


@pytest.mark.fleet
def test_field_mission_feed_timeline_and_distances(
    operator: Page, console: ConsoleLog, start_mission: Start, api: httpx.Client
) -> None:
    with one_field_mission_at_a_time():
        _field_view(operator, console, start_mission, api)


def _field_view(page: Page, console: ConsoleLog, start_mission: Start, api: httpx.Client) -> None:
    mission = start_mission(policy="nearest", seed=0, speed=paced(50.0), field=True)
    mid = mission["id"]
    open_live(page, mid)
    # a field run plays back from its stored poses: the timeline is on and says so
    timeline = page.locator("#timeline")
    expect(timeline).to_have_attribute("data-source", "poses")
    expect(timeline).not_to_have_attribute("data-disabled", "true")
    expect(page.locator("#tl-range")).to_be_enabled()
    expect(page.locator("#tl-play")).to_be_enabled()
    expect(page.locator("#tl-source")).to_have_text("field: stored poses")

    # distances from the heartbeats: every robot that moved has a distance, and the chart
    # shows each type's sum, while the mission runs
    wait_for(page, "window.__regolith.lastCounters.minerals_delivered >= 3", timeout=120)
    wait_for(
        page,
        """[...document.querySelectorAll('#robot-table tr[data-robot]')]
            .filter(tr => Number(tr.dataset.distance) > 0).length >= 10""",
        timeout=30,
    )
    chart = page.evaluate("window.__regolith.charts.distance")
    assert all(chart.get(t, 0) > 0 for t in ("scout", "excavator", "hauler")), chart
    expect(page.locator("#chart-distance")).not_to_contain_text("no data")
    grown = table_distances(page)
    wait_for(  # and they grow as the robots drive on
        page,
        f"""(() => {{ const was = {grown};
            return [...document.querySelectorAll('#robot-table tr[data-robot]')]
              .filter(tr => Number(tr.dataset.distance) > (was[tr.dataset.robot] || 0) + 1)
              .length >= 6; }})()""",
        timeout=60,
    )

    detail = wait_while_delivering(page, api, mid)
    assert detail["status"] == "completed", detail
    wait_for(page, "window.__regolith.final", timeout=30)
    m = detail["metrics"]
    # the counters are the final ones (the stored metrics)
    counters = page.evaluate("window.__regolith.lastCounters")
    assert counters["minerals_delivered"] == m["minerals_delivered"] == 64, (counters, m)
    expect(page.locator("[data-counter='minerals']")).to_have_text("64/64")
    # no robot was stopped: none is shown failed because its process ended with the mission
    expect(page.locator('#robot-table tr[data-robot][data-state="failed"]')).to_have_count(0)
    # the stored metrics carry the distances, as a simulated run's do
    assert all(m["distance"][t] > 0 for t in ("scout", "excavator", "hauler")), m["distance"]
    assert m["distance_total"] == pytest.approx(sum(m["distance"].values()))

    # every auction as the API has it: closed in the feed too, none left open
    items = api.get(f"/missions/{mid}/auctions", params={"limit": 500}).json()["items"]
    expect(page.locator("#feed-count")).to_have_text(f"{len(items)} · 0 open")
    feed = {a["id"]: a["status"] for a in page.evaluate("window.__regolith.auctions")}
    assert set(feed) == {a["id"] for a in items}
    wrong = {a["id"]: (feed[a["id"]], a["status"]) for a in items if feed[a["id"]] != a["status"]}
    assert wrong == {}, wrong
    assert console.errors == []


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
