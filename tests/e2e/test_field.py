"""A field mission (every robot its own process over Zenoh) on the dashboard, like a simulated
one: twelve robots on the map moving, counters rising, an operator SIGKILL shown as a failed
robot, and, once it completes, its auctions stored in the same tables (docs/field.md)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import httpx
from playwright.sync_api import Page, expect

from tests.e2e.conftest import ConsoleLog, Server
from tests.e2e.test_dashboard import Start, open_live, wait_for
from tests.field.serial import one_field_mission_at_a_time


def test_field_mission_on_the_dashboard(
    page: Page, console: ConsoleLog, start_mission: Start, api: httpx.Client, server: Server
) -> None:
    with one_field_mission_at_a_time():
        _field_mission_on_the_dashboard(page, console, start_mission, api, server)


def _field_mission_on_the_dashboard(
    page: Page, console: ConsoleLog, start_mission: Start, api: httpx.Client, server: Server
) -> None:
    mission = start_mission(policy="nearest", seed=0, speed=50, field=True)
    mid = mission["id"]
    open_live(page, mid)
    expect(page.locator("#map")).to_have_attribute("data-robot-count", "12")
    first = {r["name"]: (r["x"], r["y"]) for r in page.evaluate("window.__regolith.robots")}
    wait_for(page, "window.__regolith.lastCounters.minerals_delivered >= 3", timeout=60)
    now = {r["name"]: (r["x"], r["y"]) for r in page.evaluate("window.__regolith.robots")}
    assert sum(now[n] != first[n] for n in first) >= 6  # the robots move on the map

    res = api.post(f"/missions/{mid}/robots/hauler-3/disable", json={"mode": "abrupt"})
    assert res.status_code == 200, res.text
    wait_for(
        page,
        "window.__regolith.robots.some(r => r.name === 'hauler-3' && r.alive === false)",
        timeout=30,
    )
    wait_for(page, "window.__regolith.auctions.length >= 10", timeout=30)
    assert console.errors == []

    assert api.post(f"/missions/{mid}/stop").status_code in (200, 204, 409)
    wait_for(page, "window.__regolith.status !== 'running'", timeout=30)
    # what mission control recorded is in the same tables as a simulated mission's
    auctions = api.get(f"/missions/{mid}/auctions", params={"limit": 500}).json()
    items = auctions["items"] if isinstance(auctions, dict) else auctions
    assert len(items) >= 10 and all(a["policy"] == "nearest" for a in items)
    assert any(a["allocated_to"] and a["allocated_to"].startswith("hauler-") for a in items)
    events = api.get(f"/missions/{mid}/events", params={"kind": "delivered"}).json()
    assert events["items"] if isinstance(events, dict) else events
    # the agents' processes are gone once the mission has ended
    deadline = time.monotonic() + 15
    assert server.proc is not None
    while _agents(server.proc.pid):
        assert time.monotonic() < deadline, f"agents left running: {_agents(server.proc.pid)}"
        time.sleep(0.2)


def _agents(parent: int) -> list[int]:
    """Agent processes the server started that are still running (not zombies)."""
    out = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes()
            stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if b"app.cli\x00agent" in cmd and int(stat[1]) == parent and stat[0] != "Z":
            out.append(int(pid))
    return out
