"""The dashboard tells the truth after a restart, and about missions that have ended.

A mission live when the server stops comes back `interrupted`: the live view must say so
(not "running", which is what the stored engine state and frames say), offer an operator
Resume, and continue once resumed. These tests run their own server, because they restart it.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from playwright.sync_api import Page, expect

from tests.e2e.conftest import ARTIFACTS, Server, running_server
from tests.e2e.test_dashboard import Start, wait_for

# every control that needs a live mission (Resume is the one thing an interrupted one takes)
LIVE_ONLY = [
    "#policy-select",
    "[data-speed='0']",
    "[data-speed='10']",
    "#stop-button",
    "#inject-open",
    "#add-robot-form button[type=submit]",
    "#robot-table tr[data-robot='hauler-1'] [data-action='fail']",
]


@pytest.fixture(scope="module")
def own_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    yield from running_server(tmp_path_factory, "server-restart")


def _start(srv: Server, **body: Any) -> int:
    with srv.api() as api:
        res = api.post("/missions", json={"policy": "fcfs", "seed": 3, "speed": 10, **body})
        assert res.status_code == 201, res.text
        return int(res.json()["id"])


def _status(srv: Server, mid: int) -> str:
    with srv.api() as api:
        return str(api.get(f"/missions/{mid}").json()["status"])


def _expect_live_only_controls(page: Page, enabled: bool) -> None:
    for sel in LIVE_ONLY:
        loc = page.locator(sel)
        if enabled:
            expect(loc).to_be_enabled()
        else:
            expect(loc).to_be_disabled()


def test_restart_shows_interrupted_and_resume_continues(operator: Page, own_server: Server) -> None:
    page = operator
    srv = own_server
    mid = _start(srv)
    page.goto(f"{srv.url}/#/live/{mid}")
    wait_for(page, "window.__regolith && window.__regolith.frames >= 3")
    expect(page.locator("#live-status")).to_have_text("running")
    expect(page.locator("#resume-button")).to_be_hidden()

    srv.restart()  # the page stays open: its stream reconnects to the new process

    assert _status(srv, mid) == "interrupted"
    status = page.locator("#live-status")
    expect(status).to_have_text("interrupted")
    expect(status).to_have_attribute("data-status", "interrupted")
    expect(page.locator("#live-conn")).to_have_attribute("data-conn", "open")
    # the snapshot's stored engine state says "running" and is applied as a frame right
    # after the record's status: the status must still be the record's
    assert page.evaluate("window.__regolith.status") == "interrupted"
    notice = page.locator("#live-notice")
    expect(notice).to_be_visible()
    expect(notice).to_contain_text("Interrupted")
    resume = page.locator("#resume-button")
    expect(resume).to_be_visible()
    expect(resume).to_be_enabled()
    _expect_live_only_controls(page, enabled=False)
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "interrupted-view.png"))
    t0 = page.evaluate("window.__regolith.t")

    resume.click()

    expect(status).to_have_text("running")  # replay takes a moment
    expect(resume).to_be_hidden()
    expect(notice).to_be_hidden()
    wait_for(page, f"window.__regolith.t > {t0} + 1")
    _expect_live_only_controls(page, enabled=True)
    assert _status(srv, mid) == "running"
    # and the controls answer again: pause through the toolbar
    page.locator("[data-speed='0']").click()
    expect(status).to_have_text("paused")
    assert _status(srv, mid) == "paused"
    with srv.api() as api:
        api.post(f"/missions/{mid}/stop")


def test_history_filter_offers_interrupted_and_stalled(page: Page, own_server: Server) -> None:
    srv = own_server
    live = _start(srv, seed=5, speed=1)
    ended = _start(srv, seed=6, speed=1)
    with srv.api() as api:
        assert api.post(f"/missions/{ended}/stop").status_code == 200
    srv.restart()
    assert _status(srv, live) == "interrupted"

    page.goto(f"{srv.url}/#/missions")
    select = page.locator("#history-filter select[name=status]")
    options = select.locator("option").all_inner_texts()
    assert {"interrupted", "stalled"} <= set(options), options
    expect(page.locator(f'#history tr[data-mission="{ended}"]')).to_be_visible()

    select.select_option("interrupted")
    row = page.locator(f'#history tr[data-mission="{live}"]')
    expect(row).to_be_visible()
    expect(row).to_have_attribute("data-status", "interrupted")
    expect(row.locator(".badge")).to_have_text("interrupted")
    expect(page.locator(f'#history tr[data-mission="{ended}"]')).to_have_count(0)
    for s in page.locator("#history tbody tr[data-mission]").all():
        expect(s).to_have_attribute("data-status", "interrupted")

    # a viewer sees the interrupted mission as such, without a Resume button
    row.get_by_role("link").click()
    expect(page.locator("#live-status")).to_have_text("interrupted")
    expect(page.locator("#live-notice")).to_contain_text("An operator can resume it")
    expect(page.locator("#resume-button")).to_be_hidden()


def test_an_ended_mission_shows_its_recorded_status(
    operator: Page, start_mission: Start, api: Any
) -> None:
    page = operator
    # opened after the end: the stored final state says "running" (the engine never ended
    # by itself), the record says "stopped"
    done = start_mission(seed=8)
    assert api.post(f"/missions/{done['id']}/stop").status_code == 200
    page.goto(f"/#/live/{done['id']}")
    expect(page.locator("#map")).to_have_attribute("data-robot-count", "12")
    expect(page.locator("#live-status")).to_have_text("stopped")
    expect(page.locator("#live-notice")).to_contain_text("Ended (stopped)")
    expect(page.locator("#resume-button")).to_be_hidden()
    _expect_live_only_controls(page, enabled=False)

    # stopped while watched: the last frame arrives after the status message
    mission = start_mission(seed=9)
    page.goto(f"/#/live/{mission['id']}")
    wait_for(page, "window.__regolith && window.__regolith.frames >= 3")
    page.once("dialog", lambda d: d.accept())
    page.locator("#stop-button").click()
    expect(page.locator("#live-status")).to_have_text("stopped")
    record = api.get(f"/missions/{mission['id']}").json()
    assert record["status"] == "stopped"
    # the view settles on the record: its final simulation time and status
    wait_for(page, f"window.__regolith.t === {record['sim_time']!r}")
    assert page.evaluate("window.__regolith.status") == "stopped"
    expect(page.locator("#live-status")).to_have_text("stopped")
    _expect_live_only_controls(page, enabled=False)
