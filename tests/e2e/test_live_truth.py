"""The live view never shows stale or made-up data: at the end it shows the stored
ending exactly; an unknown mission says so; a token is checked before it is kept."""

from __future__ import annotations

from typing import Any

from playwright.sync_api import Page, expect

from tests.e2e.conftest import TOKEN, ConsoleLog
from tests.e2e.test_dashboard import WORK, Start, open_live, wait_for


def _all_events(api: Any, mission_id: int, kind: str) -> list[dict[str, Any]]:
    items: list[dict[str, Any]] = []
    after = -1
    while True:
        page = api.get(
            f"/missions/{mission_id}/events", params={"kind": kind, "after": after, "limit": 1000}
        ).json()
        items += page["items"]
        if page["next_after"] is None:
            return items
        after = page["next_after"]


def _expect_stored_ending(page: Page, api: Any, mission_id: int) -> None:
    """Every figure the view shows is the stored one, to the last bit."""
    wait_for(page, "window.__regolith.final === true")
    record = api.get(f"/missions/{mission_id}").json()
    metrics = record["metrics"]
    robots = {r["name"]: r for r in api.get(f"/missions/{mission_id}/robots").json()}
    shown = page.evaluate("window.__regolith.charts")
    assert shown["final"] is True
    assert shown["distance"] == metrics["distance"]  # the distance chart
    delivered = _all_events(api, mission_id, "delivered")
    assert shown["delivered"] == [[e["t"], e["data"]["delivered"]] for e in delivered]
    assert shown["delivered"][-1][1] == metrics["minerals_delivered"]
    assert shown["total"] == metrics["minerals_total"]
    assert shown["t"] == record["sim_time"] == page.evaluate("window.__regolith.t")
    auctions = api.get(
        f"/missions/{mission_id}/auctions", params={"status": "closed", "limit": 500}
    ).json()
    assert auctions["total"] == len(auctions["items"]) > 0
    times: dict[str, list[float]] = {}
    for a in auctions["items"]:
        times.setdefault(a["kind"], []).append(a["closed_at"] - a["opened_at"])
    assert shown["openTimes"] == times
    # the chart's bars carry the same figures (rounded in their tooltips)
    bars = page.locator("#chart-distance rect title").all_text_contents()
    for kind, value in metrics["distance"].items():
        assert f"{kind} · {kind}: {value:.1f} m" in bars, bars
    # the robot table: each row's state, task and exact distance as stored
    rows = page.locator("#robot-table tbody tr[data-robot]")
    expect(rows).to_have_count(len(robots))
    for row in rows.all():
        r = robots[row.get_attribute("data-robot") or ""]
        assert float(row.get_attribute("data-distance") or "nan") == r["distance"]
        assert (row.get_attribute("data-task") or None) == r["task"]
        state = "failed" if r["alive"] is False and r["state"] != "disabled" else r["state"]
        assert row.get_attribute("data-state") == state
    counters = page.evaluate("window.__regolith.lastCounters")
    for key in ("sites_found", "minerals_delivered", "auctions", "bids", "declines"):
        assert counters[key] == metrics[key], key
    expect(page.locator('[data-counter="minerals"]')).to_have_text(
        f"{metrics['minerals_delivered']}/{metrics['minerals_total']}"
    )


def test_a_mission_run_to_the_end_at_max_shows_its_stored_ending(
    operator: Page, start_mission: Start, api: Any, console: ConsoleLog
) -> None:
    page = operator
    mission = start_mission(seed=5, speed=10, planner="straight")  # the view, not the paths
    open_live(page, mission["id"])
    page.locator('[data-speed="max"]').click()
    wait_for(page, "window.__regolith.status === 'completed'", 60, WORK)
    expect(page.locator("#live-status")).to_have_text("completed")
    _expect_stored_ending(page, api, mission["id"])
    # opened afresh after the end: the same, from the record
    page.goto("/#/missions")
    page.goto(f"/#/live/{mission['id']}")
    _expect_stored_ending(page, api, mission["id"])
    assert console.errors == []


def test_an_unknown_mission_says_not_found(page: Page, console: ConsoleLog) -> None:
    failed: list[str] = []
    page.on("response", lambda r: failed.append(f"{r.status} {r.url}") if r.status >= 400 else None)
    sockets: list[str] = []
    page.on("websocket", lambda ws: sockets.append(ws.url))
    page.goto("/#/live/abc")  # not an id at all: nothing is asked
    expect(page.locator("#live-empty-missing")).to_be_visible()
    expect(page.locator("#live-empty-missing")).to_contain_text("Mission not found")
    expect(page.locator("#live-missing-id")).to_have_text("abc")
    expect(page.locator("#live")).to_be_hidden()
    page.goto("/#/live/999999")  # an id the server does not know: asked once
    expect(page.locator("#live-missing-id")).to_have_text("999999")
    expect(page.locator("#live-empty-missing")).to_be_visible()
    page.wait_for_timeout(1500)  # a robot poll (1 s) would have happened by now
    assert failed == [f"404 {page.url.split('/#')[0]}/api/missions/999999"], failed
    assert sockets == []
    assert [e for e in console.errors if "404" not in e] == []
    assert len(console.errors) <= 1  # the browser's own line for the one 404


def test_the_token_is_checked_before_it_is_kept(page: Page) -> None:
    page.goto("/#/missions")
    badge = page.locator("#operator-status")
    expect(badge).to_have_text("Read-only")
    page.locator("#token-button").click()
    dialog = page.locator("#token-dialog")
    dialog.get_by_label("Token").fill("not-the-token")
    dialog.get_by_role("button", name="Save").click()
    expect(page.locator("#token-error")).to_have_text("The server did not accept this token.")
    expect(dialog).to_be_visible()  # still open, nothing kept
    expect(badge).to_have_text("Read-only")
    assert page.evaluate("localStorage.getItem('regolith.token')") is None
    dialog.get_by_label("Token").fill(TOKEN)
    dialog.get_by_role("button", name="Save").click()
    expect(dialog).to_be_hidden()
    expect(badge).to_have_text("Operator")
    assert page.evaluate("localStorage.getItem('regolith.token')") == TOKEN
    page.locator("#token-button").click()
    expect(page.locator("#token-error")).to_have_text("")  # the old error is gone
    dialog.get_by_role("button", name="Cancel").click()
    # a kept token the server later refuses is shown as refused, not as "Operator"
    page.evaluate("localStorage.setItem('regolith.token', 'stale-token')")
    page.reload()
    page.locator("#start-form button[type=submit]").click()
    expect(page.locator("#start-error")).to_contain_text("not accepted")
    expect(badge).to_have_text("Token refused")
