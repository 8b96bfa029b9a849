"""Playback in the browser: scrub a finished mission with operator actions to a time; the map,
the robot table, the counters and the feed show that moment, as the stored events and the
API's `/state` say."""

from __future__ import annotations

from typing import Any

import httpx
from playwright.sync_api import Page, expect

from tests.e2e.conftest import ARTIFACTS, ConsoleLog
from tests.e2e.test_dashboard import wait_for
from tests.progress import wait_progress


def _until(api: httpx.Client, mid: int, done: Any) -> dict[str, Any]:
    """Poll the mission until `done`, as long as its simulated time moves (tests/progress.py)."""
    seen: dict[str, Any] = {}

    def probe() -> dict[str, Any] | None:
        m: dict[str, Any] = api.get(f"/missions/{mid}").json()
        seen.update(m)
        return m if done(m) else None

    return wait_progress(probe, lambda: (seen.get("status"), seen.get("sim_time")), str(done))


def _events(api: httpx.Client, mid: int, kind: str) -> list[dict[str, Any]]:
    page = api.get(f"/missions/{mid}/events", params={"kind": kind, "limit": 1000}).json()
    assert page["next_after"] is None
    items: list[dict[str, Any]] = page["items"]
    return items


def test_scrub_a_finished_mission(page: Page, console: ConsoleLog, api: httpx.Client) -> None:
    mid = api.post("/missions", json={"seed": 4, "speed": 300}).json()["id"]
    base = f"/missions/{mid}"
    _until(api, mid, lambda m: m["sim_time"] > 150)
    api.post(f"{base}/robots/hauler-1/disable", json={"mode": "abrupt"}).raise_for_status()
    _until(api, mid, lambda m: m["sim_time"] > 400)
    api.put(f"{base}/policy", json={"policy": "coalition"}).raise_for_status()
    api.post(f"{base}/robots", json={"type": "hauler"}).raise_for_status()
    api.put(f"{base}/speed", json={"speed": "max"}).raise_for_status()
    end = _until(api, mid, lambda m: m["status"] == "completed")["sim_time"]
    actions = [a for a in api.get(f"{base}/actions").json() if a["replay"]]
    failed_at, switched_at = actions[0]["t"], actions[1]["t"]
    t = round((failed_at + switched_at) / 2, 3)  # hauler-1 down, no new robot yet, Policy 1
    sites = _events(api, mid, "site_found")
    delivered = [e for e in _events(api, mid, "delivered") if e["t"] <= t]
    added = _events(api, mid, "robot_added")[0]["data"]["robot"]

    page.goto(f"/#/live/{mid}")
    timeline = page.locator("#timeline")
    expect(timeline).to_have_attribute("data-end", str(end))
    expect(timeline).to_have_attribute("data-markers", str(len(sites) + 5))
    for kind, n in [("failure", 1), ("operator", 3), ("policy", 1), ("site", len(sites))]:
        expect(page.locator(f".tl-mark[data-kind={kind}]")).to_have_count(n)

    page.locator("#tl-range").fill(str(t))
    wait_for(page, f"Number(document.querySelector('#timeline').dataset.shownT) === {t}")
    expect(timeline).to_have_attribute("data-mode", "back")
    state = api.get(f"{base}/state", params={"t": t}).json()
    assert state["t"] == t
    drawn = {r["name"]: (r["x"], r["y"], r["state"]) for r in page.evaluate("__regolith.robots")}
    assert drawn == {r["name"]: (r["x"], r["y"], r["state"]) for r in state["state"]["robots"]}
    assert drawn["hauler-1"][2] == "failed" and added not in drawn
    expect(page.locator("tr[data-robot='hauler-1']")).to_have_attribute("data-state", "failed")
    expect(page.locator(f"tr[data-robot='{added}']")).to_have_count(0)
    found = sum(1 for e in sites if e["t"] <= t)
    expect(page.locator("[data-counter=sites]")).to_have_text(f"{found}/{len(sites)}")
    minerals = delivered[-1]["data"]["delivered"] if delivered else 0
    total = state["state"]["counters"]["minerals_total"]
    expect(page.locator("[data-counter=minerals]")).to_have_text(f"{minerals}/{total}")
    assert page.evaluate("__regolith.lastCounters") == state["state"]["counters"]
    feed = {a["id"] for a in page.evaluate("__regolith.auctions")}
    assert feed == {a["id"] for a in state["auctions"]}
    assert all(a["opened_at"] <= t for a in state["auctions"])
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "playback-scrubbed.png"))

    page.locator("#tl-latest").click()  # back to the final state
    expect(timeline).to_have_attribute("data-mode", "latest")
    final = {r["name"]: (r["x"], r["y"]) for r in api.get(f"{base}/robots").json()}
    wait_for(page, "__regolith.frames >= 1 && __regolith.robots.length > 12")
    assert {r["name"]: (r["x"], r["y"]) for r in page.evaluate("__regolith.robots")} == final
    assert not console.errors, console.errors


def test_look_back_at_a_live_mission(page: Page, api: httpx.Client, start_mission: Any) -> None:
    """The stream and the robot poll go on while the view looks back; they do not move it."""
    mid = start_mission(seed=6, speed=20)["id"]
    page.goto(f"/#/live/{mid}")
    wait_for(page, "__regolith.frames >= 5 && __regolith.t > 30")
    page.locator("#tl-range").fill("12.5")
    wait_for(page, "Number(document.querySelector('#timeline').dataset.shownT) === 12.5")
    state = api.get(f"/missions/{mid}/state", params={"t": 12.5}).json()["state"]
    pose = {r["name"]: (r["x"], r["y"], r["state"]) for r in state["robots"]}
    frames = page.evaluate("__regolith.frames")
    page.wait_for_timeout(2500)  # frames at 10 Hz and two robot polls would have moved it
    assert page.evaluate("__regolith.frames") == frames and page.evaluate("__regolith.t") == 12.5
    drawn = {r["name"]: (r["x"], r["y"], r["state"]) for r in page.evaluate("__regolith.robots")}
    assert drawn == pose
    end = float(page.locator("#timeline").get_attribute("data-end") or 0)
    assert end > 30  # the timeline's end still follows the live mission
    expect(page.locator("#inject-open")).to_be_hidden()
    page.locator("#tl-latest").click()
    expect(page.locator("#timeline")).to_have_attribute("data-mode", "latest")
    wait_for(page, f"__regolith.t > {end}")
    expect(page.locator("#live-status")).to_have_attribute("data-status", "running")
