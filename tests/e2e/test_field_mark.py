"""A field run is marked as one on the dashboard: a small "field" mark in the run
history and the live header, no Resume for an interrupted field run, and compare keeps field
runs apart from simulated ones.

A real field mission is twelve agent processes (tests/field, `fleet`); here the stored mark is
set in the server's own database while it is stopped, as migration 0003 stores it.
"""

from __future__ import annotations

import sqlite3
import time
from collections.abc import Iterator
from typing import Any

import pytest
from playwright.sync_api import Page, expect

from tests.e2e.conftest import ConsoleLog, Server, running_server

SMALL = {"name": "field-mark", "width": 40.0, "height": 40.0, "sites": 3}


@pytest.fixture(scope="module")
def own_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    """A server of its own: its stored missions are edited, which no other test should see."""
    yield from running_server(tmp_path_factory, "field-mark")


def _ended(api: Any, mid: int) -> dict[str, Any]:
    for _ in range(600):
        m: dict[str, Any] = api.get(f"/missions/{mid}").json()
        if m["status"] not in ("running", "paused"):
            return m
        time.sleep(0.1)
    raise AssertionError(f"mission {mid} did not finish")


def test_field_runs_are_marked_and_kept_apart(
    operator: Page, own_server: Server, console: ConsoleLog
) -> None:
    page = operator
    body = {"policy": "fcfs", "scenario": SMALL, "planner": "straight"}
    with own_server.api() as api:
        ids = [
            api.post("/missions", json={**body, "seed": s, "speed": "max"}).json()["id"]
            for s in (1, 2)
        ]
        sim, field_done = (_ended(api, i) for i in ids)
        live = api.post("/missions", json={**body, "seed": 3, "paused": True}).json()["id"]
    own_server.stop()  # `live` comes back interrupted; two of the three become field runs
    with sqlite3.connect(own_server.data_dir / "regolith.db") as db:
        db.execute(
            "update missions set mode = 'field' where id in (?, ?)", (field_done["id"], live)
        )
    own_server.restart()

    page.goto(f"{own_server.url}/#/missions")
    row = page.locator(f'#history tr[data-mission="{live}"]')
    expect(row).to_have_attribute("data-mode", "field")
    expect(row.locator(".badge.field")).to_have_text("field")
    expect(page.locator(f'#history tr[data-mission="{sim["id"]}"] .badge.field')).to_have_count(0)
    page.locator("#history-filter select[name=mode]").select_option("field")
    rows = page.locator("#history tbody tr[data-mission]")
    expect(rows).to_have_count(2)
    assert set(rows.evaluate_all("rs => rs.map(r => r.dataset.mode)")) == {"field"}

    page.goto(f"{own_server.url}/#/live/{live}")
    expect(page.locator("#live-status")).to_have_text("interrupted")
    expect(page.locator("#live-field")).to_be_visible()
    expect(page.locator("#resume-button")).to_be_hidden()
    expect(page.locator("#live-notice")).to_contain_text("cannot be resumed")
    page.goto(f"{own_server.url}/#/live/{sim['id']}")  # a simulated run: no mark
    expect(page.locator("#live-status")).to_have_text("completed")
    expect(page.locator("#live-field")).to_be_hidden()

    page.goto(f"{own_server.url}/#/compare")
    key = f"field-mark#{sim['scenario_hash']}"
    scenario = page.locator("#compare-scenario")
    expect(scenario.locator(f'option[value="{key}#field"]')).to_contain_text("field")
    for value, mid in ((key, sim["id"]), (f"{key}#field", field_done["id"])):
        scenario.select_option(value)
        rows = page.locator("#compare-table tbody tr[data-mission]")
        expect(rows).to_have_count(1)  # never pooled with the other mode
        expect(rows).to_have_attribute("data-mission", str(mid))
    assert not console.errors, console.errors
