"""Energy on, in the dashboard: every robot's battery bar on the map is drawn at the level its
streamed charge says, and the robot list's charge column shows the same charge."""

from __future__ import annotations

import re
from pathlib import Path

import httpx
from playwright.sync_api import Page, expect

from engine import load_scenario
from tests.e2e.conftest import ConsoleLog, Server, painted
from tests.e2e.test_dashboard import WORK, Start, wait_for
from tests.e2e.test_live_deltas import _snapshot

ENERGY = Path(__file__).resolve().parents[2] / "scenarios" / "realism" / "energy.toml"
LOW, CRITICAL = 0.5, 0.2  # frontend/js/maprobots.js


def _level(charge: float) -> str:
    return "critical" if charge < CRITICAL else "low" if charge < LOW else "ok"


def test_battery_bars_and_the_charge_column_show_the_streamed_charge(
    operator: Page, start_mission: Start, api: httpx.Client, server: Server, console: ConsoleLog
) -> None:
    page = operator
    scenario = load_scenario(ENERGY).model_dump(mode="json")
    mission = start_mission(seed=3, speed=200, planner="straight", scenario=scenario)
    mid = mission["id"]
    page.goto(f"/#/live/{mid}")
    expect(page.locator("#map")).to_have_attribute("data-robot-count", "12")
    # run until some battery is below half (the batteries are small: minutes of work)
    wait_for(
        page,
        "window.__regolith.stream.robots.some((r) => r.charge != null && r.charge < 0.5)",
        60,
        WORK,
    )
    api.post(f"/missions/{mid}/pause").raise_for_status()
    expect(page.locator("#live-status")).to_have_text("paused")
    snap = _snapshot(server, mid)
    wait_for(page, f"window.__regolith.stream.seq === {snap['seq']}")
    painted(page)  # the next animation frame draws the paused state
    robots = page.evaluate("window.__regolith.stream.robots")
    up = [r for r in robots if r["alive"] and r["state"] not in ("failed", "disabled")]
    assert all(r["charge"] is not None for r in robots)
    want = {"ok": 0, "low": 0, "critical": 0}
    for r in up:
        want[_level(r["charge"])] += 1
    assert want["low"] + want["critical"] > 0
    assert page.evaluate("window.__regolith.drawn.batteries") == want
    # the robot list's charge column: the same charge, in whole percent (within one: the
    # stream carries charge to the percent, the robot list's poll in full)
    expect(page.locator("#robot-table")).to_have_class(re.compile(r"\bwith-charge\b"))
    for r in robots:
        page.wait_for_function(
            """([name, want]) => {
                const td = document.querySelector(
                    `#robot-table tr[data-robot="${name}"] td.charge`);
                return td && /^\\d+%$/.test(td.textContent)
                    && Math.abs(parseInt(td.textContent) - want) <= 1;
            }""",
            arg=[r["name"], r["charge"] * 100],
        )
    assert console.errors == []
