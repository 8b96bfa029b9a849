"""The dashboard on a delta stream at scale: a 120-robot mission's map, robot list
and counters show exactly the stream's state (a fresh snapshot taken beside it agrees), the
virtualized robot list renders only rows in view yet reaches every robot, and the stream
ends at the stored state."""

from __future__ import annotations

import json
from typing import Any

import httpx
from playwright.sync_api import Page, expect
from websockets.sync.client import connect

from app.live.frames import DIGITS
from engine import reference_scenario
from tests.e2e.conftest import ConsoleLog, Server
from tests.e2e.test_dashboard import Start, wait_for

FIELDS = ("name", "type", "state", "x", "y", "heading", "load", "alive")


def _snapshot(server: Server, mission_id: int) -> dict[str, Any]:
    """A second viewer's snapshot: joining brings the stream up to date for every viewer."""
    url = f"ws://127.0.0.1:{server.port}/api/missions/{mission_id}/live"
    with connect(url, max_size=2**24) as ws:
        snap: dict[str, Any] = json.loads(ws.recv(timeout=30))
    return snap


def _robots(state: dict[str, Any]) -> dict[str, tuple[Any, ...]]:
    return {r["name"]: tuple(r[k] for k in FIELDS) for r in state["robots"]}


def _at_stream_precision(state: dict[str, Any]) -> dict[str, tuple[Any, ...]]:
    """Poses as the stream rounds them (1 cm, 1 mrad). While no frame flows (a paused
    mission), the page takes poses from its poll of the robot list (`_poseFromDetail`), which
    the REST answer gives unrounded: equal at the stream's precision is what a viewer sees."""
    return {
        r["name"]: tuple(round(r[k], DIGITS[k]) if k in DIGITS else r[k] for k in FIELDS)
        for r in state["robots"]
    }


def test_a_scaled_mission_on_deltas_shows_the_streamed_state_and_its_stored_end(
    operator: Page, start_mission: Start, api: httpx.Client, server: Server, console: ConsoleLog
) -> None:
    page = operator
    scenario = reference_scenario().scaled(10).model_dump(mode="json")
    mission = start_mission(seed=2, speed=60, planner="straight", scenario=scenario)
    mid = mission["id"]
    page.goto(f"/#/live/{mid}")
    expect(page.locator("#map")).to_have_attribute("data-robot-count", "120")
    wait_for(page, "window.__regolith.frames >= 30", 60, "window.__regolith.frames")
    api.post(f"/missions/{mid}/pause").raise_for_status()
    expect(page.locator("#live-status")).to_have_text("paused")
    snap = _snapshot(server, mid)  # its join sends the page the last delta up to `seq`
    wait_for(page, f"window.__regolith.stream.seq === {snap['seq']}")
    stream = page.evaluate("window.__regolith.stream")
    assert _at_stream_precision(stream) == _at_stream_precision(snap["state"])
    assert stream["t"] == snap["state"]["t"] and stream["counters"] == snap["state"]["counters"]
    # the view (map and lists) shows the stream's state (or the polled list's, once frames
    # stop: the same poses, unrounded)
    shown = page.evaluate("window.__regolith.robots")
    assert _at_stream_precision({"robots": shown}) == _at_stream_precision(stream)
    drawn = page.evaluate("window.__regolith.drawn")
    assert sorted(drawn["order"]) == sorted(_robots(stream)) and drawn["batches"] <= 12
    counters = page.evaluate("window.__regolith.lastCounters")
    assert counters == stream["counters"]
    # the robot list is virtualized: only rows in view, each with the stream's state ...
    rows = page.locator("#robot-table tbody tr[data-robot]")
    assert 0 < rows.count() < 60
    states = {n: s[2] for n, s in _robots(stream).items()}
    for row in rows.all():
        assert row.get_attribute("data-state") == states[row.get_attribute("data-robot") or ""]
    # ... and scrolling reaches the last robot
    page.locator(".robots-wrap").evaluate("el => el.scrollTo(0, el.scrollHeight)")
    expect(page.locator('#robot-table tr[data-robot="hauler-60"]')).to_be_visible()
    # on again at max, then stopped: the stream's last state is the stored one (to 1 cm),
    # and the view shows the stored one exactly
    api.put(f"/missions/{mid}/speed", json={"speed": "max"}).raise_for_status()
    api.post(f"/missions/{mid}/resume").raise_for_status()
    before = page.evaluate("window.__regolith.stream.seq")
    wait_for(page, f"window.__regolith.stream.seq > {before + 10}", 60, "window.__regolith.t")
    api.post(f"/missions/{mid}/stop").raise_for_status()
    expect(page.locator("#live-status")).to_have_text("stopped")
    wait_for(page, "window.__regolith.final === true")
    stored = {r["name"]: r for r in api.get(f"/missions/{mid}/robots").json()}
    end = page.evaluate("window.__regolith.stream")
    assert end["status"] == api.get(f"/missions/{mid}").json()["status"]
    for r in end["robots"]:
        s = stored[r["name"]]
        assert (r["state"], r["load"], r["alive"]) == (s["state"], s["load"], s["alive"])
        assert abs(r["x"] - s["x"]) <= 0.005 + 1e-9 and abs(r["y"] - s["y"]) <= 0.005 + 1e-9
    shown = {r["name"]: r for r in page.evaluate("window.__regolith.robots")}
    assert {n: (r["x"], r["y"], r["state"]) for n, r in shown.items()} == {
        n: (s["x"], s["y"], s["state"]) for n, s in stored.items()
    }
    assert console.errors == []
